#pragma once
// Embree 3 as a reference builder: a device with a set thread count and a memory monitor, and a
// triangle scene built through rtcCommitScene at a chosen quality. Only the harness knows Embree.

#include <embree3/rtcore.h>

#include <atomic>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/triangle.h"

namespace sahbench {

enum class EmbreeQuality { kLow, kMedium, kHigh };

/// "low", "medium" or "high"; anything else is an error naming the value.
EmbreeQuality parse_embree_quality(std::string_view text);
std::string to_string(EmbreeQuality quality);

/// An Embree device. Its thread count is set through the device config ("threads=N"): pinning threads
/// before the device exists makes every Embree build single-threaded. Errors become sahbench::Error.
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
  /// Throws if Embree recorded an error since the last check; `what` says which call.
  void check(const char* what) const;

 private:
  static bool monitor(void* user, ssize_t bytes, bool post);
  RTCDevice device_ = nullptr;
  std::atomic<int64_t> bytes_{0};
  std::atomic<int64_t> peak_{0};
};

/// A committed Embree scene of one triangle geometry. The vertex data is copied (Embree reads 16 bytes
/// past the last vertex, so the buffer is padded) and indices are 0..3n-1.
class EmbreeScene {
 public:
  EmbreeScene(EmbreeDevice& device, std::span<const Triangle> triangles, EmbreeQuality quality);
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  RTCScene get() const { return scene_; }
  double commit_ms() const { return commit_ms_; }   ///< time of rtcCommitScene alone
  int64_t bytes() const { return bytes_; }          ///< Embree's bytes after the commit, buffers excluded

 private:
  RTCScene scene_ = nullptr;
  double commit_ms_ = 0.0;
  int64_t bytes_ = 0;
};

}  // namespace sahbench
