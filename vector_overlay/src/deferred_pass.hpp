#pragma once
// What the deferred lookup's layers hold (vector_overlay/deferred_lookup.hpp), for the library's
// own users: the pass (deferred_pass.cpp) and the projected frame's technique, which builds its
// layers' indices itself (lines, reach classes: techniques/deferred_technique.cpp).
#include <array>
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

#include "deferred_index.hpp"
#include "vector_overlay/deferred_lookup.hpp"

namespace gis::overlay {

struct DeferredLayer::Impl {
  struct Chart {
    DeferredChart chart;
    deferred::Index index;
    /// Boxes (frame coordinates) holding every ground point the index can colour.
    std::vector<std::array<glm::dvec3, 2>> cover;
  };
  std::vector<Chart> charts;
  std::uint64_t serial = 0;
};

/// A layer of one chart made of an index built elsewhere, with its cover boxes.
DeferredLayer deferredLayerOf(DeferredChart chart, deferred::Index index, std::vector<std::array<glm::dvec3, 2>> cover);

}  // namespace gis::overlay
