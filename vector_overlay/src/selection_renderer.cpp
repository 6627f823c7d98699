#include "vector_overlay/selection_renderer.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "gfx/camera.hpp"
#include "vector_overlay/selection_states.hpp"

namespace gis::overlay {
namespace {

constexpr glm::vec4 kFullScreen{-1.0F, -1.0F, 1.0F, 1.0F};

/// The plane (a, b, c, d) through three homogeneous points: the cofactor vector of the 3 × 4
/// matrix of their coordinates (zero when they are dependent).
glm::dvec4 planeThrough(const glm::dvec4& p, const glm::dvec4& q, const glm::dvec4& r) {
  const auto minor = [&](int i, int j, int k) {
    const auto at = [](const glm::dvec4& v, int n) { return v[static_cast<glm::dvec4::length_type>(n)]; };
    return at(p, i) * (at(q, j) * at(r, k) - at(q, k) * at(r, j)) -
           at(p, j) * (at(q, i) * at(r, k) - at(q, k) * at(r, i)) +
           at(p, k) * (at(q, i) * at(r, j) - at(q, j) * at(r, i));
  };
  return {minor(1, 2, 3), -minor(0, 2, 3), minor(0, 1, 3), -minor(0, 1, 2)};
}

}  // namespace

Result<SelectionRenderer> SelectionRenderer::create() {
  Result<gfx::Program> volume = gfx::Program::build({{"lasso_volume.vert", {}}, {"overlay_volume.frag", {}}});
  Result<gfx::Program> rect = gfx::Program::build({{"overlay_cover.vert", {}}, {"overlay_volume.frag", {}}});
  Result<SelectionRenderer> r;
  r.diagnostics = volume.diagnostics;
  r.diagnostics.append(rect.diagnostics);
  if (!volume || !rect) return r;
  SelectionRenderer renderer;
  renderer.volumeProgram_ = std::move(*volume);
  renderer.rectProgram_ = std::move(*rect);
  renderer.emptyVao_ = gfx::createVertexArray();
  renderer.vao_ = gfx::createVertexArray();
  glEnableVertexArrayAttrib(renderer.vao_.id(), 0);
  glVertexArrayAttribFormat(renderer.vao_.id(), 0, 4, GL_FLOAT, GL_FALSE, 0);
  glVertexArrayAttribBinding(renderer.vao_.id(), 0, 0);
  renderer.timer_.emplace();
  renderer.stats_.emplace();
  r.value = std::move(renderer);
  return r;
}

Diagnostics SelectionRenderer::setSteps(std::vector<SelectionStep> steps) {
  Diagnostics diagnostics;
  steps_ = std::move(steps);
  volumes_.clear();
  for (std::size_t i = 0; i < steps_.size(); ++i) {
    volumes_.push_back(steps_[i].op == SelectionOp::Invert
                           ? LassoVolume{}
                           : buildLassoVolume(steps_[i].lasso, "lasso " + std::to_string(i + 1), diagnostics));
  }
  return diagnostics;
}

void SelectionRenderer::upload(const OverlayView& view) {
  // Homogeneous coordinates relative to the eye: (x − eye · w, w).
  const glm::dmat4 relative = view.viewProj * glm::translate(glm::dmat4(1.0), view.eye);
  const glm::dvec4 wRow(relative[0][3], relative[1][3], relative[2][3], relative[3][3]);
  const double wMin = 0.5 * view.nearPlane;
  // Keep where clip w ≥ wMin (for a point at infinity: in front of the eye).
  const auto f = [&](const glm::dvec4& h) { return glm::dot(wRow, h) - wMin * h.w; };
  std::vector<glm::vec4> out;
  ranges_.assign(steps_.size(), Range{});
  for (std::size_t s = 0; s < volumes_.size(); ++s) {
    Range& range = ranges_[s];
    range.first = static_cast<GLint>(out.size());
    glm::dvec2 lo(1.0), hi(-1.0);
    bool whole = false;
    const auto emit = [&](const glm::dvec4& h) {
      out.emplace_back(static_cast<float>(h.x), static_cast<float>(h.y), static_cast<float>(h.z),
                       static_cast<float>(h.w));
      const glm::dvec4 c = relative * h;
      if (!(c.w > 1e-9 * view.nearPlane)) {
        whole = true;  // in the eye plane (a direction sideways): its image is unbounded
        return;
      }
      lo = glm::min(lo, glm::dvec2(c) / c.w);
      hi = glm::max(hi, glm::dvec2(c) / c.w);
    };
    for (const auto& t : volumes_[s].triangles) {
      std::array<glm::dvec4, 3> v;
      for (std::size_t k = 0; k < 3; ++k) v[k] = glm::dvec4(glm::dvec3(t[k]) - view.eye * t[k].w, t[k].w);
      // A face whose plane passes through the eye is seen edge on (every wall of a lasso drawn
      // from this very camera): it covers no area, but rounded it may become a sliver that
      // counts. Leave it out when the eye is within 1e-7 of its nearest finite vertex's distance.
      // (A dark cap at infinity lies in the plane at infinity: never edge on.)
      double nearest = std::numeric_limits<double>::infinity();
      for (const glm::dvec4& h : v)
        if (h.w != 0.0) nearest = std::min(nearest, glm::length(glm::dvec3(h) / h.w));
      if (std::isfinite(nearest)) {
        const glm::dvec4 plane = planeThrough(v[0], v[1], v[2]);
        const double normal = glm::length(glm::dvec3(plane));
        if (!(normal > 0.0) || std::abs(plane.w) <= 1e-7 * nearest * normal) continue;
      }
      std::array<double, 3> d{f(v[0]), f(v[1]), f(v[2])};
      int inside = 0;
      for (double x : d) inside += x >= 0.0 ? 1 : 0;
      if (inside == 0) continue;
      if (inside == 3) {
        for (const glm::dvec4& h : v) emit(h);
        continue;
      }
      std::vector<glm::dvec4> poly;
      for (std::size_t k = 0; k < 3; ++k) {
        const std::size_t n = (k + 1) % 3;
        const bool in = d[k] >= 0.0, nextIn = d[n] >= 0.0;
        if (in) poly.push_back(v[k]);
        if (in != nextIn) poly.push_back(v[k] + (d[k] / (d[k] - d[n])) * (v[n] - v[k]));
      }
      for (std::size_t k = 1; k + 1 < poly.size(); ++k) {
        emit(poly[0]);
        emit(poly[k]);
        emit(poly[k + 1]);
      }
    }
    range.count = static_cast<GLsizei>(out.size()) - range.first;
    if (range.count > 0) {
      range.rect = whole ? kFullScreen
                         : glm::vec4(static_cast<float>(std::max(lo.x, -1.0)), static_cast<float>(std::max(lo.y, -1.0)),
                                     static_cast<float>(std::min(hi.x, 1.0)), static_cast<float>(std::min(hi.y, 1.0)));
    }
  }
  const std::size_t bytes = out.size() * sizeof(glm::vec4);
  if (bytes == 0) return;
  if (!vertices_ || capacity_ < bytes) {
    capacity_ = std::max(bytes, 2 * capacity_);
    vertices_ = gfx::createBuffer();
    glNamedBufferData(vertices_.id(), static_cast<GLsizeiptr>(capacity_), nullptr, GL_STREAM_DRAW);
  }
  glNamedBufferSubData(vertices_.id(), 0, static_cast<GLsizeiptr>(bytes), out.data());
  glVertexArrayVertexBuffer(vao_.id(), 0, vertices_.id(), 0, sizeof(glm::vec4));
}

void SelectionRenderer::drawRect(gfx::StateCache& cache, const glm::vec4& rect) {
  if (!(rect.z > rect.x && rect.w > rect.y)) return;
  cache.useProgram(rectProgram_);
  cache.bindVertexArray(emptyVao_.id());
  glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
}

void SelectionRenderer::drawStep(gfx::StateCache& cache, std::size_t step) {
  const Range& r = ranges_[step];
  if (r.count == 0) return;
  cache.useProgram(volumeProgram_);
  cache.bindVertexArray(vao_.id());
  glDrawArrays(GL_TRIANGLES, r.first, r.count);
}

SelectionFrameStats SelectionRenderer::select(gfx::StateCache& cache, const OverlayView& view,
                                              const SelectionSettings& settings) {
  SelectionFrameStats stats;
  if (steps_.empty()) return stats;
  if (settings.measure) {
    timer_->begin();
    stats_->begin();
  }
  upload(view);
  for (const Range& r : ranges_) stats.triangles += static_cast<std::size_t>(r.count) / 3;
  volumeProgram_.set("u_modelViewProj", gfx::relativeToCentre(view.viewProj, view.eye));
  volumeProgram_.set("u_color", glm::vec4(0.0F));
  volumeProgram_.set("u_maskBit", 0.0F);
  rectProgram_.set("u_color", glm::vec4(0.0F));
  rectProgram_.set("u_maskBit", 0.0F);
  const auto mark = [&](std::size_t i, const gfx::PipelineState& state) {
    cache.apply(state);
    drawStep(cache, i);
    ++stats.markDraws;
    ++stats.volumes;
  };
  const auto screen = [&](const gfx::PipelineState& state, const glm::vec4& rect) {
    cache.apply(state);
    rectProgram_.set("u_rect", rect);
    drawRect(cache, rect);
    ++stats.screenPasses;
  };

  if (settings.scheme == SelectionScheme::Report) {
    for (std::size_t i = 0; i < steps_.size(); ++i) {
      switch (steps_[i].op) {
        case SelectionOp::Invert:
          screen(kReportInvertIncrement, kFullScreen);
          screen(kReportReduceXor, kFullScreen);
          break;
        case SelectionOp::Single:
          screen(kSelectClear, kFullScreen);
          mark(i, kReportMarkAdd);
          break;
        case SelectionOp::Or:
          mark(i, kReportMarkAdd);
          screen(kReportReduceOr, kFullScreen);
          break;
        case SelectionOp::And:
          mark(i, kReportMarkAdd);
          screen(kReportReduceAnd, kFullScreen);
          break;
        case SelectionOp::Xor:
          mark(i, kReportMarkAdd);
          screen(kReportReduceXor, kFullScreen);
          break;
        case SelectionOp::Subtract:
          mark(i, kReportMarkSubtract);
          screen(kReportReduceSubtract, kFullScreen);
          break;
      }
    }
  } else {
    // Runs of one operator (a Single followed by Ors is one run), each with one combine pass.
    std::size_t i = 0;
    while (i < steps_.size()) {
      const SelectionOp op = steps_[i].op;
      if (op == SelectionOp::Invert) {
        screen(kSelectInvert, kFullScreen);
        ++i;
        continue;
      }
      const SelectionOp follower = op == SelectionOp::Single ? SelectionOp::Or : op;
      const std::size_t limit =
          op == SelectionOp::And ? 1 : (op == SelectionOp::Xor ? steps_.size() : kSelectionRunSize);
      std::size_t end = i + 1;
      while (end < steps_.size() && end - i < limit && steps_[end].op == follower) ++end;
      glm::vec4 rect(1.0F, 1.0F, -1.0F, -1.0F);
      for (std::size_t k = i; k < end; ++k) {
        mark(k, op == SelectionOp::Xor ? kSelectMarkParity : kSelectMarkCount);
        const glm::vec4& r = ranges_[k].rect;
        if (r.z > r.x && r.w > r.y) {
          rect = glm::vec4(std::min(rect.x, r.x), std::min(rect.y, r.y), std::max(rect.z, r.z), std::max(rect.w, r.w));
        }
      }
      switch (op) {
        case SelectionOp::Single:
          screen(kSelectCombineSingle, kFullScreen);
          break;
        case SelectionOp::And:
          screen(kSelectCombineAnd, kFullScreen);
          break;
        case SelectionOp::Or:
          screen(kSelectCombineOr, rect);
          break;
        case SelectionOp::Subtract:
          screen(kSelectCombineSubtract, rect);
          break;
        case SelectionOp::Xor:
          screen(kSelectCombineXor, rect);
          break;
        case SelectionOp::Invert:
          break;
      }
      i = end;
    }
  }
  if (settings.measure) {
    stats_->end();
    timer_->end();
    stats.gpuMilliseconds = static_cast<double>(timer_->nanoseconds().value_or(0)) * 1e-6;
    stats.fragments = stats_->result().fragmentShaderInvocations;
  }
  return stats;
}

void SelectionRenderer::highlight(gfx::StateCache& cache, const SelectionStyle& style,
                                  const SelectionSettings& settings) {
  cache.apply(settings.scheme == SelectionScheme::Report ? kReportHighlight : kSelectHighlight);
  rectProgram_.set("u_rect", kFullScreen);
  rectProgram_.set("u_color", glm::vec4(glm::vec3(style.color), style.color.w * style.opacity));
  rectProgram_.set("u_maskBit", 0.0F);
  drawRect(cache, kFullScreen);
}

void SelectionRenderer::clear(gfx::StateCache& cache) {
  cache.apply(kSelectClear);
  rectProgram_.set("u_rect", kFullScreen);
  drawRect(cache, kFullScreen);
}

void SelectionRenderer::drawVolumes(gfx::StateCache& cache, const OverlayView& view, const glm::vec4& colour) {
  if (steps_.empty()) return;
  upload(view);
  cache.apply(kSelectShowVolumes);
  volumeProgram_.set("u_modelViewProj", gfx::relativeToCentre(view.viewProj, view.eye));
  volumeProgram_.set("u_color", colour);
  volumeProgram_.set("u_maskBit", 0.0F);
  for (std::size_t i = 0; i < steps_.size(); ++i) drawStep(cache, i);
}

}  // namespace gis::overlay
