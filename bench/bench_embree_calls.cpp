// What one call of Embree's API costs beyond its traversal: rays that miss the scene's box, so that each
// query is the call, Embree's ray set-up and one root test, through rtcIntersect1 / rtcOccluded1 (one
// ray per call, as the harness's embree_1 rows trace), rtcOccluded1M (a stream of single rays) and
// rtcOccluded16 (sixteen rays per call). The difference per ray between the one-ray calls and the others
// is a fixed cost that every embree_1 figure carries and the packet rows do not. Items are rays.

#include <benchmark/benchmark.h>
#include <embree3/rtcore.h>

#include <vector>

namespace {

// A 32 x 32 grid of triangles in the plane z = 10, and rays from z = 0 going away from it.
struct MissScene {
  MissScene() : device(rtcNewDevice(nullptr)), scene(rtcNewScene(device)) {
    RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    constexpr unsigned kTriangles = 1024;
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
        geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 3 * kTriangles));
    auto* index = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), kTriangles));
    for (unsigned i = 0; i < kTriangles; ++i) {
      const float x = float(i % 32), y = float(i / 32);
      const float corners[9] = {x, y, 10, x + 1, y, 10, x, y + 1, 10};
      for (int k = 0; k < 9; ++k) v[9 * i + k] = corners[k];
      for (unsigned k = 0; k < 3; ++k) index[3 * i + k] = 3 * i + k;
    }
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(scene, geometry);
    rtcReleaseGeometry(geometry);
    rtcCommitScene(scene);
  }
  ~MissScene() {
    rtcReleaseScene(scene);
    rtcReleaseDevice(device);
  }
  RTCDevice device;
  RTCScene scene;
};

const MissScene& miss_scene() {
  static const MissScene scene;
  return scene;
}

RTCRay miss_ray(unsigned i) {
  RTCRay r{};
  r.org_x = float(i % 32);
  r.org_y = 5.0f;
  r.dir_x = 0.01f;
  r.dir_y = 0.02f;
  r.dir_z = -1.0f;
  r.tfar = 1e30f;
  r.mask = ~0u;
  return r;
}

// One ray per call: `query(i)` traces the i-th miss ray through `context` and returns a value to keep.
template <class Query>
void one_ray_per_call(benchmark::State& state, Query query) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  unsigned i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(query(context, i++));
  state.SetItemsProcessed(state.iterations());
}

void BM_Occluded1(benchmark::State& state) {
  one_ray_per_call(state, [scene = miss_scene().scene](RTCIntersectContext& context, unsigned i) {
    RTCRay r = miss_ray(i);
    rtcOccluded1(scene, &context, &r);
    return r.tfar;
  });
}
BENCHMARK(BM_Occluded1)->Name("embree_call/occluded1");

void BM_Intersect1(benchmark::State& state) {
  one_ray_per_call(state, [scene = miss_scene().scene](RTCIntersectContext& context, unsigned i) {
    RTCRayHit h{};
    h.ray = miss_ray(i);
    h.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, &context, &h);
    return h.hit.geomID;
  });
}
BENCHMARK(BM_Intersect1)->Name("embree_call/intersect1");

void BM_Occluded1M(benchmark::State& state) {
  const MissScene& s = miss_scene();
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  std::vector<RTCRay> rays(1024);
  for (auto _ : state) {
    for (unsigned k = 0; k < rays.size(); ++k) rays[k] = miss_ray(k);
    rtcOccluded1M(s.scene, &context, rays.data(), static_cast<unsigned>(rays.size()), sizeof(RTCRay));
    benchmark::DoNotOptimize(rays[0].tfar);
  }
  state.SetItemsProcessed(state.iterations() * int64_t(rays.size()));
}
BENCHMARK(BM_Occluded1M)->Name("embree_call/occluded1M_1024");

void BM_Occluded16(benchmark::State& state) {
  const MissScene& s = miss_scene();
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  alignas(64) int valid[16];
  alignas(64) RTCRay16 packet{};
  unsigned i = 0;
  for (auto _ : state) {
    for (int k = 0; k < 16; ++k) {
      const RTCRay r = miss_ray(i++);
      valid[k] = -1;
      packet.org_x[k] = r.org_x;
      packet.org_y[k] = r.org_y;
      packet.org_z[k] = r.org_z;
      packet.dir_x[k] = r.dir_x;
      packet.dir_y[k] = r.dir_y;
      packet.dir_z[k] = r.dir_z;
      packet.tnear[k] = 0.0f;
      packet.tfar[k] = r.tfar;
      packet.mask[k] = r.mask;
    }
    rtcOccluded16(valid, s.scene, &context, &packet);
    benchmark::DoNotOptimize(packet.tfar[0]);
  }
  state.SetItemsProcessed(state.iterations() * 16);
}
BENCHMARK(BM_Occluded16)->Name("embree_call/occluded16");

}  // namespace
