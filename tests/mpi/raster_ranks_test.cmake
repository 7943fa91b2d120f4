# Runs one tiled raster job on one process and on 2 MPI ranks (as root if need be, more ranks
# than cores allowed) and checks that both write the same GeoTIFF and that both ranks took
# tiles. Variables: POTMAP, MPIEXEC, MAP, WORK_DIR; BAND (ZLO,ZHI): instead of MAP, a small 3D
# map written here, rastered by that height band.
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
set(job raster --map ${MAP} --bounds -300,-100,0,200 --res 0.25 --tile 64 --json)
set(tiles 169)
if(BAND)
  set(rows "x,y,z,gamma,w_mean,w_var\n")
  foreach(i RANGE 0 24)
    math(EXPR x "(${i} % 5) * 2 - 4")
    math(EXPR y "(${i} / 5) * 2 - 4")
    math(EXPR z "${i} % 3")
    math(EXPR w "(${i} % 4) * 2 - 3")
    string(APPEND rows "${x}.3,${y}.1,${z}.2,3.0,${w},0.4\n")
  endforeach()
  file(WRITE ${WORK_DIR}/map3.csv "${rows}")
  set(job raster --map ${WORK_DIR}/map3.csv --bounds -5,5,-5,5 --res 0.05 --band ${BAND}
    --band-step 0.2 --tile 64 --json)
  set(tiles 16)
endif()

execute_process(COMMAND ${POTMAP} ${job} --out ${WORK_DIR}/one.tif
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "one process failed (${rc}):\n${out}\n${err}")
endif()

execute_process(COMMAND ${MPIEXEC} -n 2 --allow-run-as-root --oversubscribe
    -x POTMAP_CACHE_DIR ${POTMAP} ${job} --out ${WORK_DIR}/two.tif
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "2 ranks failed (${rc}):\n${out}\n${err}")
endif()
if(NOT out MATCHES "\"ranks\": 2")
  message(FATAL_ERROR "the job did not run on 2 ranks:\n${out}\n${err}")
endif()
if(NOT out MATCHES "\"ranks_with_tiles\": 2")
  message(FATAL_ERROR "one rank took no tile:\n${out}")
endif()
if(NOT out MATCHES "\"computed\": ${tiles}")
  message(FATAL_ERROR "the ranks did not compute the ${tiles} tiles between them:\n${out}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK_DIR}/one.tif ${WORK_DIR}/two.tif
  RESULT_VARIABLE same)
if(NOT same EQUAL 0)
  message(FATAL_ERROR "2 ranks wrote a different GeoTIFF from one process")
endif()
message(STATUS "one process and 2 ranks wrote the same GeoTIFF")
