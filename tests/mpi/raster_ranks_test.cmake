# Runs one tiled raster job on one process and on 2 MPI ranks (as root if need be, more ranks
# than cores allowed) and checks that both write the same GeoTIFF and that both ranks took
# tiles. Variables: POTMAP, MPIEXEC, MAP, WORK_DIR.
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
set(job raster --map ${MAP} --bounds -300,-100,0,200 --res 0.25 --tile 64 --json)

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
if(NOT out MATCHES "\"computed\": 169")
  message(FATAL_ERROR "the ranks did not compute the 169 tiles between them:\n${out}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK_DIR}/one.tif ${WORK_DIR}/two.tif
  RESULT_VARIABLE same)
if(NOT same EQUAL 0)
  message(FATAL_ERROR "2 ranks wrote a different GeoTIFF from one process")
endif()
message(STATUS "one process and 2 ranks wrote the same GeoTIFF")
