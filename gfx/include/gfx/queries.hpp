#pragma once
// GPU timer queries and pipeline-statistics queries, for benchmarks and the HUD.
// Fragment counts are deterministic on one machine; wall time is not.
#include <array>
#include <cstdint>
#include <optional>

#include "gfx/handles.hpp"

namespace gis::gfx {

/// GL_TIME_ELAPSED around a range of commands. Only one may be active at a time (GL rule).
class GpuTimer {
 public:
  GpuTimer();
  void begin();
  void end();
  /// Nanoseconds; waits for the GPU when `wait`, otherwise nullopt until available.
  [[nodiscard]] std::optional<std::uint64_t> nanoseconds(bool wait = true) const;

 private:
  QueryHandle query_;
};

/// Counters of ARB_pipeline_statistics_query (core in GL 4.6, supported by llvmpipe) plus
/// samples passed. Only one set may be active at a time.
struct PipelineCounts {
  std::uint64_t verticesSubmitted = 0;
  std::uint64_t primitivesSubmitted = 0;
  std::uint64_t vertexShaderInvocations = 0;
  std::uint64_t clippingInputPrimitives = 0;
  std::uint64_t clippingOutputPrimitives = 0;
  std::uint64_t fragmentShaderInvocations = 0;
  std::uint64_t samplesPassed = 0;

  PipelineCounts& operator+=(const PipelineCounts& o);
};

class PipelineStatistics {
 public:
  /// `available()` is false when the extension is missing; then begin/end do nothing.
  PipelineStatistics();
  [[nodiscard]] bool available() const { return available_; }
  void begin();
  void end();
  /// Waits for the results.
  [[nodiscard]] PipelineCounts result() const;

 private:
  static constexpr std::size_t kCount = 7;
  bool available_ = false;
  std::array<QueryHandle, kCount> queries_;
};

}  // namespace gis::gfx
