// Stencil polyhedra (docs/design.md §4-5): the layers' closed pieces marked z-pass or z-fail into the
// stencil, then covered where the count is not zero. Two entries of the registry use it: ours,
// and the seed paper's construction (the layers are then built one bound pair per feature and
// covered by the pieces' bounding boxes: OverlayLayer does that by its build options).
#include "techniques/techniques.hpp"

#include <array>

namespace gis::overlay {
namespace {

class StencilVolumes final : public OverlayTechnique {
 public:
  explicit StencilVolumes(OverlayRenderer renderer) : renderer_(std::move(renderer)) {}

  void drawFrame(gfx::StateCache& cache, const TechniqueFrame& frame, TechniqueFrameStats& stats) override {
    stats.layers = renderer_.draw(cache, frame.view, frame.layers, frame.settings);
  }

 private:
  OverlayRenderer renderer_;
};

Result<std::unique_ptr<OverlayTechnique>> create(const TechniqueOptions& options) {
  (void)options;
  Result<std::unique_ptr<OverlayTechnique>> result;
  Result<OverlayRenderer> renderer = OverlayRenderer::create();
  result.diagnostics = std::move(renderer.diagnostics);
  if (renderer) result.value = std::make_unique<StencilVolumes>(std::move(*renderer));
  return result;
}

}  // namespace

const TechniqueInfo kStencilTechnique{
    "stencil", "stencil polyhedra", "our stencil polyhedra (exact)", "#1f77b4", PieceConstruction::Ours, 0, {},
    &create};
const TechniqueInfo kPaperTechnique{"paper",
                                    "paper's construction",
                                    "the seed paper's construction of the polyhedra",
                                    "#ff7f0e",
                                    PieceConstruction::Paper,
                                    0,
                                    {},
                                    &create};

}  // namespace gis::overlay
