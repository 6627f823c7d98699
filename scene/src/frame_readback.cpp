#include "scene/frame_readback.hpp"

#include <algorithm>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "vector_overlay/selection_states.hpp"

namespace gis::scene {

Result<SelectionPixels> drawSelection(gfx::StateCache& cache, const gfx::RenderTarget& target,
                                      const SelectionRequest& request, const Camera& camera) {
  return drawSelection(
      cache, target, request,
      overlayViewOf(camera, static_cast<double>(target.width()) / static_cast<double>(target.height())));
}

Result<SelectionPixels> drawSelection(gfx::StateCache& cache, const gfx::RenderTarget& target,
                                      const SelectionRequest& request, const overlay::OverlayView& view) {
  Result<SelectionPixels> result;
  Result<overlay::SelectionRenderer> renderer = overlay::SelectionRenderer::create();
  result.diagnostics = std::move(renderer.diagnostics);
  if (!renderer) return result;
  result.diagnostics.append(renderer->setSteps(request.steps));
  cache.bindDrawTarget(target.framebuffer(), target.width(), target.height());
  gfx::enableMaskWrites(target.framebuffer(), false);
  overlay::SelectionSettings settings;
  settings.scheme = request.scheme;
  settings.measure = true;
  SelectionPixels out;
  out.stats = renderer->select(cache, view, settings);
  const std::vector<std::uint8_t> stencil = gfx::readStencil(target);
  const std::vector<float> depth = gfx::readDepth(target);
  out.pixels.resize(stencil.size());
  for (std::size_t i = 0; i < stencil.size(); ++i) {
    const bool selected = request.scheme == overlay::SelectionScheme::Runs ? (stencil[i] & overlay::kSelectedBit) != 0
                                                                           : depth[i] > 0.0F && stencil[i] == 1;
    out.pixels[i] = selected ? 255 : 0;
  }
  renderer->highlight(cache, request.highlight, settings);
  if (request.showVolumes) renderer->drawVolumes(cache, view, *request.showVolumes);
  gfx::enableMaskWrites(target.framebuffer(), true);
  result.value = std::move(out);
  return result;
}

std::optional<std::size_t> fillLayerNamed(const LoadedScene& scene, const SceneRenderer& renderer,
                                          std::string_view name) {
  for (std::size_t j = 0; j < renderer.overlaySources().size(); ++j) {
    const auto& [layer, outline] = renderer.overlaySources()[j];
    if (!outline && scene.layers[layer].description.name == name) return j;
  }
  return std::nullopt;
}

OverlapPixels drawOverlap(gfx::StateCache& cache, const gfx::RenderTarget& target, SceneRenderer& renderer,
                          std::size_t a, std::size_t b, overlay::OverlapOp op, const overlay::OverlayView& view) {
  OverlapPixels out = drawOverlap(cache, target, renderer.overlayRenderer(), renderer.drawnChunks(a),
                                  renderer.drawnChunks(b), op, view);
  out.a = a;
  out.b = b;
  return out;
}

OverlapPixels drawOverlap(gfx::StateCache& cache, const gfx::RenderTarget& target, overlay::OverlayRenderer& renderer,
                          std::span<const overlay::OverlayLayer* const> a,
                          std::span<const overlay::OverlayLayer* const> b, overlay::OverlapOp op,
                          const overlay::OverlayView& view) {
  OverlapPixels out{0, 1, {}, {}};
  cache.bindDrawTarget(target.framebuffer(), target.width(), target.height());
  gfx::enableMaskWrites(target.framebuffer(), false);  // the overlay mask stays as the layers left it
  overlay::OverlaySettings settings;
  settings.measure = true;
  out.marks = renderer.markOverlap(cache, view, a, b, settings);
  out.flags = gfx::readStencil(target);
  renderer.coverOverlap(cache, out.marks, op, kOverlapColour);
  gfx::enableMaskWrites(target.framebuffer(), true);
  return out;
}

OpenVolumePixels drawOpenVolumes(gfx::StateCache& cache, const gfx::RenderTarget& target, SceneRenderer& renderer,
                                 const overlay::OverlayView& view) {
  std::vector<ChunkedLayer> layers;
  for (std::size_t j = 0; j < renderer.overlayLayers().size(); ++j) {
    const auto chunks = renderer.drawnChunks(j);
    layers.push_back({renderer.overlayLayers()[j].name(), {chunks.begin(), chunks.end()}});
  }
  return drawOpenVolumes(cache, target, renderer.overlayRenderer(), layers, view);
}

OpenVolumePixels drawOpenVolumes(gfx::StateCache& cache, const gfx::RenderTarget& target,
                                 overlay::OverlayRenderer& renderer, std::span<const ChunkedLayer> layers,
                                 const overlay::OverlayView& view) {
  OpenVolumePixels out;
  cache.bindDrawTarget(target.framebuffer(), target.width(), target.height());
  gfx::enableMaskWrites(target.framebuffer(), false);
  overlay::OverlaySettings settings;
  settings.measure = true;
  out.pixels.assign(static_cast<std::size_t>(target.width()) * static_cast<std::size_t>(target.height()), 0);
  for (const ChunkedLayer& layer : layers) {
    OpenVolumeLayer counted{layer.name, 0, renderer.countOpenFaces(cache, view, layer.chunks, settings)};
    const std::vector<std::uint8_t> counts = gfx::readStencil(target);
    renderer.coverOpenFaces(cache, counted.marks, kOpenVolumeColour);
    for (std::size_t i = 0; i < counts.size() && i < out.pixels.size(); ++i) {
      if (counts[i] == 0) continue;
      ++counted.openPixels;
      out.pixels[i] = 255;
    }
    out.layers.push_back(std::move(counted));
  }
  for (std::uint8_t p : out.pixels) out.openPixels += p != 0 ? 1u : 0u;
  gfx::enableMaskWrites(target.framebuffer(), true);
  return out;
}

namespace {

constexpr std::size_t kMaskBits = 8;  // mask.png is 8-bit: the scene file's first 8 layers
constexpr std::size_t kGpuBits = 32;  // the GPU mask's bits: one per drawn layer

/// Per pixel, the votes of one sample's GPU mask `bits`: per scene-file layer 1 when some drawn
/// layer of it covers the pixel (a fill and an outline of one scene layer vote once), and per GPU
/// bit 1 when its layer does.
void addVotes(std::span<const std::size_t> fileIndexOfBit, const std::vector<std::uint32_t>& bits, std::size_t pixels,
              std::vector<int>& layerVotes, std::vector<int>& bitVotes) {
  const std::size_t used = std::min(fileIndexOfBit.size(), kGpuBits);
  for (std::size_t i = 0; i < pixels && i < bits.size(); ++i) {
    std::uint8_t layers = 0;
    for (std::size_t j = 0; j < used; ++j) {
      if (((bits[i] >> j) & 1U) == 0U) continue;
      ++bitVotes[i * kGpuBits + j];
      if (fileIndexOfBit[j] < kMaskBits) layers = static_cast<std::uint8_t>(layers | (1U << fileIndexOfBit[j]));
    }
    for (std::size_t layer = 0; layer < kMaskBits; ++layer) layerVotes[i * kMaskBits + layer] += (layers >> layer) & 1;
  }
}

}  // namespace

FrameImages readFrame(gfx::StateCache& cache, const gfx::RenderTarget& target,
                      std::span<const std::size_t> fileIndexOfBit) {
  FrameImages frame;
  std::optional<gfx::RenderTarget> resolved;
  if (target.multisampled()) resolved.emplace(target.width(), target.height(), 0, true);
  frame.samples = target.samples();
  const std::size_t pixels = static_cast<std::size_t>(target.width()) * static_cast<std::size_t>(target.height());
  std::vector<int> layerVotes(pixels * kMaskBits, 0), bitVotes(pixels * kGpuBits, 0);
  int samples = 1;
  if (resolved) {
    samples = target.samples();
    for (int k = 0; k < samples; ++k) {
      target.copySampleInto(cache, *resolved, k);
      addVotes(fileIndexOfBit, gfx::readMask(*resolved), pixels, layerVotes, bitVotes);
    }
  } else {
    addVotes(fileIndexOfBit, gfx::readMask(target), pixels, layerVotes, bitVotes);
  }
  frame.mask.assign(pixels, 0);
  frame.coveredPixels.assign(std::min(fileIndexOfBit.size(), kGpuBits), 0);
  for (std::size_t i = 0; i < pixels; ++i) {
    for (std::size_t layer = 0; layer < kMaskBits; ++layer) {
      if (2 * layerVotes[i * kMaskBits + layer] >= samples)
        frame.mask[i] = static_cast<std::uint8_t>(frame.mask[i] | (1U << layer));
    }
    for (std::size_t j = 0; j < frame.coveredPixels.size(); ++j)
      frame.coveredPixels[j] += bitVotes[i * kGpuBits + j] > 0 && 2 * bitVotes[i * kGpuBits + j] >= samples ? 1U : 0U;
  }
  if (resolved) target.resolveInto(*resolved);
  const gfx::RenderTarget& readable = resolved ? *resolved : target;
  const std::vector<std::uint8_t> rgba = gfx::readColorRgba8(readable);
  frame.depth = gfx::readDepth(readable);
  frame.rgb.resize(rgba.size() / 4 * 3);
  for (std::size_t i = 0, n = rgba.size() / 4; i < n; ++i) {
    for (std::size_t c = 0; c < 3; ++c) frame.rgb[i * 3 + c] = rgba[i * 4 + c];
  }
  return frame;
}

FrameImages readFrame(gfx::StateCache& cache, const LoadedScene& scene, const SceneRenderer& renderer,
                      const gfx::RenderTarget& target) {
  std::vector<std::size_t> fileIndexOfBit;
  for (const auto& source : renderer.overlaySources())
    fileIndexOfBit.push_back(scene.layers[source.first].description.fileIndex);
  return readFrame(cache, target, fileIndexOfBit);
}

}  // namespace gis::scene
