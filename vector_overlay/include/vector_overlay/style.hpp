#pragma once
// Layer styles as the scene file states them.
#include <map>
#include <string>

#include <glm/vec4.hpp>

namespace gis::overlay {

enum class LayerKind { Polygon, Line };
enum class LineJoin { Round, Miter, Bevel };
enum class LineCap { Round, Flat, Square };

struct LayerStyle {
  glm::vec4 color{1.0F, 0.5F, 0.0F, 1.0F};  ///< straight (not premultiplied) RGBA
  float opacity = 0.5F;
  /// Per-feature colour: the value of this attribute (as text) looked up in `categories`;
  /// features whose value is not listed get `color`.
  std::string colorAttribute;
  std::map<std::string, glm::vec4> categories;
  /// Layers are drawn by increasing order (ties keep the scene's order); later layers cover
  /// earlier ones.
  int drawOrder = 0;
  // polygons
  float outlineWidthMetres = 0.0F;
  float outlineWidthPixels = 0.0F;  ///< > 0: the outline in pixels (instead of metres)
  glm::vec4 outlineColor{0.0F, 0.0F, 0.0F, 1.0F};
  // lines
  double widthMetres = 10.0;
  std::string widthAttribute;  ///< per-feature width (e.g. "width_m"); falls back to widthMetres
  LineJoin join = LineJoin::Round;
  LineCap cap = LineCap::Round;
  double miterLimit = 4.0;
  /// > 0: lines (and outlines in pixels) keep this width on screen, up to `maxWidthMetres` on
  /// the ground (LineShape); `widthMetres` and `widthAttribute` are then not used.
  double widthPixels = 0.0;
  /// Lines (and outlines) in metres are at least this many pixels wide on screen, up to
  /// `maxWidthMetres` (LineShape::minWidth): far roads stay visible lines instead of breaking
  /// into dots. 0: exactly their width in metres. Drawn by the tiled technique (the
  /// whole-load techniques draw the width in metres: LayerBuildOptions::minWidthInPixels).
  double minWidthPixels = 1.0;
  /// The largest width in metres of lines in pixels; 0: 50 m for `widthPixels`, none (10⁷ m)
  /// for `minWidthPixels`.
  double maxWidthMetres = 0.0;
  [[nodiscard]] double widthCap() const {
    if (maxWidthMetres > 0.0) return maxWidthMetres;
    return widthPixels > 0.0 ? 50.0 : 1e7;
  }
};

/// "#rrggbb" or "#rrggbbaa" → RGBA in [0,1]; false if malformed.
bool parseHexColor(const std::string& text, glm::vec4& out);

LineJoin parseLineJoin(const std::string& text, bool& ok);
LineCap parseLineCap(const std::string& text, bool& ok);

}  // namespace gis::overlay
