// keepFreedHeapForFrames (core/heap.hpp): memory freed at the top of the heap stays with the
// process for the next frame instead of going back to the system, as llvmpipe's per-frame scene
// needs. glibc only; the sanitizer builds bring their own allocator and do not build this test.
// Each test runs in a process of its own (ctest), the first without the setting, as a control.
#include <malloc.h>

#include <cstddef>
#include <cstdlib>
#include <vector>

#include <gtest/gtest.h>

#include "core/heap.hpp"

namespace {

constexpr std::size_t kBlock = 64 * 1024;  // below glibc's first mmap threshold (128 KiB): heap
constexpr std::size_t kBlocks = 256;       // 16 MiB, as a frame's binned scene

/// Allocates a frame's worth of blocks, frees them (newest first, so they join the top of the
/// heap) and returns how much of the heap's top the process still holds afterwards.
std::size_t keptAfterAFrame() {
  std::vector<void*> blocks;
  blocks.reserve(kBlocks);
  for (std::size_t i = 0; i < kBlocks; ++i) {
    void* p = std::malloc(kBlock);
    if (p == nullptr) return 0;
    static_cast<volatile char*>(p)[0] = 1;  // touched, as a driver's memory is
    blocks.push_back(p);
  }
  for (auto it = blocks.rbegin(); it != blocks.rend(); ++it) std::free(*it);
  return mallinfo2().keepcost;
}

TEST(Heap, ByDefaultTheFreedTopOfTheHeapGoesBackToTheSystem) {
  // The control: what the setting is for. glibc trims the top beyond 128 KiB.
  EXPECT_LT(keptAfterAFrame(), kBlock * kBlocks / 4);
}

TEST(Heap, KeptForTheNextFrameOnceSet) {
  gis::keepFreedHeapForFrames();
  EXPECT_GE(keptAfterAFrame(), kBlock * kBlocks);
}

}  // namespace
