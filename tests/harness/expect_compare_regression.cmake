# `sahbench compare` gates CI through its exit code: a run against itself exits 0, and a run whose SAH
# cost got worse exits 1 and names the metric.
#   cmake -DSAHBENCH=path/to/sahbench -DWORK=dir -P expect_compare_regression.cmake
file(MAKE_DIRECTORY "${WORK}")
set(header "run_id,run_fingerprint,scene,builder,builder_params,layout,threads,ray_set,frame,sah_cost,nodes,leaves,max_depth,nodes_per_ray,prims_per_ray,mem_bytes,refs_per_prim,mismatches")
set(key "r1,0123456789abcdef,proc:sphere,binned_sah,bins=8,bvh2,1,primary,0")
file(WRITE "${WORK}/baseline.csv" "${header}\n${key},38.937587,21713,10857,16,8.492,1.306,774896,1.0000,0\n")
file(WRITE "${WORK}/worse.csv" "${header}\n${key},40.5,21713,10857,16,8.492,1.306,774896,1.0000,0\n")

execute_process(COMMAND "${SAHBENCH}" compare "${WORK}/baseline.csv" "${WORK}/baseline.csv" --deterministic-only
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc STREQUAL "0")
  message(FATAL_ERROR "a run against itself: exit code ${rc}, expected 0\nstdout: ${out}\nstderr: ${err}")
endif()

execute_process(COMMAND "${SAHBENCH}" compare "${WORK}/baseline.csv" "${WORK}/worse.csv" --deterministic-only
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc STREQUAL "1")
  message(FATAL_ERROR "a worse SAH cost: exit code ${rc}, expected 1\nstdout: ${out}\nstderr: ${err}")
endif()
string(FIND "${out}" "sah_cost" at)
if(at EQUAL -1)
  message(FATAL_ERROR "the regression report does not name sah_cost:\n${out}")
endif()
