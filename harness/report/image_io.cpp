#include "harness/report/image_io.h"

#include <OpenImageIO/imageio.h>

#include "core/error.h"

namespace sahbench {
namespace {

void write_pixels(const std::filesystem::path& path, const OIIO::ImageSpec& spec, OIIO::TypeDesc type,
                  const void* data) {
  const std::string name = path.string();
  auto out = OIIO::ImageOutput::create(name);
  if (!out) throw Error(name + ": cannot write this image format: " + OIIO::geterror());
  if (!out->open(name, spec)) throw Error(name + ": cannot open for writing: " + out->geterror());
  if (!out->write_image(type, data)) throw Error(name + ": write failed: " + out->geterror());
  if (!out->close()) throw Error(name + ": write failed: " + out->geterror());
}

void check_size(const std::filesystem::path& path, std::size_t have, std::size_t want) {
  if (have != want)
    throw Error(path.string() + ": image has " + std::to_string(have) + " values, its size says " +
                std::to_string(want));
}

}  // namespace

void write_float_image(const std::filesystem::path& path, const FloatImage& image) {
  check_size(path, image.pixels.size(), std::size_t{image.width} * image.height * image.channel_count());
  OIIO::ImageSpec spec(static_cast<int>(image.width), static_cast<int>(image.height),
                       static_cast<int>(image.channel_count()), OIIO::TypeDesc::FLOAT);
  spec.channelnames = image.channels;
  // Lossless: the counts and depths are data, not pictures.
  spec.attribute("compression", "zip");
  if (!image.kind.empty()) spec.attribute("sahbench:map", image.kind);
  write_pixels(path, spec, OIIO::TypeDesc::FLOAT, image.pixels.data());
}

void write_rgb_image(const std::filesystem::path& path, const RgbImage& image) {
  check_size(path, image.pixels.size(), std::size_t{image.width} * image.height * 3);
  OIIO::ImageSpec spec(static_cast<int>(image.width), static_cast<int>(image.height), 3,
                       OIIO::TypeDesc::UINT8);
  write_pixels(path, spec, OIIO::TypeDesc::UINT8, image.pixels.data());
}

FloatImage read_float_image(const std::filesystem::path& path) {
  const std::string name = path.string();
  if (!std::filesystem::is_regular_file(path)) throw Error(name + ": no such image file");
  auto in = OIIO::ImageInput::open(name);
  if (!in) throw Error(name + ": cannot read image: " + OIIO::geterror());
  const OIIO::ImageSpec& spec = in->spec();
  FloatImage image;
  image.width = static_cast<uint32_t>(spec.width);
  image.height = static_cast<uint32_t>(spec.height);
  image.channels = spec.channelnames;
  image.channels.resize(static_cast<std::size_t>(spec.nchannels));
  image.kind = spec.get_string_attribute("sahbench:map");
  image.from_integers = !spec.format.is_floating_point();
  image.pixels.resize(std::size_t{image.width} * image.height * image.channel_count());
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, image.pixels.data()))
    throw Error(name + ": cannot read image: " + in->geterror());
  in->close();
  return image;
}

}  // namespace sahbench
