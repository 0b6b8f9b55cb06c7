#include "harness/embree/embree_trace.h"

#include <embree3/rtcore.h>
#include <fmt/format.h>
#include <pmmintrin.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <xmmintrin.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"

namespace sahbench {

bool embree_accepts(const Ray& ray) {
  for (int a = 0; a < 3; ++a) {
    const auto axis = static_cast<std::size_t>(a);
    if (!(std::abs(ray.org[axis]) <= kEmbreeLargeFloat) || !(std::abs(ray.dir[axis]) <= kEmbreeLargeFloat))
      return false;
  }
  return !std::isnan(ray.tmin) && !std::isnan(ray.tmax);
}

void check_embree_range(std::span<const Ray> rays, const std::string& what) {
  const auto far = std::find_if_not(rays.begin(), rays.end(), embree_accepts);
  if (far != rays.end())
    throw Error(
        fmt::format("{}: ray {} has an origin or direction component beyond {:g}, outside the range "
                    "Embree traces (its assertion would stop the process)",
                    what, far - rays.begin(), kEmbreeLargeFloat));
}

namespace {

// Every ray is in every mask group (rtcore_ray.h: a ray hits a geometry when ray.mask & geometry.mask
// is non-zero; geometries default to 0xFFFFFFFF).
constexpr unsigned kAllMask = 0xFFFFFFFFu;
// Packet lane states for rtcIntersect8/16's `valid` argument (rtcore_scene.h): -1 active, 0 inactive.
constexpr int kLaneActive = -1;
constexpr int kLaneInactive = 0;

// Sets FTZ and DAZ for the lifetime of one chunk and then restores the thread's MXCSR. Embree asks for
// both on every tracing thread; restoring keeps our own kernels, which may run next on the same TBB
// threads, from silently flushing denormals because an Embree cell happened to run first.
class DenormalsFlushed {
 public:
  DenormalsFlushed() : saved_(_mm_getcsr()) {
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
  }
  ~DenormalsFlushed() { _mm_setcsr(saved_); }
  DenormalsFlushed(const DenormalsFlushed&) = delete;
  DenormalsFlushed& operator=(const DenormalsFlushed&) = delete;

 private:
  unsigned saved_;
};

template <class Out>
void check_sizes(std::span<const Ray> rays, std::span<Out> out, const char* what) {
  if (rays.size() != out.size())
    throw Error(std::string("Embree ") + what + ": " + std::to_string(rays.size()) + " rays but " +
                std::to_string(out.size()) + " result slots");
}

// Runs `body(begin, end)` over [0, count) in chunks of kEmbreeTraceChunk, one TBB task per chunk, in
// the caller's arena. Each chunk runs with FTZ/DAZ and checks Embree's error code afterwards (Embree 3
// keeps one per thread and device, so the check must happen on the thread that traced).
template <class Body>
void for_each_chunk(const EmbreeScene& scene, std::size_t count, const char* what, const Body& body) {
  const std::size_t chunks = (count + kEmbreeTraceChunk - 1) / kEmbreeTraceChunk;
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, chunks, 1),
      [&](const tbb::blocked_range<std::size_t>& range) {
        const DenormalsFlushed flushed;
        for (std::size_t chunk = range.begin(); chunk < range.end(); ++chunk) {
          const std::size_t begin = chunk * kEmbreeTraceChunk;
          body(begin, std::min(count, begin + kEmbreeTraceChunk));
        }
        scene.device().check(what);
      },
      tbb::simple_partitioner());
}

void set_ray(RTCRay& out, const Ray& ray) {
  out.org_x = ray.org.x;
  out.org_y = ray.org.y;
  out.org_z = ray.org.z;
  out.tnear = ray.tmin;
  out.dir_x = ray.dir.x;
  out.dir_y = ray.dir.y;
  out.dir_z = ray.dir.z;
  out.time = 0.0f;
  out.tfar = far_limit(ray);  // the question every kernel of ours answers: no hit at an infinite t
  out.mask = kAllMask;
  out.id = 0;
  out.flags = 0;
}

