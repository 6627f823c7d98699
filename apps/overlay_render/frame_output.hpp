#pragma once
// What overlay_render writes for a frame, the same in both frames (docs/frames.md): color.png,
// depth.tiff and mask.png, the run's clock and its peak memory.
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <vector>

namespace gis::app {

/// color.png (RGB, top row first), depth.tiff (float depth as stored) and mask.png (bit i: the
/// scene file's layer i) in `out`; each failure is reported (it names the file). False if any failed.
bool writeFrameImages(const std::filesystem::path& out, int width, int height, const std::vector<std::uint8_t>& rgb,
                      const std::vector<float>& depth, const std::vector<std::uint8_t>& mask);

/// When the run started (options read), and how long it took to the first frame read back:
/// stats.json's first_frame_seconds in both frames.
struct RunClock {
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  double firstFrameSeconds = 0.0;
  /// Sets firstFrameSeconds to the time since start.
  void firstFrameDone();
};
RunClock& runClock();

/// The process's peak resident memory so far (bytes; 0 when it cannot be read). With Mesa's
/// software rasteriser the GPU's buffers live in it too.
std::size_t peakResidentBytes();

}  // namespace gis::app
