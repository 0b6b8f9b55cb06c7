#pragma once
// Tracing sahbench rays through a committed Embree scene: single rays (rtcIntersect1, rtcOccluded1) and
// packets of 8 or 16 (rtcIntersect8/16, rtcOccluded8/16), in parallel over fixed-size chunks with TBB.
// The rays are the harness's own (core/ray.h) with the same origin, direction, tmin and tmax that our
// kernels get; the hits come back in our format.

#include <cstdint>
#include <span>
#include <string>

#include "core/ray.h"
#include "harness/embree/embree_scene.h"

namespace sahbench {

/// Rays per TBB task. A multiple of 16, so that only the last chunk of a batch holds a partial packet;
/// 1024 rays are tens of microseconds of tracing, enough to amortise the task and the per-chunk set-up
/// (MXCSR, error check), and still thousands of tasks for a million rays.
inline constexpr std::size_t kEmbreeTraceChunk = 1024;

/// Embree 3's RayK::valid() (kernels/common/ray.h), asserted in Debian's build before every traversal:
/// origin and direction components within FLT_LARGE = 1.844e18 (common/math/constants.h), tnear and tfar
/// not NaN. A ray outside that range aborts the process, so it must never be handed to Embree.
inline constexpr float kEmbreeLargeFloat = 1.844e18f;
bool embree_accepts(const Ray& ray);

/// Throws an Error "`what`: ray I has an origin or direction component beyond 1.844e18, ..." for the first
/// ray of `rays` Embree does not accept (I counted from 0), before any of them is handed to Embree.
void check_embree_range(std::span<const Ray> rays, const std::string& what);

/// Closest hit of every ray, rtcIntersect1 (rtcore_scene.h). hits[i].prim is Embree's primID (the scene
/// triangle index, see EmbreeScene) or kInvalidPrim for a miss; t is the returned tfar; (u, v) are
/// Embree's barycentrics, which use our convention p = (1-u-v) v0 + u v1 + v v2 (rtcore_ray.h's RTCHit;
/// checked by a test). Embree's hit interval is tnear < t <= tfar (open at tmin, where ours is closed),
/// and it culls no faces (RTC_DEVICE_PROPERTY_BACKFACE_CULLING_ENABLED is 0 on Debian's build).
/// Runs tbb::parallel_for in the caller's arena, so tbb::global_control and task_arena limits apply.
/// Every tracing thread runs with flush-to-zero and denormals-are-zero set, as Embree asks for speed
/// (its verbose start-up warning), and each chunk restores the thread's previous MXCSR afterwards.
/// `hits` must have the size of `rays`; errors recorded by Embree are thrown as sahbench::Error.
void embree_intersect1(const EmbreeScene& scene, std::span<const Ray> rays, std::span<Hit> hits);

/// Whether each ray hits anything in [tmin, tmax], rtcOccluded1: Embree sets tfar to -inf on a hit.
/// occluded[i] is 1 or 0. Same threading and MXCSR handling as embree_intersect1.
void embree_occluded1(const EmbreeScene& scene, std::span<const Ray> rays, std::span<uint8_t> occluded);

/// embree_intersect1 with packets of `width` = 8 or 16 rays (rtcIntersect8/16): consecutive rays form
/// a packet, and the lanes past the end of the batch are masked out of the last one. A width the device
/// has no native packet kernel for (RTC_DEVICE_PROPERTY_NATIVE_RAY8/16_SUPPORTED) is an error naming it.
void embree_intersect_packets(const EmbreeScene& scene, std::span<const Ray> rays, std::span<Hit> hits,
                              int width);

/// embree_occluded1 with packets of 8 or 16 rays (rtcOccluded8/16).
void embree_occluded_packets(const EmbreeScene& scene, std::span<const Ray> rays, std::span<uint8_t> occluded,
                             int width);

/// Whether `device` traces packets of `width` (8 or 16) natively; false for any other width.
bool embree_packets_supported(const EmbreeDevice& device, int width);

/// The instruction set of Embree's ray kernels: "avx512", "avx2", "avx", "sse42" or "sse2", the
/// namespaces Embree prints for its intersectors (e.g. avx512::BVH8Triangle4Intersector1Moeller).
///
/// Embree 3 has no property for the ISA it picked; only its verbose output (device config
/// "verbose=2") names the intersectors, and it prints that to stdout. So this infers it from what the
/// API does expose: Embree enables native 16-wide packets only with AVX-512 kernels and 8-wide ones
/// only with AVX or AVX2 kernels (Device::getProperty in kernels/common/device.cpp), and it picks the
/// best ISA it was compiled for that the CPU has. Where the property cannot tell AVX from AVX2 (or SSE2
/// from SSE4.2), the CPU's flags decide, which assumes Embree was compiled for both, as Debian's build
/// is (verbose=1: "SSE2 SSE4.2 AVX AVX2 AVX512 (compile time enabled)"). A test checks the answer
/// against the verbose output. Embree's builders may run another ISA (verbose=2 shows
/// avx::BVH8BuilderSAH on an AVX-512 machine), which this does not describe.
std::string embree_isa(const EmbreeDevice& device);

}  // namespace sahbench
