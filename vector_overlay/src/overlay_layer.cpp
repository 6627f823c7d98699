#include "vector_overlay/overlay_layer.hpp"

#include <algorithm>

#include "gfx/gl.hpp"

namespace gis::overlay {

Result<OverlayLayer> OverlayLayer::build(std::string name, LayerKind kind, const LayerStyle& style,
                                         SharedFeatures features, const HeightBoundsProvider& bounds,
                                         const LayerBuildOptions& options) {
  Result<LayerGeometry> geometry =
      LayerGeometry::build(std::move(name), kind, style, std::move(features), bounds, options);
  Result<OverlayLayer> r;
  r.diagnostics = std::move(geometry.diagnostics);
  if (geometry) r.value = upload(std::move(*geometry));
  return r;
}

OverlayLayer OverlayLayer::upload(LayerGeometry geometry) {
  OverlayLayer layer(std::move(geometry));
  // Buffers of exactly the built size: a layer that is never edited wastes nothing.
  (void)layer.geometry_.takeChanges();
  layer.reallocate(std::max<std::size_t>(layer.geometry_.vertexCount(), 1),
                   std::max<std::size_t>(layer.geometry_.indexCount(), 1));
  if (const ArraysInFile* arrays = layer.geometry_.arraysInFile()) {
    // Straight from the file into the buffers, a slice at a time (their indices were checked
    // when read); then the file is let go, as a lean tile's arrays are.
    const auto copy = [&](GLuint buffer, std::uint64_t at, std::uint64_t bytes) {
      return arrays->read(at, bytes, [&](const void* data, std::uint64_t offset, std::uint64_t n) {
        glNamedBufferSubData(buffer, static_cast<GLintptr>(offset), static_cast<GLsizeiptr>(n), data);
      });
    };
    const bool copied =
        copy(layer.vertices_.id(), arrays->verticesAt, arrays->vertexCount * sizeof(LayerGeometry::Vertex)) &&
        copy(layer.indices_.id(), arrays->indicesAt, arrays->indexCount * sizeof(std::uint32_t)) &&
        (!layer.scaling_ || copy(layer.scaling_.id(), arrays->scalingAt, arrays->scalingCount * sizeof(glm::vec4))) &&
        (!layer.normals_ || copy(layer.normals_.id(), arrays->normalsAt, arrays->normalsCount * sizeof(glm::vec4)));
    // A file that cannot be read now (it was read a moment ago to check it): draw nothing of it.
    if (!copied) layer.broken_ = true;
    layer.geometry_.releaseArrays();
  }
  return layer;
}

void OverlayLayer::reallocate(std::size_t vertexCapacity, std::size_t indexCapacity) {
  using Vertex = LayerGeometry::Vertex;
  vertexCapacity_ = vertexCapacity;
  indexCapacity_ = indexCapacity;
  const std::vector<Vertex>& vertices = geometry_.vertices();
  const std::vector<std::uint32_t>& indices = geometry_.indices();
  // New storage with everything so far (the CPU copy is the source).
  vertices_ = gfx::createBuffer();
  indices_ = gfx::createBuffer();
  glNamedBufferData(vertices_.id(), static_cast<GLsizeiptr>(vertexCapacity_ * sizeof(Vertex)), nullptr,
                    GL_DYNAMIC_DRAW);
  if (widthPixels() > 0.0) {
    scaling_ = gfx::createBuffer();
    glNamedBufferData(scaling_.id(), static_cast<GLsizeiptr>(vertexCapacity_ * sizeof(glm::vec4)), nullptr,
                      GL_DYNAMIC_DRAW);
    if (!geometry_.scaling().empty()) {
      glNamedBufferSubData(scaling_.id(), 0, static_cast<GLsizeiptr>(geometry_.scaling().size() * sizeof(glm::vec4)),
                           geometry_.scaling().data());
    }
  }
  if (geometry_.alongNormals()) {  // world pieces: the directions their caps are padded along
    normals_ = gfx::createBuffer();
    glNamedBufferData(normals_.id(), static_cast<GLsizeiptr>(vertexCapacity_ * sizeof(glm::vec4)), nullptr,
                      GL_DYNAMIC_DRAW);
    if (!geometry_.normals().empty()) {
      glNamedBufferSubData(normals_.id(), 0, static_cast<GLsizeiptr>(geometry_.normals().size() * sizeof(glm::vec4)),
                           geometry_.normals().data());
    }
  }
  glNamedBufferData(indices_.id(), static_cast<GLsizeiptr>(indexCapacity_ * sizeof(std::uint32_t)), nullptr,
                    GL_DYNAMIC_DRAW);
  if (!vertices.empty()) {
    glNamedBufferSubData(vertices_.id(), 0, static_cast<GLsizeiptr>(vertices.size() * sizeof(Vertex)), vertices.data());
  }
  if (!indices.empty()) {
    glNamedBufferSubData(indices_.id(), 0, static_cast<GLsizeiptr>(indices.size() * sizeof(std::uint32_t)),
                         indices.data());
  }
  gpuBytes_ =
      vertexCapacity_ * (sizeof(Vertex) + (scaling_ ? sizeof(glm::vec4) : 0) + (normals_ ? sizeof(glm::vec4) : 0)) +
      indexCapacity_ * sizeof(std::uint32_t);
}

void OverlayLayer::sync() {
  using Vertex = LayerGeometry::Vertex;
  const GeometryChange change = geometry_.takeChanges();
  if (change.empty()) return;
  const std::vector<Vertex>& vertices = geometry_.vertices();
  const std::vector<std::uint32_t>& indices = geometry_.indices();
  if (vertices.size() > vertexCapacity_ || indices.size() > indexCapacity_) {
    // Outgrown: twice the capacity, so that a run of edits reallocates rarely.
    reallocate(std::max<std::size_t>({vertices.size(), 2 * vertexCapacity_, 1024}),
               std::max<std::size_t>({indices.size(), 2 * indexCapacity_, 4096}));
    return;
  }
  if (change.vertexBegin < change.vertexEnd) {
    const std::size_t n = change.vertexEnd - change.vertexBegin;
    glNamedBufferSubData(vertices_.id(), static_cast<GLintptr>(change.vertexBegin * sizeof(Vertex)),
                         static_cast<GLsizeiptr>(n * sizeof(Vertex)), vertices.data() + change.vertexBegin);
    if (scaling_ && change.vertexEnd <= geometry_.scaling().size()) {
      glNamedBufferSubData(scaling_.id(), static_cast<GLintptr>(change.vertexBegin * sizeof(glm::vec4)),
                           static_cast<GLsizeiptr>(n * sizeof(glm::vec4)),
                           geometry_.scaling().data() + change.vertexBegin);
    }
  }
  if (change.indexBegin < change.indexEnd) {
    glNamedBufferSubData(indices_.id(), static_cast<GLintptr>(change.indexBegin * sizeof(std::uint32_t)),
                         static_cast<GLsizeiptr>((change.indexEnd - change.indexBegin) * sizeof(std::uint32_t)),
                         indices.data() + change.indexBegin);
  }
}

Diagnostics OverlayLayer::replaceFeature(std::size_t index, geo::Feature feature) {
  Diagnostics d = geometry_.replaceFeature(index, std::move(feature));
  sync();
  return d;
}

Diagnostics OverlayLayer::setFeatureStyle(std::size_t index, const FeatureStyle& style) {
  Diagnostics d = geometry_.setFeatureStyle(index, style);
  sync();
  return d;
}

Diagnostics OverlayLayer::setFeature(std::size_t index, geo::Feature feature, FeatureStyle style) {
  Diagnostics d = geometry_.setFeature(index, std::move(feature), std::move(style));
  sync();
  return d;
}

void OverlayLayer::removeFeature(std::size_t index) {
  geometry_.removeFeature(index);
  sync();
}

void OverlayLayer::refreshBounds(const HeightBoundsProvider& bounds) {
  geometry_.refreshBounds(bounds);
  sync();
}

}  // namespace gis::overlay
