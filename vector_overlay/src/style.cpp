#include "vector_overlay/style.hpp"

#include <cctype>

namespace gis::overlay {
namespace {

int hexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  const int lower = std::tolower(static_cast<unsigned char>(c));
  if (lower >= 'a' && lower <= 'f') return lower - 'a' + 10;
  return -1;
}

}  // namespace

bool parseHexColor(const std::string& text, glm::vec4& out) {
  if ((text.size() != 7 && text.size() != 9) || text[0] != '#') return false;
  float channels[4] = {0.0F, 0.0F, 0.0F, 1.0F};
  for (std::size_t i = 0; i * 2 + 1 < text.size(); ++i) {
    const int hi = hexDigit(text[1 + i * 2]);
    const int lo = hexDigit(text[2 + i * 2]);
    if (hi < 0 || lo < 0) return false;
    channels[i] = static_cast<float>(hi * 16 + lo) / 255.0F;
  }
  out = glm::vec4(channels[0], channels[1], channels[2], channels[3]);
  return true;
}

LineJoin parseLineJoin(const std::string& text, bool& ok) {
  ok = true;
  if (text == "round") return LineJoin::Round;
  if (text == "miter") return LineJoin::Miter;
  if (text == "bevel") return LineJoin::Bevel;
  ok = false;
  return LineJoin::Round;
}

LineCap parseLineCap(const std::string& text, bool& ok) {
  ok = true;
  if (text == "round") return LineCap::Round;
  if (text == "flat" || text == "butt") return LineCap::Flat;
  if (text == "square") return LineCap::Square;
  ok = false;
  return LineCap::Round;
}

}  // namespace gis::overlay
