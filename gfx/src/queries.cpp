#include "gfx/queries.hpp"

namespace gis::gfx {
namespace {

constexpr std::array<GLenum, 7> kStatisticTargets{GL_VERTICES_SUBMITTED_ARB,
                                                  GL_PRIMITIVES_SUBMITTED_ARB,
                                                  GL_VERTEX_SHADER_INVOCATIONS_ARB,
                                                  GL_CLIPPING_INPUT_PRIMITIVES_ARB,
                                                  GL_CLIPPING_OUTPUT_PRIMITIVES_ARB,
                                                  GL_FRAGMENT_SHADER_INVOCATIONS_ARB,
                                                  GL_SAMPLES_PASSED};

std::uint64_t queryResult(GLuint id, bool wait, bool* ready) {
  GLint available = GL_TRUE;
  if (!wait) glGetQueryObjectiv(id, GL_QUERY_RESULT_AVAILABLE, &available);
  if (ready) *ready = available == GL_TRUE;
  if (available != GL_TRUE) return 0;
  GLuint64 value = 0;
  glGetQueryObjectui64v(id, GL_QUERY_RESULT, &value);
  return value;
}

}  // namespace

GpuTimer::GpuTimer() : query_(createQuery(GL_TIME_ELAPSED)) {}
void GpuTimer::begin() { glBeginQuery(GL_TIME_ELAPSED, query_.id()); }
void GpuTimer::end() { glEndQuery(GL_TIME_ELAPSED); }

std::optional<std::uint64_t> GpuTimer::nanoseconds(bool wait) const {
  bool ready = false;
  const std::uint64_t ns = queryResult(query_.id(), wait, &ready);
  if (!ready) return std::nullopt;
  return ns;
}

PipelineCounts& PipelineCounts::operator+=(const PipelineCounts& o) {
  verticesSubmitted += o.verticesSubmitted;
  primitivesSubmitted += o.primitivesSubmitted;
  vertexShaderInvocations += o.vertexShaderInvocations;
  clippingInputPrimitives += o.clippingInputPrimitives;
  clippingOutputPrimitives += o.clippingOutputPrimitives;
  fragmentShaderInvocations += o.fragmentShaderInvocations;
  samplesPassed += o.samplesPassed;
  return *this;
}

PipelineStatistics::PipelineStatistics()
    : available_(epoxy_has_gl_extension("GL_ARB_pipeline_statistics_query") || epoxy_gl_version() >= 46) {
  if (!available_) return;
  for (std::size_t i = 0; i < kCount; ++i) queries_[i] = createQuery(kStatisticTargets[i]);
}

void PipelineStatistics::begin() {
  if (!available_) return;
  for (std::size_t i = 0; i < kCount; ++i) glBeginQuery(kStatisticTargets[i], queries_[i].id());
}

void PipelineStatistics::end() {
  if (!available_) return;
  for (std::size_t i = 0; i < kCount; ++i) glEndQuery(kStatisticTargets[i]);
}

PipelineCounts PipelineStatistics::result() const {
  PipelineCounts c;
  if (!available_) return c;
  std::array<std::uint64_t, kCount> v{};
  for (std::size_t i = 0; i < kCount; ++i) v[i] = queryResult(queries_[i].id(), true, nullptr);
  c.verticesSubmitted = v[0];
  c.primitivesSubmitted = v[1];
  c.vertexShaderInvocations = v[2];
  c.clippingInputPrimitives = v[3];
  c.clippingOutputPrimitives = v[4];
  c.fragmentShaderInvocations = v[5];
  c.samplesPassed = v[6];
  return c;
}

}  // namespace gis::gfx
