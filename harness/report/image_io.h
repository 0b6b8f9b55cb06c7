#pragma once
// Image files through OpenImageIO: float images (OpenEXR, raw values) and 8-bit RGB images (PNG) for
// viewing. Only this file knows OpenImageIO; the rest of the harness sees plain pixel arrays.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace sahbench {

/// A float image, pixels interleaved by channel, rows top to bottom: pixel (x, y) channel c is
/// pixels[(y * width + x) * channels.size() + c].
struct FloatImage {
  uint32_t width = 0, height = 0;
  std::vector<std::string> channels;  ///< channel names, e.g. {"Y"} or {"R", "G", "B"}
  std::vector<float> pixels;
  /// What the values are ("nodes", "depth", ...: `sahbench image`'s maps), kept in the file as the
  /// attribute sahbench:map; empty where unknown (a file without it).
  std::string kind;
  /// Read from a file of integer samples (an 8-bit PNG: a picture of values, not the values).
  bool from_integers = false;

  std::size_t channel_count() const { return channels.size(); }
  float at(uint32_t x, uint32_t y, std::size_t c = 0) const {
    return pixels[(std::size_t{y} * width + x) * channels.size() + c];
  }
};

/// An 8-bit RGB image, rows top to bottom.
struct RgbImage {
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> pixels;  ///< 3 bytes a pixel
};

/// Writes `image` as 32-bit float channels in the format the extension names (.exr). A file that cannot
/// be written is an Error naming it and OpenImageIO's reason.
void write_float_image(const std::filesystem::path& path, const FloatImage& image);

/// Writes `image` in the format the extension names (.png).
void write_rgb_image(const std::filesystem::path& path, const RgbImage& image);

/// Reads any image OpenImageIO reads (first subimage) as float channels.
FloatImage read_float_image(const std::filesystem::path& path);

}  // namespace sahbench
