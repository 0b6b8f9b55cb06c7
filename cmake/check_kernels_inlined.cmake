# Fails when a helper of the SIMD wide kernels (traversal/wide_kernels.inl) was compiled out of line.
# The kernels depend on GCC inlining every helper into the traversal loop; SAHBENCH_KERNEL_INLINE forces
# it. Without it, a new kernel variant pushed the translation units over GCC's inline-unit-growth limit
# and the kernels lost 6-15% with nothing else to show for it.
# Usage: cmake -DNM=nm -DLIBRARY=libsahbench_traversal.a -P check_kernels_inlined.cmake
execute_process(COMMAND ${NM} -C ${LIBRARY} OUTPUT_VARIABLE symbols RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "${NM} -C ${LIBRARY} failed (${status})")
endif()
# Functions of the SIMD kernels' namespaces that are meant to be called: the entry points, the
# per-ray, per-pair and per-packet loop bodies, a packet batch's run of lone rays (trace_alone), a
# batch's shadow-cache loops (trace_shadow_cached, trace_packets_shadow_cached: out of line so that the
# loops without them are unchanged), the benchmark loops, the tests' one-node test, the watertight block
# test (kept as a call on purpose), the watertight test's finish in double (lane_in_double: for lanes
# whose float edge functions are zero or out of range, rarely run; GCC leaves it out of line in the AVX2
# and AVX-512 files) and the binary layouts' packet kernels (pair_packets.inl).
set(allowed
    "trace_batch|trace_packet_batch|trace_alone|trace_shadow_cached|trace_packets_shadow_cached|trace_ray|trace_ray_pair|trace_packet|node_test_loop|node_test_one|block_test_loop|intersect_block_watertight|lane_in_double|trace_pair_packet|trace_packed_pair_packet|trace_binary_packet")
string(REPLACE "\n" ";" lines "${symbols}")
set(found 0)
set(offending "")
set(member "")
set(shared "")
foreach(line IN LISTS lines)
  if(line MATCHES "^(.*\\.o):$")
    set(member "${CMAKE_MATCH_1}")
  endif()
  # An inline function of the other layers (a triangle test, the binary walk) left out of line in a
  # kernel file is a copy built for that file's instruction set, which the linker may pick for every
  # caller: pair_packets.inl is flattened so that none is left.
  if(member MATCHES "wide_kernels_(sse|avx2|avx512)" AND line MATCHES " [wWvV] (sahbench::.*)$")
    set(symbol "${CMAKE_MATCH_1}")
    if(NOT line MATCHES "sahbench::wide_(sse|avx2|avx512)::")
      string(APPEND shared "  ${member}: ${symbol}\n")
    endif()
  endif()
  # The function's own name: the first after the namespace, before any template arguments (which may
  # name the namespace's types again, e.g. trace_packet_batch<wide_avx512::Lanes16, ...>).
  if(line MATCHES " [tTwW] ([^<(]*sahbench::wide_(sse|avx2|avx512)::([A-Za-z_0-9]+).*)$")
    set(symbol "${CMAKE_MATCH_1}")
    set(function "${CMAKE_MATCH_3}")
    math(EXPR found "${found} + 1")
    if(NOT function MATCHES "^(${allowed})$")
      string(APPEND offending "  ${symbol}\n")
    endif()
  endif()
endforeach()
if(found EQUAL 0)
  message(FATAL_ERROR "no symbol of the SIMD kernels found in ${LIBRARY}: is it the right library?")
endif()
if(NOT shared STREQUAL "")
  message(FATAL_ERROR "inline functions of other layers compiled out of line in a kernel file:\n${shared}")
endif()
if(NOT offending STREQUAL "")
  message(FATAL_ERROR "kernel helpers compiled out of line (mark them SAHBENCH_KERNEL_INLINE):\n${offending}")
endif()
message(STATUS "${found} kernel functions, all entry points")
