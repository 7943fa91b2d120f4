# `pip install` of the source tree into a fresh virtual environment, then the installed package
# used from outside the source tree (check_installed.py): the first scans of a 2D log mapped by
# map_recording() and the first keyframes of a 3D drive by map_recording(), each also by
# `python -m potmap mapping` (the same maps and scores).
# Run by CTest as `cmake -P` with SOURCE_DIR, BUILD_DIR, WORK_DIR, PYTHON, LOG and DRIVE.
#
# The venv sees Debian's packages (--system-site-packages: NumPy, setuptools, wheel), so pip
# works offline (--no-index, --no-build-isolation). POTMAP_CMAKE_BUILD_DIR points setup.py at
# this build, already compiled: the test packs it rather than compiling potmap a second time
# (minutes on CI's two cores); `pip install .` without it configures and builds its own.
cmake_minimum_required(VERSION 3.20)

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  set(run_output "${out}" PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${WORK_DIR}")
set(venv "${WORK_DIR}/venv")
run("${PYTHON}" -m venv --system-site-packages "${venv}")
run(${CMAKE_COMMAND} -E env "POTMAP_CMAKE_BUILD_DIR=${BUILD_DIR}"
    "${venv}/bin/python" -m pip install --no-index --no-build-isolation --no-cache-dir
    --disable-pip-version-check "${SOURCE_DIR}")
file(GLOB module "${venv}/lib/python*/site-packages/potmap/_potmap*.so")
if(NOT module)
  message(FATAL_ERROR "pip installed no compiled module under ${venv}/lib/python*/site-packages/potmap")
endif()

execute_process(
  COMMAND "${venv}/bin/python" "${CMAKE_CURRENT_LIST_DIR}/check_installed.py" "${venv}" --script
          --log "${LOG}" --drive "${DRIVE}" --out "${WORK_DIR}/out"
  WORKING_DIRECTORY "${WORK_DIR}"  # not the build tree, which holds a potmap/ too
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the pip-installed package failed its checks:\n${out}\n${err}")
endif()
message(STATUS "pip-installed potmap: ${out}")
