# wavemap (github.com/ethz-asl/wavemap) as a peer method of the experiments, only when asked for:
#   cmake -DPOTMAP_WAVEMAP_DIR=<wavemap's install prefix> ...
# (wavemap's C++ library built and installed on its own; Debian's libgoogle-glog-dev, Eigen and
# Boost). Off by default: CI, the tests and users never need it. `potmap experiment ...
# --methods ...,wavemap` then maps with it (include/potmap/experiments/wavemap_method.hpp).
set(POTMAP_WAVEMAP_DIR "" CACHE PATH
  "wavemap's install prefix: adds the wavemap peer to the experiments (empty: off)")
if(NOT POTMAP_WAVEMAP_DIR)
  return()
endif()
find_package(wavemap CONFIG REQUIRED PATHS ${POTMAP_WAVEMAP_DIR} NO_DEFAULT_PATH)
message(STATUS "wavemap peer: ${wavemap_DIR} (version ${wavemap_VERSION})")
# The file that calls wavemap compiles with wavemap's own flags (-march=native among them) in an
# object library of its own, so that no other potmap file shares its inline Eigen code.
add_library(potmap_wavemap_objects OBJECT
  ${CMAKE_CURRENT_SOURCE_DIR}/host/experiments/peers/wavemap_grid.cpp)
target_include_directories(potmap_wavemap_objects
  PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/include ${CMAKE_CURRENT_BINARY_DIR}/generated/include)
target_link_libraries(potmap_wavemap_objects PRIVATE wavemap::wavemap_core)
set_target_properties(potmap_wavemap_objects PROPERTIES
  CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON POSITION_INDEPENDENT_CODE ON)
target_sources(potmap_experiments PRIVATE
  ${CMAKE_CURRENT_SOURCE_DIR}/host/experiments/peers/wavemap_method.cpp
  $<TARGET_OBJECTS:potmap_wavemap_objects>)
target_link_libraries(potmap_experiments PRIVATE $<LINK_ONLY:wavemap::wavemap_core>)
target_compile_definitions(potmap_experiments PUBLIC POTMAP_WITH_WAVEMAP)
