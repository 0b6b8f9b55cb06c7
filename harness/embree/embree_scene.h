#pragma once
// Embree 3 as a reference builder: a device with a set thread count and a memory monitor, and a
// triangle scene built through rtcCommitScene at a chosen quality. Only the harness knows Embree.

#include <embree3/rtcore.h>

#include <atomic>
#include <cstdint>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/triangle.h"

namespace sahbench {

/// kRefit: a scene made to be refitted when its vertices move (EmbreeScene::update_vertices); its first
/// commit builds as usual.
enum class EmbreeQuality { kLow, kMedium, kHigh, kRefit };

/// "low", "medium", "high" or "refit"; anything else is an error naming the value.
EmbreeQuality parse_embree_quality(std::string_view text);
std::string to_string(EmbreeQuality quality);

/// The RTCBuildQuality for `quality` (rtcore_common.h).
RTCBuildQuality to_rtc(EmbreeQuality quality);

/// An Embree device. Its thread count is set through the device config ("threads=N"): pinning threads
/// before the device exists makes every Embree build single-threaded. `threads` = 0 leaves the config
/// out, so Embree follows TBB's own limits (tbb::global_control, the calling arena). Errors become
/// sahbench::Error.
///
/// Embree 3.13 (common/tasking/taskschedulertbb.cpp, kernels/common/device.cpp) turns "threads=N" into
/// a process-wide tbb::global_control(max_allowed_parallelism, N), and with several devices alive uses
/// the largest request of them all, a device without "threads=" counting as unlimited. So a device
/// created with 0 lifts every other device's limit while it lives; use it only where the caller sets
/// its own global_control.
class EmbreeDevice {
 public:
  explicit EmbreeDevice(int threads);
  ~EmbreeDevice();
  EmbreeDevice(const EmbreeDevice&) = delete;
  EmbreeDevice& operator=(const EmbreeDevice&) = delete;

  RTCDevice get() const { return device_; }
  /// Bytes Embree holds now, and the most it held since the last reset_peak (from its memory monitor).
  int64_t bytes() const { return bytes_.load(); }
  int64_t peak_bytes() const { return peak_.load(); }
  void reset_peak() { peak_.store(bytes_.load()); }
  /// Throws if Embree recorded an error since the last check on this thread (Embree 3 keeps one error
  /// code per thread and device); `what` says which call, and Embree's own message (from its error
  /// callback, e.g. "depth limit reached") is appended.
  void check(const char* what) const;
  /// rtcGetDeviceProperty (rtcore_device.h).
  ssize_t property(RTCDeviceProperty property) const { return rtcGetDeviceProperty(device_, property); }

 private:
  static bool monitor(void* user, ssize_t bytes, bool post);
  static void on_error(void* user, RTCError code, const char* message);
  RTCDevice device_ = nullptr;
  mutable std::mutex message_mutex_;
  std::string last_message_;  ///< Embree's message for the latest error, guarded by message_mutex_
  std::atomic<int64_t> bytes_{0};
  std::atomic<int64_t> peak_{0};
};

/// Scene flags (rtcSetSceneFlags, rtcore_scene.h). Both off by default, Embree's own default.
struct EmbreeSceneOptions {
  /// RTC_SCENE_FLAG_ROBUST: "avoid optimizations that reduce arithmetic accuracy". On this Embree it
  /// also swaps the triangle test from Moeller-Trumbore to the watertight Pluecker test
  /// (BVH8Triangle4vIntersector1Pluecker instead of BVH8Triangle4Intersector1Moeller, as verbose=2
  /// reports), so edge and vertex hits agree with our watertight reference.
  bool robust = false;
  /// RTC_SCENE_FLAG_DYNAMIC: the scene will be modified and recommitted (refit work).
  bool dynamic = false;

  friend bool operator==(const EmbreeSceneOptions&, const EmbreeSceneOptions&) = default;
};

/// A committed Embree scene of one triangle geometry. The vertex data is copied (Embree reads 16 bytes
/// past the last vertex, so the buffer is padded) and indices are 0..3n-1, so Embree's primID is the
/// scene triangle index.
///
/// EmbreeQuality::kRefit makes a scene that Embree refits: Embree 3 honours a geometry's build quality
/// (RTC_BUILD_QUALITY_REFIT here) only in its two-level mode, which it uses for a scene with
/// RTC_SCENE_FLAG_DYNAMIC and scene build quality RTC_BUILD_QUALITY_LOW (rtcSetGeometryBuildQuality(3):
/// "Embree currently uses the per-geometry build quality when the scene build quality is set to
/// RTC_BUILD_QUALITY_LOW"). With any other scene quality it silently rebuilds on every commit (measured:
/// the "refit" then takes as long as a rebuild). The constructor sets all three; options.dynamic is
/// implied.
class EmbreeScene {
 public:
  EmbreeScene(EmbreeDevice& device, std::span<const Triangle> triangles, EmbreeQuality quality,
              EmbreeSceneOptions options = {});
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  RTCScene get() const { return scene_; }
  EmbreeDevice& device() const { return *device_; }
  const EmbreeSceneOptions& options() const { return options_; }
  std::size_t triangle_count() const { return triangle_count_; }
  double commit_ms() const { return commit_ms_; }  ///< time of rtcCommitScene alone
  int64_t bytes() const { return bytes_; }         ///< Embree's bytes after the commit, buffers excluded

  /// Moves the vertices to `triangles` (same count and order as at construction) and recommits: copies
  /// them into Embree's vertex buffer, then rtcUpdateGeometryBuffer, rtcCommitGeometry and
  /// rtcCommitScene. Returns the milliseconds of those three calls (the copy is not timed: it stands
  /// for the application's own vertex update). A kRefit scene refits; any other rebuilds. Throws Error
  /// for a different triangle count or an Embree error.
  double update_vertices(std::span<const Triangle> triangles);

 private:
  EmbreeDevice* device_;
  EmbreeSceneOptions options_;
  std::size_t triangle_count_ = 0;
  RTCScene scene_ = nullptr;
  RTCGeometry geometry_ = nullptr;  // owned by scene_
  float* vertices_ = nullptr;       // Embree's vertex buffer
  double commit_ms_ = 0.0;
  int64_t bytes_ = 0;
};

}  // namespace sahbench
