#pragma once
// Fixture for *_gltest: one headless OpenGL 4.5 core context per test program (EGL, Mesa
// surfaceless), reversed-Z on, and a check after every test that the KHR_debug output reported
// no GL error.
#include <memory>

#include <gtest/gtest.h>

#include "gfx/camera.hpp"
#include "gfx/context.hpp"
#include "gfx/state_cache.hpp"

namespace gis::test {

class GlTest : public ::testing::Test {
 public:
  static void SetUpTestSuite() {
    if (!context()) {
      Result<std::unique_ptr<gfx::Context>> created = gfx::createHeadlessContext({});
      ASSERT_TRUE(created.ok()) << (created.diagnostics.empty() ? std::string("no context")
                                                                : created.diagnostics.items().front().toString());
      context() = std::move(*created);
    }
  }

 protected:
  void SetUp() override {
    ASSERT_NE(context(), nullptr);
    context()->makeCurrent();
    context()->debug().reset();
    gfx::enableReversedZ();
    cache_.invalidate();
    cache_.apply(gfx::kOpaque);
  }

  void TearDown() override {
    glFinish();
    const auto& debug = context()->debug();
    EXPECT_EQ(debug.errorCount(), 0u) << "GL errors reported by KHR_debug:\n" << joined(debug.errorMessages());
  }

  static std::unique_ptr<gfx::Context>& context() {
    static std::unique_ptr<gfx::Context> ctx;
    return ctx;
  }

  static std::string joined(const std::vector<std::string>& lines) {
    std::string out;
    for (const std::string& l : lines) out += l + "\n";
    return out;
  }

  gfx::StateCache cache_;
};

}  // namespace gis::test
