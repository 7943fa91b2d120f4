# Installs the built potmap into a fresh prefix, checks the installed package files carry no
# path of the build machine, then builds and runs a consumer twice: with find_package(potmap)
# and with pkg-config; then the C embedding example (EXAMPLE_DIR) the same two ways, running it
# on EXAMPLE_MAP (if that file exists) and on its own small map, and its mapper program on
# EXAMPLE_LOG (a real log streamed through the C mapper). Run by CTest as `cmake -P` with:
#   BUILD_DIR, SOURCE_DIR (potmap's), CONSUMER_DIR, WORK_DIR, CXX and CC (compilers), GENERATOR,
#   EXAMPLE_DIR, EXAMPLE_MAP, EXAMPLE_LOG
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
