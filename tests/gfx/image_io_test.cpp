// PNG and TIFF through OpenImageIO: what is written reads back bit for bit.
#include <filesystem>
#include <random>

#include <gtest/gtest.h>

#include "gfx/image_io.hpp"
#include "test_paths.hpp"

namespace gis::test {
namespace {

std::filesystem::path outputDir() {
  std::filesystem::path dir(STENCIL_GIS_TEST_OUTPUT_DIR);
  std::filesystem::create_directories(dir);
  return dir;
}

TEST(ImageIo, PngRoundTripIsExact) {
  std::mt19937 rng(1);
  std::vector<std::uint8_t> pixels(37 * 23 * 3);
  for (auto& p : pixels) p = static_cast<std::uint8_t>(rng());
  const std::string path = (outputDir() / "round_trip.png").string();
  ASSERT_TRUE(gfx::writeImage8(path, 37, 23, 3, pixels).ok());
  Result<gfx::Image8> back = gfx::readImage8(path);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(back->width, 37);
  EXPECT_EQ(back->height, 23);
  EXPECT_EQ(back->channels, 3);
  EXPECT_EQ(back->pixels, pixels);
}

TEST(ImageIo, FloatTiffRoundTripIsExact) {
  std::vector<float> depth(31 * 17);
  for (std::size_t i = 0; i < depth.size(); ++i) depth[i] = 1.0F / static_cast<float>(i + 1);
  const std::string path = (outputDir() / "depth.tiff").string();
  ASSERT_TRUE(gfx::writeImageFloat(path, 31, 17, depth).ok());
  Result<gfx::ImageFloat> back = gfx::readImageFloat(path);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(back->pixels, depth);
}

TEST(ImageIo, UnwritablePathIsAnErrorNotACrash) {
  Result<bool> r = gfx::writeImage8("/nonexistent-dir/x.png", 2, 2, 1, std::vector<std::uint8_t>(4));
  EXPECT_FALSE(r.ok());
  ASSERT_FALSE(r.diagnostics.empty());
  EXPECT_NE(r.diagnostics.items().front().toString().find("/nonexistent-dir/x.png"), std::string::npos);
}

}  // namespace
}  // namespace gis::test
