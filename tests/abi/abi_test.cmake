# Checks what the shared library exports (run by CTest as `cmake -P` with LIBRARY, the built
# libpotmap.so, and SOURCE_DIR):
#   - its SONAME is libpotmap.so.<major>;
#   - it does not need OctoMap (only the experiments library, potmap::experiments, does);
#   - with GDAL_MODULE (the path of libpotmap_gdal.so) it does not need GDAL, which that module,
#     next to it, holds, with its entry points exported;
#   - every function potmap.h declares is exported;
#   - nothing of host/'s namespaces (potmap::detail, ::npy, ::npz, ::data) is;
#   - every strong symbol it defines is potmap's (C API or namespace potmap);
#   - every public C++ header wraps its namespace in POTMAP_CXX_API_BEGIN/END (else its
#     functions would be hidden: consumers would fail to link).
cmake_minimum_required(VERSION 3.20)
find_program(NM nm REQUIRED)
find_program(READELF readelf REQUIRED)

execute_process(COMMAND ${READELF} -d "${LIBRARY}" OUTPUT_VARIABLE dyn RESULT_VARIABLE rc)
if(NOT rc EQUAL 0 OR NOT dyn MATCHES "SONAME\\)[^\n]*\\[libpotmap\\.so\\.[0-9]+\\]")
  message(FATAL_ERROR "no SONAME libpotmap.so.<major> in ${LIBRARY}:\n${dyn}")
endif()
if(dyn MATCHES "NEEDED\\)[^\n]*\\[lib(octomap|octomath)")
  message(FATAL_ERROR "${LIBRARY} needs OctoMap (only the experiments should):\n${dyn}")
endif()
if(GDAL_MODULE)
  if(dyn MATCHES "NEEDED\\)[^\n]*\\[libgdal")
    message(FATAL_ERROR "${LIBRARY} needs GDAL (its module ${GDAL_MODULE} should hold it):\n${dyn}")
  endif()
  get_filename_component(lib_dir "${LIBRARY}" DIRECTORY)
  get_filename_component(module_dir "${GDAL_MODULE}" DIRECTORY)
  if(NOT lib_dir STREQUAL module_dir)
    message(FATAL_ERROR "${GDAL_MODULE} is not beside ${LIBRARY}: the loader looks there")
  endif()
  execute_process(COMMAND ${NM} -D --defined-only "${GDAL_MODULE}" OUTPUT_VARIABLE msyms)
  foreach(fn potmap_gdal_write_cog potmap_gdal_read_geotiff_band potmap_gdal_check_crs)
    if(NOT msyms MATCHES "T ${fn}\n")
      message(FATAL_ERROR "${GDAL_MODULE} does not export ${fn}")
    endif()
  endforeach()
endif()

execute_process(COMMAND ${NM} -D -C --defined-only "${LIBRARY}" OUTPUT_VARIABLE syms RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "nm failed on ${LIBRARY}")
endif()
string(REPLACE "\n" ";" lines "${syms}")

file(READ "${SOURCE_DIR}/include/potmap/potmap.h" header)
string(REGEX MATCHALL "POTMAP_EXPORT[^(;]* (potmap_[a-z_0-9]+)\\(" decls "${header}")
list(LENGTH decls ndecls)
if(ndecls LESS 20)
  message(FATAL_ERROR "found only ${ndecls} functions in potmap.h: the pattern is out of date")
endif()
foreach(d IN LISTS decls)
  string(REGEX REPLACE ".* (potmap_[a-z_0-9]+)\\($" "\\1" fn "${d}")
  if(NOT syms MATCHES "\n[0-9a-f]+ T ${fn}\n")
    message(FATAL_ERROR "C API function ${fn} is not exported")
  endif()
endforeach()

set(strong 0)
foreach(line IN LISTS lines)
  if(line MATCHES "potmap::(detail|npy|npz|data)::")
    message(FATAL_ERROR "internal symbol exported: ${line}")
  endif()
  if(line MATCHES "^[0-9a-f]+ [TDBR] (.*)$")
    math(EXPR strong "${strong} + 1")
    set(name "${CMAKE_MATCH_1}")
    # _edata, _end, __bss_start: section markers the linker defines in some links (here once
    # GDAL is linked), not code of anyone's.
    if(NOT name MATCHES "^(potmap_|potmap::|typeinfo (name )?for potmap::|vtable for potmap::|_init$|_fini$|_edata$|_end$|__bss_start$)"
       AND NOT name MATCHES "^[a-zA-Z_:<>, *&]*potmap::[A-Za-z]+::?")
      message(FATAL_ERROR "a symbol that is not potmap's is exported: ${line}")
    endif()
  endif()
endforeach()

file(GLOB headers "${SOURCE_DIR}/include/potmap/*.hpp")
foreach(h IN LISTS headers)
  file(READ "${h}" text)
  string(REGEX MATCHALL "\nnamespace potmap[ a-z:]*{" opens "${text}")
  string(REGEX MATCHALL "\nPOTMAP_CXX_API_BEGIN\nnamespace potmap" wrapped "${text}")
  list(LENGTH opens nopen)
  list(LENGTH wrapped nwrapped)
  if(NOT nopen EQUAL nwrapped)
    message(FATAL_ERROR "${h}: wrap each 'namespace potmap {' in POTMAP_CXX_API_BEGIN/END "
                        "(potmap/export.h) so that its declarations are exported")
  endif()
endforeach()
message(STATUS "${ndecls} C API functions exported, ${strong} strong symbols, all potmap's")