Hit to_hit(unsigned geom_id, unsigned prim_id, float tfar, float u, float v) {
  if (geom_id == RTC_INVALID_GEOMETRY_ID) return {};
  return {prim_id, tfar, u, v};
}

// The SoA packet types and calls of one width (rtcore_ray.h, rtcore_scene.h).
template <int W>
struct PacketApi;

template <>
struct PacketApi<8> {
  using RayHit = RTCRayHit8;
  using Ray = RTCRay8;
  static void intersect(const int* valid, RTCScene s, RTCIntersectContext* c, RayHit* r) {
    rtcIntersect8(valid, s, c, r);
  }
  static void occluded(const int* valid, RTCScene s, RTCIntersectContext* c, Ray* r) {
    rtcOccluded8(valid, s, c, r);
  }
};

template <>
struct PacketApi<16> {
  using RayHit = RTCRayHit16;
  using Ray = RTCRay16;
  static void intersect(const int* valid, RTCScene s, RTCIntersectContext* c, RayHit* r) {
    rtcIntersect16(valid, s, c, r);
  }
  static void occluded(const int* valid, RTCScene s, RTCIntersectContext* c, Ray* r) {
    rtcOccluded16(valid, s, c, r);
  }
};

// Fills lanes [0, active) of a packet from `rays` and masks out the rest. Inactive lanes still get a
// finite, empty ray (tnear 0 > tfar -inf) so no lane of the SIMD code computes on garbage.
template <int W, class PacketRay>
void fill_packet(PacketRay& packet, int (&valid)[W], const sahbench::Ray* rays, int active) {
  for (int lane = 0; lane < W; ++lane) {
    const bool on = lane < active;
    const sahbench::Ray ray = on ? rays[lane] : sahbench::Ray{};
    valid[lane] = on ? kLaneActive : kLaneInactive;
    packet.org_x[lane] = ray.org.x;
    packet.org_y[lane] = ray.org.y;
    packet.org_z[lane] = ray.org.z;
    packet.tnear[lane] = ray.tmin;
    packet.dir_x[lane] = ray.dir.x;
    packet.dir_y[lane] = ray.dir.y;
    packet.dir_z[lane] = ray.dir.z;
    packet.time[lane] = 0.0f;
    packet.tfar[lane] = on ? far_limit(ray) : -std::numeric_limits<float>::infinity();
    packet.mask[lane] = kAllMask;
    packet.id[lane] = 0;
    packet.flags[lane] = 0;
  }
}

template <int W>
void intersect_packets(const EmbreeScene& scene, std::span<const Ray> rays, std::span<Hit> hits) {
  using Api = PacketApi<W>;
  for_each_chunk(scene, rays.size(), "rtcIntersect packets", [&](std::size_t begin, std::size_t end) {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    typename Api::RayHit packet;  // RTC_ALIGN(32/64) in its declaration
    alignas(64) int valid[W];
    for (std::size_t first = begin; first < end; first += W) {
      const int active = static_cast<int>(std::min<std::size_t>(W, end - first));
      fill_packet<W>(packet.ray, valid, rays.data() + first, active);
      for (int lane = 0; lane < W; ++lane) {
        packet.hit.geomID[lane] = RTC_INVALID_GEOMETRY_ID;
        packet.hit.instID[0][lane] = RTC_INVALID_GEOMETRY_ID;
      }
      Api::intersect(valid, scene.get(), &context, &packet);
      for (int lane = 0; lane < active; ++lane)
        hits[first + lane] = to_hit(packet.hit.geomID[lane], packet.hit.primID[lane], packet.ray.tfar[lane],
                                    packet.hit.u[lane], packet.hit.v[lane]);
    }
  });
}

