#include "gfx/image_io.hpp"

#include <OpenImageIO/imageio.h>

namespace gis::gfx {
namespace {

Diagnostic ioError(const std::string& path, const std::string& what) {
  return Diagnostic{Severity::Error, path, "", "", what};
}

Result<bool> write(const std::string& path, int width, int height, int channels, OIIO::TypeDesc type,
                   const void* pixels) {
  auto out = OIIO::ImageOutput::create(path);
  if (!out) return Result<bool>::failure(ioError(path, "cannot create image writer: " + OIIO::geterror()));
  OIIO::ImageSpec spec(width, height, channels, type);
  if (type == OIIO::TypeDesc::FLOAT) spec.attribute("compression", "zip");
  if (!out->open(path, spec) || !out->write_image(type, pixels) || !out->close()) {
    return Result<bool>::failure(ioError(path, "cannot write image: " + out->geterror()));
  }
  Result<bool> r;
  r.value = true;
  return r;
}

template <typename ImageT, typename T>
Result<ImageT> read(const std::string& path, OIIO::TypeDesc type) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) return Result<ImageT>::failure(ioError(path, "cannot open image: " + OIIO::geterror()));
  const OIIO::ImageSpec& spec = in->spec();
  ImageT image;
  image.width = spec.width;
  image.height = spec.height;
  image.channels = spec.nchannels;
  image.pixels.resize(static_cast<std::size_t>(spec.width) * static_cast<std::size_t>(spec.height) *
                      static_cast<std::size_t>(spec.nchannels));
  if (!in->read_image(0, 0, 0, spec.nchannels, type, image.pixels.data())) {
    return Result<ImageT>::failure(ioError(path, "cannot read image: " + in->geterror()));
  }
  Result<ImageT> r;
  r.value = std::move(image);
  return r;
}

}  // namespace

Result<bool> writeImage8(const std::string& path, int width, int height, int channels,
                         const std::vector<std::uint8_t>& pixels) {
  return write(path, width, height, channels, OIIO::TypeDesc::UINT8, pixels.data());
}

Result<bool> writeImageFloat(const std::string& path, int width, int height, const std::vector<float>& pixels) {
  return write(path, width, height, 1, OIIO::TypeDesc::FLOAT, pixels.data());
}

Result<Image8> readImage8(const std::string& path) { return read<Image8, std::uint8_t>(path, OIIO::TypeDesc::UINT8); }

Result<ImageFloat> readImageFloat(const std::string& path) {
  return read<ImageFloat, float>(path, OIIO::TypeDesc::FLOAT);
}

}  // namespace gis::gfx
