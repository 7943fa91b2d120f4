# Installs the built potmap into a fresh prefix, checks the installed package files carry no
# path of the build machine, runs the installed command on the prefix's libpotmap (its help, and a
# real job: EXAMPLE_MAP scored on EXAMPLE_TEST, the same scores as the build tree's command), then builds and runs a consumer twice: with
# find_package(potmap) and with pkg-config; then the C embedding example (EXAMPLE_DIR) the same
# two ways, running it on EXAMPLE_MAP (if that file exists) and on its own small map, and its
# mapper program on EXAMPLE_LOG (a real log streamed through the C mapper); last, the installed
# Python package is imported from the prefix (PYTHONPATH) and runs the command. Run by CTest as
# `cmake -P` with:
#   BUILD_DIR, SOURCE_DIR (potmap's), CONSUMER_DIR, WORK_DIR, CXX and CC (compilers), GENERATOR,
#   EXAMPLE_DIR, EXAMPLE_MAP, EXAMPLE_TEST, EXAMPLE_LOG, BUILD_COMMAND (the build tree's
#   potmap command; empty when it is not built)
#   and, when the Python package is built: PYTHON, PY_DIR (its folder, relative to the prefix),
#   PY_CHECK (python/tests/check_installed.py), INSTALL_PREFIX (the configured prefix)
cmake_minimum_required(VERSION 3.20)

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  set(run_output "${out}" PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE "${WORK_DIR}")
set(prefix "${WORK_DIR}/prefix")
run(${CMAKE_COMMAND} --install "${BUILD_DIR}" --prefix "${prefix}")

# Relocatable package: no absolute path of the source or build tree in the package files.
file(GLOB_RECURSE package_files "${prefix}/*.cmake" "${prefix}/*.pc" "${prefix}/include/*")
if(NOT package_files)
  message(FATAL_ERROR "nothing installed under ${prefix}")
endif()
foreach(f IN LISTS package_files)
  file(READ "${f}" text)
  foreach(p IN ITEMS "${SOURCE_DIR}" "${BUILD_DIR}" "${prefix}")
    string(FIND "${text}" "${p}" at)
    if(NOT at EQUAL -1)
      message(FATAL_ERROR "${f} contains the build machine's path ${p}")
    endif()
  endforeach()
endforeach()

# 0. The command, installed: it finds the prefix's libpotmap by its run path, from any prefix and
#    without LD_LIBRARY_PATH.
if(BUILD_COMMAND)
  set(potmap "${prefix}/bin/potmap")
  set(bare ${CMAKE_COMMAND} -E env --unset=LD_LIBRARY_PATH)
  run(${bare} "${potmap}" --help)
  if(NOT run_output MATCHES "mapping")
    message(FATAL_ERROR "${potmap} --help does not list `mapping`:\n${run_output}")
  endif()
  run(${bare} ldd "${potmap}")
  string(REGEX MATCH "libpotmap\\.so\\.[0-9]+ => [^ ]+" found "${run_output}")
  string(FIND "${found}" "=> ${prefix}/" at)
  if(NOT at GREATER 0)
    message(FATAL_ERROR "${potmap} does not load the prefix's libpotmap:\n${run_output}")
  endif()
  # A real job (device, map and CSV readers): the town's map scored on its test points, as the
  # build tree's command scores it.
  foreach(which installed built)
    if(which STREQUAL "installed")
      run(${bare} "${potmap}" eval --map "${EXAMPLE_MAP}" --test "${EXAMPLE_TEST}" --json -)
    else()
      run("${BUILD_COMMAND}" eval --map "${EXAMPLE_MAP}" --test "${EXAMPLE_TEST}" --json -)
    endif()
    foreach(key auc nll n kernels)
      string(JSON ${which}_${key} GET "${run_output}" ${key})
    endforeach()
  endforeach()
  foreach(key auc nll n kernels)
    if(NOT installed_${key} STREQUAL built_${key})
      message(FATAL_ERROR "installed potmap eval: ${key} ${installed_${key}}, the build's "
                          "command: ${built_${key}}")
    endif()
  endforeach()
  message(STATUS "installed potmap eval: AUC ${installed_auc}, NLL ${installed_nll} on "
                 "${installed_n} points, as the build's command")
endif()

# 1. CMake package.
run(${CMAKE_COMMAND} -S "${CONSUMER_DIR}" -B "${WORK_DIR}/cmake-consumer" -G "${GENERATOR}"
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_CXX_COMPILER=${CXX} -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build "${WORK_DIR}/cmake-consumer")
run("${WORK_DIR}/cmake-consumer/app")
message(STATUS "find_package consumer: ${run_output}")

