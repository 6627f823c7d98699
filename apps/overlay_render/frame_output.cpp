#include "frame_output.hpp"

#include <sys/resource.h>

#include "app/cli.hpp"
#include "gfx/image_io.hpp"

namespace gis::app {

bool writeFrameImages(const std::filesystem::path& out, int width, int height, const std::vector<std::uint8_t>& rgb,
                      const std::vector<float>& depth, const std::vector<std::uint8_t>& mask) {
  bool ok = true;
  for (const auto& written : {gfx::writeImage8((out / "color.png").string(), width, height, 3, rgb),
                              gfx::writeImageFloat((out / "depth.tiff").string(), width, height, depth),
                              gfx::writeImage8((out / "mask.png").string(), width, height, 1, mask)}) {
    report(written.diagnostics);
    ok = ok && written.ok();
  }
  return ok;
}

void RunClock::firstFrameDone() {
  firstFrameSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

RunClock& runClock() {
  static RunClock clock;
  return clock;
}

std::size_t peakResidentBytes() {
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0;
  return static_cast<std::size_t>(usage.ru_maxrss) * 1024;  // kilobytes on Linux
}

}  // namespace gis::app
