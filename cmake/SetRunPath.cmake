# Sets the run path of an ELF file: cmake -DFILE=<file> -DRUN_PATH=<run path> -P SetRunPath.cmake.
# pip's backend (setup.py) points the packaged module and command at the package's own lib/
# folder with it. CMake rewrites the entry in place, so the new run path must be no longer than
# the one `cmake --install` wrote ($ORIGIN/ and a relative path to the prefix's library folder).
cmake_minimum_required(VERSION 3.21)
if(NOT FILE OR NOT DEFINED RUN_PATH)
  message(FATAL_ERROR "usage: cmake -DFILE=<file> -DRUN_PATH=<run path> -P SetRunPath.cmake")
endif()
file(RPATH_SET FILE "${FILE}" NEW_RPATH "${RUN_PATH}")
