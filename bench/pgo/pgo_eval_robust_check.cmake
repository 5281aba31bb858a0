# ctest: GNC-TLS on smallGrid3D with 50 % wrong loop closures (outlier seed 2, the hardest of the three measured), its
# threshold 1.5 times the right closures' largest residual (--noise-bound 1 --noise-margin 1.5) and its weighted
# solves from the chordal estimate (--gnc-chordal 1; by conjugate gradients, the default), keeps no wrong closure
# and ends within 5 % of the outlier-free solution's RMS radius, the issue's target (bench/results/pose_graph.md:
# 2.6 %; warm-started GNC there ends 55 % away). cmake -P with PGO_EVAL, GRAPH, WORK_DIR. Skips when ../shared/data
# is absent.
if(NOT EXISTS ${GRAPH})
  message("SKIP: ${GRAPH} not found (the shared data is not beside this checkout)")
  return()
endif()
get_filename_component(dir ${GRAPH} DIRECTORY)
file(MAKE_DIRECTORY ${WORK_DIR})
execute_process(COMMAND ${PGO_EVAL} --data-dir ${dir} --graphs smallGrid3D --outliers 0.5 --solvers gnc_tls
                        --seed 2 --noise-bound 1 --noise-margin 1.5 --gnc-chordal 1 --json ${WORK_DIR}/pgo.json
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "pgo_eval failed (${rc}): ${out}${err}")
endif()
file(READ ${WORK_DIR}/pgo.json json)
string(JSON n LENGTH "${json}")
math(EXPR last "${n} - 1")
set(share "")
set(wrong_kept "")
set(prefix "pgo_eval.smallGrid3D.outliers_50.gnc_tls_noise_bound_150pct_cg_chordal")
foreach(i RANGE ${last})
  string(JSON name GET "${json}" ${i} name)
  if(name STREQUAL "${prefix}.rmse_to_outlier_free_share")
    string(JSON share GET "${json}" ${i} value)
  elseif(name STREQUAL "${prefix}.wrong_kept")
    string(JSON wrong_kept GET "${json}" ${i} value)
  endif()
endforeach()
if(share STREQUAL "" OR wrong_kept STREQUAL "")
  message(FATAL_ERROR "pgo_eval wrote no ${prefix} figures:\n${out}")
endif()
if(NOT wrong_kept EQUAL 0)
  message(FATAL_ERROR "GNC-TLS kept ${wrong_kept} wrong closures:\n${out}")
endif()
if(share GREATER 0.05)
  message(FATAL_ERROR "GNC-TLS ended ${share} of the radius from the outlier-free solution (over 0.05):\n${out}")
endif()
message("GNC-TLS at 50 % wrong closures: none kept, ${share} of the radius from the outlier-free solution")