# 2. pkg-config.
find_program(PKG_CONFIG pkg-config REQUIRED)
file(GLOB pc_dirs "${prefix}/lib*/pkgconfig" "${prefix}/lib/*/pkgconfig")
string(REPLACE ";" ":" pc_path "${pc_dirs}")
set(ENV{PKG_CONFIG_PATH} "${pc_path}")
run(${PKG_CONFIG} --cflags --libs potmap)
string(STRIP "${run_output}" flags)
separate_arguments(flags UNIX_COMMAND "${flags}")
run(${CXX} -std=c++17 "${CONSUMER_DIR}/main.cpp" ${flags} -o "${WORK_DIR}/pc-app")
# pkg-config gives no run path: point the loader at the prefix.
set(libdirs "")
foreach(fl IN LISTS flags)
  if(fl MATCHES "^-L(.*)")
    list(APPEND libdirs "${CMAKE_MATCH_1}")
  endif()
endforeach()
string(REPLACE ";" ":" libpath "${libdirs}")
run(${CMAKE_COMMAND} -E env "LD_LIBRARY_PATH=${libpath}" "${WORK_DIR}/pc-app")
message(STATUS "pkg-config consumer: ${run_output}")

# 3. The C embedding example, find_package(potmap): on the real map when there is one.
run(${CMAKE_COMMAND} -S "${EXAMPLE_DIR}" -B "${WORK_DIR}/cmake-example" -G "${GENERATOR}"
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_C_COMPILER=${CC} -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build "${WORK_DIR}/cmake-example")
set(example_args "-")
if(EXISTS "${EXAMPLE_MAP}")
  set(example_args "${EXAMPLE_MAP}")
endif()
run("${WORK_DIR}/cmake-example/embed_c" ${example_args} "${WORK_DIR}/example-results.csv")
message(STATUS "embed_c (find_package): ${run_output}")
file(STRINGS "${WORK_DIR}/example-results.csv" rows)
list(LENGTH rows nrows)
if(NOT nrows EQUAL 4097)  # header + 64 x 64 points
  message(FATAL_ERROR "embed_c wrote ${nrows} lines, expected 4097")
endif()

# 3b. The mapper example (map_log.c) on the first scans of a real log: dictionary from scans
#     0-9, the next 20 mapped by RePOT; it exits 1 if the overall map misclassifies its own
#     scans' end points or free space.
if(NOT EXISTS "${EXAMPLE_LOG}")
  message(FATAL_ERROR "EXAMPLE_LOG ${EXAMPLE_LOG} not found (../shared/data)")
endif()
run("${WORK_DIR}/cmake-example/embed_map_log" "${EXAMPLE_LOG}" "${WORK_DIR}/example-overall.potmap"
    10 20)
message(STATUS "embed_map_log (find_package): ${run_output}")
foreach(f IN ITEMS example-overall.potmap example-overall.potdict)
  if(NOT EXISTS "${WORK_DIR}/${f}")
    message(FATAL_ERROR "embed_map_log did not write ${f}")
  endif()
endforeach()

# 4. The same example with pkg-config and the C compiler alone, on its own small map.
run(${PKG_CONFIG} --cflags --libs potmap)
string(STRIP "${run_output}" flags)
separate_arguments(flags UNIX_COMMAND "${flags}")
run(${CC} -std=c99 -Wall -Werror "${EXAMPLE_DIR}/embed.c" ${flags} -lm -o "${WORK_DIR}/pc-embed")
run(${CMAKE_COMMAND} -E env "LD_LIBRARY_PATH=${libpath}" "${WORK_DIR}/pc-embed" -
    "${WORK_DIR}/pc-results.csv")
message(STATUS "embed_c (pkg-config): ${run_output}")

# 5. The Python package, imported from the prefix by the interpreter it was built for: the
#    module loads the prefix's libpotmap (its run path) and `python -m potmap` runs the prefix's
#    command (check_installed.py).
if(PY_DIR)
  set(check_args "")
  if(NOT BUILD_COMMAND)
    set(check_args --no-command)
  endif()
  execute_process(COMMAND ${CMAKE_COMMAND} -E env --unset=LD_LIBRARY_PATH
                          "PYTHONPATH=${prefix}/${PY_DIR}" "${PYTHON}" "${PY_CHECK}" "${prefix}"
                          ${check_args}
                  WORKING_DIRECTORY "${WORK_DIR}"  # not the build tree, which holds a potmap/ too
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "importing the installed Python package failed:\n${out}\n${err}")
  endif()
  message(STATUS "installed Python package: ${out}")
  # Without PYTHONPATH the interpreter must look where a real install puts the package.
  # (No `;` in the code: run() passes its arguments on as a CMake list.)
  run("${PYTHON}" -c "import site, sys\nprint(sys.argv[1] in site.getsitepackages())"
      "${INSTALL_PREFIX}/${PY_DIR}")
  string(STRIP "${run_output}" found)
  if(NOT found STREQUAL "True")
    message(FATAL_ERROR "${PYTHON} does not search ${INSTALL_PREFIX}/${PY_DIR}: set POTMAP_PYTHON_INSTALL_DIR")
  endif()
endif()
