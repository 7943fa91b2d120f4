# Installs the build into a fresh prefix and imports the installed package with the system
# Python: the module must load the installed libpotmap (its RPATH), not the build tree's, and
# the configured install folder must be one the interpreter searches on its own. Run by CTest
# as `cmake -P` with BUILD_DIR, WORK_DIR, PYTHON, PY_DIR (relative to the prefix) and
# INSTALL_PREFIX (the configured prefix).
cmake_minimum_required(VERSION 3.20)

file(REMOVE_RECURSE "${WORK_DIR}")
set(prefix "${WORK_DIR}/prefix")
execute_process(COMMAND ${CMAKE_COMMAND} --install "${BUILD_DIR}" --prefix "${prefix}"
                RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "install failed: ${err}")
endif()
file(GLOB module "${prefix}/${PY_DIR}/potmap/_potmap*.so")
if(NOT module)
  message(FATAL_ERROR "no compiled module under ${prefix}/${PY_DIR}/potmap")
endif()
foreach(f __init__.py __init__.pyi py.typed)
  if(NOT EXISTS "${prefix}/${PY_DIR}/potmap/${f}")
    message(FATAL_ERROR "${f} not installed into ${prefix}/${PY_DIR}/potmap")
  endif()
endforeach()

set(check [=[
import sys
import potmap
prefix = sys.argv[1]
assert potmap.__file__.startswith(prefix), potmap.__file__
libs = [l.split()[-1] for l in open("/proc/self/maps") if "libpotmap" in l]
assert libs and all(l.startswith(prefix) for l in libs), libs
s = potmap.synthetic_scene(test_points=200)
v = s.map.evaluate_exact(s.test.positions)
print("installed potmap", potmap.__version__, "AUC", round(potmap.score(v.prob, s.test.labels).auc, 3))
]=])
execute_process(COMMAND ${CMAKE_COMMAND} -E env "PYTHONPATH=${prefix}/${PY_DIR}"
                        "${PYTHON}" -c "${check}" "${prefix}"
                WORKING_DIRECTORY "${WORK_DIR}"  # not the build tree, which holds a potmap/ too
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "importing the installed package failed:\n${out}\n${err}")
endif()
message(STATUS "${out}")

# Without PYTHONPATH the system Python must look where a real install puts the package.
execute_process(COMMAND "${PYTHON}" -c "import site, sys; print(sys.argv[1] in site.getsitepackages())"
                        "${INSTALL_PREFIX}/${PY_DIR}"
                OUTPUT_VARIABLE found OUTPUT_STRIP_TRAILING_WHITESPACE)
if(NOT found STREQUAL "True")
  message(FATAL_ERROR "${PYTHON} does not search ${INSTALL_PREFIX}/${PY_DIR}: set POTMAP_PYTHON_INSTALL_DIR")
endif()
