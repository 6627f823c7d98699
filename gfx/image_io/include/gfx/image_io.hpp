#pragma once
// Image files through OpenImageIO. Pixels are top row first, channels interleaved.
#include <cstdint>
#include <string>
#include <vector>

#include "core/diagnostics.hpp"

namespace gis::gfx {

/// 8-bit image (1 = grey, 3 = RGB, 4 = RGBA) to PNG (or any format OIIO infers from the name).
Result<bool> writeImage8(const std::string& path, int width, int height, int channels,
                         const std::vector<std::uint8_t>& pixels);
/// One-channel float32 image (e.g. depth as stored) to TIFF.
Result<bool> writeImageFloat(const std::string& path, int width, int height, const std::vector<float>& pixels);

struct Image8 {
  int width = 0, height = 0, channels = 0;
  std::vector<std::uint8_t> pixels;
};
struct ImageFloat {
  int width = 0, height = 0, channels = 0;
  std::vector<float> pixels;
};
Result<Image8> readImage8(const std::string& path);
Result<ImageFloat> readImageFloat(const std::string& path);

}  // namespace gis::gfx
