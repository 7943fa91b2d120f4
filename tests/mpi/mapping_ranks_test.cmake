# `potmap mapping` on one process and on 2 MPI ranks (as root if need be, more ranks than cores
# allowed), for a 2D log and a 3D drive: the ranks' merged map must be scored on the same
# held-out samples as the one process's and score within the given margins of it. Then the
# refusals: more ranks than scans, and POT's summed kernels, which keep nothing to merge.
# Variables: POTMAP, MPIEXEC, LOG, DRIVE, WORK_DIR, SCANS, KEYFRAMES, and the margins in
# millionths: LOG_AUC_MARGIN, LOG_NLL_MARGIN, DRIVE_AUC_MARGIN, DRIVE_NLL_MARGIN.
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
set(mpi ${MPIEXEC} -n 2 --allow-run-as-root --oversubscribe -x POTMAP_CACHE_DIR)

# A score in millionths (CMake's arithmetic is on integers).
function(micro value out)
  if(NOT value MATCHES "^([0-9]+)\\.?([0-9]*)$")
    message(FATAL_ERROR "not a plain decimal score: ${value}")
  endif()
  set(whole ${CMAKE_MATCH_1})
  string(SUBSTRING "${CMAKE_MATCH_2}000000" 0 6 frac)
  string(REGEX REPLACE "^0+([0-9])" "\\1" frac "${frac}")
  math(EXPR v "${whole} * 1000000 + ${frac}")
  set(${out} ${v} PARENT_SCOPE)
endfunction()

# Reads auc, nll and held-out count from scores.json under `member` (overall or scores).
function(read_scores file member prefix)
  file(READ ${file} json)
  string(JSON auc GET "${json}" ${member} auc)
  string(JSON nll GET "${json}" ${member} nll)
  if(member STREQUAL "overall")
    string(JSON n GET "${json}" ${member} points)
  else()
    string(JSON n GET "${json}" ${member} n)
  endif()
  string(JSON ranks ERROR_VARIABLE no_ranks GET "${json}" ranks ranks)
  set(${prefix}_auc ${auc} PARENT_SCOPE)
  set(${prefix}_nll ${nll} PARENT_SCOPE)
  set(${prefix}_n ${n} PARENT_SCOPE)
  set(${prefix}_ranks "${ranks}" PARENT_SCOPE)
endfunction()

function(compare name NAME input member)
  execute_process(COMMAND ${POTMAP} mapping ${input} ${ARGN} -q --out ${WORK_DIR}/${name}-one
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${name}: one process failed (${rc}):\n${out}\n${err}")
  endif()
  execute_process(COMMAND ${mpi} ${POTMAP} mapping ${input} ${ARGN} -q --out ${WORK_DIR}/${name}-two
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${name}: 2 ranks failed (${rc}):\n${out}\n${err}")
  endif()
  read_scores(${WORK_DIR}/${name}-one/scores.json ${member} one)
  read_scores(${WORK_DIR}/${name}-two/scores.json ${member} two)
  message(STATUS "${name}: one process AUC ${one_auc} NLL ${one_nll}; 2 ranks AUC ${two_auc} "
    "NLL ${two_nll} (${two_n} held-out samples)")
  if(NOT two_ranks EQUAL 2)
    message(FATAL_ERROR "${name}: scores.json does not say 2 ranks merged:\n${out}\n${err}")
  endif()
  if(NOT one_n EQUAL two_n)
    message(FATAL_ERROR "${name}: scored on ${two_n} held-out samples, one process on ${one_n}")
  endif()
  foreach(m auc nll)
    micro(${one_${m}} a)
    micro(${two_${m}} b)
    math(EXPR d "${b} - ${a}")
    if(d LESS 0)
      math(EXPR d "-${d}")
    endif()
    string(TOUPPER ${m} M)
    set(margin ${${NAME}_${M}_MARGIN})
    if(d GREATER margin)
      message(FATAL_ERROR "${name}: 2 ranks' ${M} ${two_${m}} is ${d} millionths from one "
        "process's ${one_${m}} (margin ${margin})")
    endif()
  endforeach()
  foreach(f map.potmap scores.json)
    if(NOT EXISTS ${WORK_DIR}/${name}-two/${f})
      message(FATAL_ERROR "${name}: 2 ranks wrote no ${f}")
    endif()
  endforeach()
endfunction()

compare(log LOG ${LOG} overall --max-scans ${SCANS})
compare(drive DRIVE ${DRIVE} scores --max-scans ${KEYFRAMES})

# Refused, naming the value: more ranks than scans; POT's summed kernels.
execute_process(COMMAND ${mpi} ${POTMAP} mapping ${LOG} --max-scans 1 -q --out ${WORK_DIR}/few
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT err MATCHES "1 scans cannot be split over 2 ranks")
  message(FATAL_ERROR "1 scan on 2 ranks was not refused (${rc}):\n${out}\n${err}")
endif()
execute_process(COMMAND ${mpi} ${POTMAP} mapping ${LOG} --max-scans 4 --method pot --preset paper -q
    --out ${WORK_DIR}/paper
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT err MATCHES "summed kernels")
  message(FATAL_ERROR "--preset paper on 2 ranks was not refused (${rc}):\n${out}\n${err}")
endif()
message(STATUS "2 ranks' merged maps score as one process's")