template <int W>
void occluded_packets(const EmbreeScene& scene, std::span<const Ray> rays, std::span<uint8_t> occluded) {
  using Api = PacketApi<W>;
  for_each_chunk(scene, rays.size(), "rtcOccluded packets", [&](std::size_t begin, std::size_t end) {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    typename Api::Ray packet;
    alignas(64) int valid[W];
    for (std::size_t first = begin; first < end; first += W) {
      const int active = static_cast<int>(std::min<std::size_t>(W, end - first));
      fill_packet<W>(packet, valid, rays.data() + first, active);
      Api::occluded(valid, scene.get(), &context, &packet);
      for (int lane = 0; lane < active; ++lane)
        occluded[first + lane] = packet.tfar[lane] == -std::numeric_limits<float>::infinity() ? 1 : 0;
    }
  });
}

void require_packets(const EmbreeDevice& device, int width) {
  if (width != 8 && width != 16)
    throw Error("Embree packets: width " + std::to_string(width) + " is not supported (8 or 16)");
  if (!embree_packets_supported(device, width))
    throw Error("Embree packets: this device has no native " + std::to_string(width) +
                "-wide packet kernels (RTC_DEVICE_PROPERTY_NATIVE_RAY" + std::to_string(width) +
                "_SUPPORTED is 0)");
}

}  // namespace

void embree_intersect1(const EmbreeScene& scene, std::span<const Ray> rays, std::span<Hit> hits) {
  check_sizes(rays, hits, "rtcIntersect1");
  for_each_chunk(scene, rays.size(), "rtcIntersect1", [&](std::size_t begin, std::size_t end) {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    for (std::size_t i = begin; i < end; ++i) {
      RTCRayHit rayhit;
      set_ray(rayhit.ray, rays[i]);
      rayhit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rayhit.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect1(scene.get(), &context, &rayhit);
      hits[i] = to_hit(rayhit.hit.geomID, rayhit.hit.primID, rayhit.ray.tfar, rayhit.hit.u, rayhit.hit.v);
    }
  });
}

void embree_occluded1(const EmbreeScene& scene, std::span<const Ray> rays, std::span<uint8_t> occluded) {
  check_sizes(rays, occluded, "rtcOccluded1");
  for_each_chunk(scene, rays.size(), "rtcOccluded1", [&](std::size_t begin, std::size_t end) {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    for (std::size_t i = begin; i < end; ++i) {
      RTCRay ray;
      set_ray(ray, rays[i]);
      rtcOccluded1(scene.get(), &context, &ray);
      occluded[i] = ray.tfar == -std::numeric_limits<float>::infinity() ? 1 : 0;
    }
  });
}

void embree_intersect_packets(const EmbreeScene& scene, std::span<const Ray> rays, std::span<Hit> hits,
                              int width) {
  require_packets(scene.device(), width);
  check_sizes(rays, hits, "rtcIntersect packets");
  if (width == 8) return intersect_packets<8>(scene, rays, hits);
  intersect_packets<16>(scene, rays, hits);
}

void embree_occluded_packets(const EmbreeScene& scene, std::span<const Ray> rays, std::span<uint8_t> occluded,
                             int width) {
  require_packets(scene.device(), width);
  check_sizes(rays, occluded, "rtcOccluded packets");
  if (width == 8) return occluded_packets<8>(scene, rays, occluded);
  occluded_packets<16>(scene, rays, occluded);
}

bool embree_packets_supported(const EmbreeDevice& device, int width) {
  if (width == 8) return device.property(RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED) != 0;
  if (width == 16) return device.property(RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED) != 0;
  return false;
}

std::string embree_isa(const EmbreeDevice& device) {
  // Embree's AVX2 target also needs FMA, BMI1/2 and LZCNT (common/sys/sysinfo.h, AVX2 feature mask);
  // every CPU with AVX2 so far has them, and the verbose check in the tests would catch one without.
  if (device.property(RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED)) return "avx512";
  if (device.property(RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED))
    return __builtin_cpu_supports("avx2") ? "avx2" : "avx";
  return __builtin_cpu_supports("sse4.2") ? "sse42" : "sse2";
}

}  // namespace sahbench
