#include "harness/embree/embree_scene.h"

#include <chrono>
#include <cstring>
#include <string>

#include "core/error.h"

namespace sahbench {
namespace {

const char* error_name(RTCError code) {
  switch (code) {
    case RTC_ERROR_NONE:
      return "none";
    case RTC_ERROR_UNKNOWN:
      return "unknown error";
    case RTC_ERROR_INVALID_ARGUMENT:
      return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION:
      return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY:
      return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU:
      return "unsupported CPU";
    case RTC_ERROR_CANCELLED:
      return "cancelled";
    default:
      return "unknown error";
  }
}

}  // namespace

EmbreeQuality parse_embree_quality(std::string_view text) {
  if (text == "low") return EmbreeQuality::kLow;
  if (text == "medium") return EmbreeQuality::kMedium;
  if (text == "high") return EmbreeQuality::kHigh;
  if (text == "refit") return EmbreeQuality::kRefit;
  throw Error("Embree quality '" + std::string(text) + "' is not one of low, medium, high, refit");
}

RTCBuildQuality to_rtc(EmbreeQuality quality) {
  switch (quality) {
    case EmbreeQuality::kLow:
      return RTC_BUILD_QUALITY_LOW;
    case EmbreeQuality::kMedium:
      return RTC_BUILD_QUALITY_MEDIUM;
    case EmbreeQuality::kHigh:
      return RTC_BUILD_QUALITY_HIGH;
    case EmbreeQuality::kRefit:
      return RTC_BUILD_QUALITY_REFIT;
  }
  return RTC_BUILD_QUALITY_MEDIUM;
}

std::string to_string(EmbreeQuality quality) {
  switch (quality) {
    case EmbreeQuality::kLow:
      return "low";
    case EmbreeQuality::kMedium:
      return "medium";
    case EmbreeQuality::kHigh:
      return "high";
    case EmbreeQuality::kRefit:
      return "refit";
  }
  return "?";
}

EmbreeDevice::EmbreeDevice(int threads) {
  if (threads < 0) throw Error("Embree: thread count " + std::to_string(threads) + " is negative");
  // No "threads=" at all for 0: Embree's "threads=0" means the same, but leaving it out says so.
  const std::string config = threads > 0 ? "threads=" + std::to_string(threads) : std::string();
  device_ = rtcNewDevice(config.c_str());
  if (!device_)
    throw Error("Embree: rtcNewDevice(\"" + config + "\") failed: " + error_name(rtcGetDeviceError(nullptr)));
  rtcSetDeviceMemoryMonitorFunction(device_, &EmbreeDevice::monitor, this);
  rtcSetDeviceErrorFunction(device_, &EmbreeDevice::on_error, this);
}

EmbreeDevice::~EmbreeDevice() {
  rtcReleaseDevice(device_);
}

bool EmbreeDevice::monitor(void* user, ssize_t bytes, bool /*post*/) {
  auto* self = static_cast<EmbreeDevice*>(user);
  const int64_t now = self->bytes_.fetch_add(bytes) + bytes;
  int64_t peak = self->peak_.load();
  while (now > peak && !self->peak_.compare_exchange_weak(peak, now)) {
  }
  return true;  // never refuse an allocation
}

void EmbreeDevice::on_error(void* user, RTCError /*code*/, const char* message) {
  auto* self = static_cast<EmbreeDevice*>(user);
  const std::lock_guard lock(self->message_mutex_);
  self->last_message_ = message ? message : "";
}

void EmbreeDevice::check(const char* what) const {
  const RTCError code = rtcGetDeviceError(device_);
  if (code == RTC_ERROR_NONE) return;
  std::string message;
  {
    const std::lock_guard lock(message_mutex_);
    message = last_message_;
  }
  throw Error(std::string("Embree: ") + what + " failed: " + error_name(code) +
              (message.empty() ? "" : " (" + message + ")"));
}

EmbreeScene::EmbreeScene(EmbreeDevice& device, std::span<const Triangle> triangles, EmbreeQuality quality,
                         EmbreeSceneOptions options)
    : device_(&device), options_(options), triangle_count_(triangles.size()) {
  scene_ = rtcNewScene(device.get());
  device.check("rtcNewScene");
  // The destructor does not run when a constructor throws; release the scene on any error below.
  struct ReleaseOnThrow {
    RTCScene& scene;
    bool armed = true;
    ~ReleaseOnThrow() {
      if (armed) rtcReleaseScene(scene);
    }
  } guard{scene_};

  // Refit needs the two-level mode: a dynamic scene of low scene quality (see the class comment).
  const bool refit = quality == EmbreeQuality::kRefit;
  if (refit) options_.dynamic = true;
  int flags = RTC_SCENE_FLAG_NONE;
  if (options_.robust) flags |= RTC_SCENE_FLAG_ROBUST;
  if (options_.dynamic) flags |= RTC_SCENE_FLAG_DYNAMIC;
  rtcSetSceneFlags(scene_, static_cast<RTCSceneFlags>(flags));
  const RTCBuildQuality q = to_rtc(quality);
  rtcSetSceneBuildQuality(scene_, refit ? RTC_BUILD_QUALITY_LOW : q);
  RTCGeometry geometry = rtcNewGeometry(device.get(), RTC_GEOMETRY_TYPE_TRIANGLE);
  rtcSetGeometryBuildQuality(geometry, q);
  const std::size_t n = triangles.size();
  // Embree-managed buffers: the vertex buffer gets Embree's own padding.
  auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0,
                                                               RTC_FORMAT_FLOAT3, 3 * sizeof(float), 3 * n));
  auto* indices = static_cast<uint32_t*>(
      rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), n));
  try {
    device.check("rtcSetNewGeometryBuffer");
  } catch (...) {
    rtcReleaseGeometry(geometry);
    throw;
  }
  for (std::size_t i = 0; i < n; ++i) {
    const Triangle& t = triangles[i];
    for (int v = 0; v < 3; ++v) {
      const Vec3& p = v == 0 ? t.v0 : (v == 1 ? t.v1 : t.v2);
      vertices[9 * i + 3 * v + 0] = p.x;
      vertices[9 * i + 3 * v + 1] = p.y;
      vertices[9 * i + 3 * v + 2] = p.z;
      indices[3 * i + v] = static_cast<uint32_t>(3 * i + v);
    }
  }
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(scene_, geometry);
  rtcReleaseGeometry(geometry);  // the scene keeps it alive
  device.check("geometry set-up");
  geometry_ = geometry;
  vertices_ = vertices;

  const int64_t before = device.bytes();
  const auto start = std::chrono::steady_clock::now();
  rtcCommitScene(scene_);
  commit_ms_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  device.check("rtcCommitScene");
  bytes_ = device.bytes() - before;
  guard.armed = false;
}

EmbreeScene::~EmbreeScene() {
  rtcReleaseScene(scene_);
}

double EmbreeScene::update_vertices(std::span<const Triangle> triangles) {
  if (triangles.size() != triangle_count_)
    throw Error("Embree: update_vertices got " + std::to_string(triangles.size()) +
                " triangles for a scene of " + std::to_string(triangle_count_));
  // Triangle is three packed Vec3, the layout of the RTC_FORMAT_FLOAT3 buffer of 3n vertices.
  static_assert(sizeof(Triangle) == 9 * sizeof(float));
  if (!triangles.empty()) std::memcpy(vertices_, triangles.data(), triangles.size() * sizeof(Triangle));
  const auto start = std::chrono::steady_clock::now();
  rtcUpdateGeometryBuffer(geometry_, RTC_BUFFER_TYPE_VERTEX, 0);
  rtcCommitGeometry(geometry_);
  rtcCommitScene(scene_);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  device_->check("rtcCommitScene after a vertex update");
  return ms;
}

}  // namespace sahbench
