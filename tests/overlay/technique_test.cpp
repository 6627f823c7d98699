// The registry of overlay techniques (technique.hpp): what the programs enumerate must be
// complete and unambiguous, without a GL context.
#include <algorithm>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "vector_overlay/technique.hpp"

namespace gis::test {
namespace {

TEST(TechniqueRegistry, NamesAreUniqueAndEveryEntryIsComplete) {
  const std::span<const overlay::TechniqueInfo> all = overlay::techniques();
  ASSERT_GE(all.size(), 4u);
  std::set<std::string_view> names, labels;
  for (const overlay::TechniqueInfo& t : all) {
    SCOPED_TRACE(std::string(t.name));
    EXPECT_TRUE(names.insert(t.name).second) << "two techniques are called " << t.name;
    EXPECT_TRUE(labels.insert(t.label).second) << "two techniques are labelled " << t.label;
    EXPECT_FALSE(t.name.empty());
    // Names are typed on command lines and in scripts: lower case, digits and '-'.
    EXPECT_TRUE(std::all_of(t.name.begin(), t.name.end(),
                            [](char c) { return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-'; }));
    EXPECT_FALSE(t.description.empty());
    ASSERT_EQ(t.plotColour.size(), 7u);
    EXPECT_EQ(t.plotColour[0], '#');
    EXPECT_NE(t.create, nullptr);
    EXPECT_EQ(overlay::findTechnique(t.name), &t);
    if (t.usesTextures()) {
      EXPECT_NE(std::find(t.textureSizes.begin(), t.textureSizes.end(), t.defaultTextureSize), t.textureSizes.end())
          << "the default size is one the viewer offers";
    } else {
      EXPECT_TRUE(t.textureSizes.empty());
    }
  }
}

TEST(TechniqueRegistry, OursIsTheDefaultAndNamesAreListedForMessages) {
  EXPECT_EQ(&overlay::defaultTechnique(), &overlay::techniques().front());
  // Ours, in view-dependent tiles; "stencil" builds every piece at load.
  EXPECT_EQ(overlay::defaultTechnique().name, "stencil-tiles");
  EXPECT_EQ(overlay::defaultTechnique().construction, overlay::PieceConstruction::Tiled);
  ASSERT_NE(overlay::findTechnique("stencil"), nullptr);
  EXPECT_EQ(overlay::findTechnique("stencil")->construction, overlay::PieceConstruction::Ours);
  ASSERT_NE(overlay::findTechnique("paper"), nullptr);
  EXPECT_EQ(overlay::findTechnique("paper")->construction, overlay::PieceConstruction::Paper);
  EXPECT_EQ(overlay::findTechnique("raster"), nullptr);
  EXPECT_EQ(overlay::findTechnique(""), nullptr);
  ASSERT_NE(overlay::findTechnique("deferred"), nullptr);
  // The lookup wherever it can, pieces in view tiles for the rest (as `auto` when it takes the
  // lookup): lines at their widths in pixels, as the tiles draw them.
  EXPECT_EQ(overlay::findTechnique("deferred")->construction, overlay::PieceConstruction::Tiled);
  EXPECT_TRUE(overlay::findTechnique("deferred")->looksUp);
  EXPECT_FALSE(overlay::findTechnique("auto")->looksUp);
  EXPECT_EQ(overlay::techniqueNameList(), "stencil-tiles, stencil, paper, drape, drape-tiles, deferred or auto");
}

}  // namespace
}  // namespace gis::test
