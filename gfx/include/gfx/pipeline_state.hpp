#pragma once
// Render state as values (after filament's PipelineState): every draw names the full state it
// needs, and the StateCache is the only code that calls glEnable/glStencilOp*/glBlendFunc*.
// Passes are named constants (kOpaque, later kMarkZPass, kCover, ...) that tests can compare
// with the stencil tables of the seed papers.
#include <array>
#include <cstdint>
#include <string>

namespace gis::gfx {

enum class CompareFunc : std::uint8_t { Never, Less, LessEqual, Equal, NotEqual, GreaterEqual, Greater, Always };
enum class StencilOp : std::uint8_t { Keep, Zero, Replace, Incr, IncrWrap, Decr, DecrWrap, Invert };
enum class BlendFactor : std::uint8_t {
  Zero,
  One,
  SrcColor,
  OneMinusSrcColor,
  DstColor,
  OneMinusDstColor,
  SrcAlpha,
  OneMinusSrcAlpha,
  DstAlpha,
  OneMinusDstAlpha,
  ConstantColor,
  ConstantAlpha
};
enum class BlendEquation : std::uint8_t { Add, Subtract, ReverseSubtract, Min, Max };
enum class CullMode : std::uint8_t { None, Front, Back };
enum class PolygonMode : std::uint8_t { Fill, Line };

/// Depth test and write. Reversed-Z is the default: nearer is greater.
struct DepthState {
  bool test = true;
  bool write = true;
  CompareFunc func = CompareFunc::Greater;
  bool clamp = false;  ///< GL_DEPTH_CLAMP: on for every volume pass (docs/design.md §3)
  bool operator==(const DepthState&) const = default;
};

/// Stencil test and operations of one face orientation.
struct StencilFace {
  CompareFunc func = CompareFunc::Always;
  std::uint8_t ref = 0;
  std::uint8_t readMask = 0xFF;
  std::uint8_t writeMask = 0xFF;
  StencilOp stencilFail = StencilOp::Keep;  ///< stencil test fails
  StencilOp depthFail = StencilOp::Keep;    ///< stencil passes, depth fails
  StencilOp depthPass = StencilOp::Keep;    ///< both pass
  bool operator==(const StencilFace&) const = default;
};

struct StencilState {
  bool test = false;
  StencilFace front;
  StencilFace back;
  bool operator==(const StencilState&) const = default;
};

struct BlendState {
  bool enabled = false;
  BlendFactor srcColor = BlendFactor::One;
  BlendFactor dstColor = BlendFactor::Zero;
  BlendFactor srcAlpha = BlendFactor::One;
  BlendFactor dstAlpha = BlendFactor::Zero;
  BlendEquation colorEquation = BlendEquation::Add;
  BlendEquation alphaEquation = BlendEquation::Add;
  bool operator==(const BlendState&) const = default;
};

struct ColorMask {
  bool r = true, g = true, b = true, a = true;
  bool operator==(const ColorMask&) const = default;
};

struct RasterState {
  CullMode cull = CullMode::Back;
  bool frontFaceCCW = true;
  ColorMask colorMask;
  PolygonMode polygonMode = PolygonMode::Fill;
  /// Polygon offset (enabled when either value is non-zero).
  float polygonOffsetFactor = 0.0F;
  float polygonOffsetUnits = 0.0F;
  bool multisample = true;
  bool operator==(const RasterState&) const = default;
};

struct PipelineState {
  DepthState depth;
  StencilState stencil;
  BlendState blend;
  RasterState raster;
  bool operator==(const PipelineState&) const = default;
};

/// Opaque geometry under reversed-Z: depth test GREATER, depth write, back-face culling.
inline constexpr PipelineState kOpaque{};

/// The state GL has on a fresh context (depth test off, LESS, no culling): what third-party
/// code expects, and what the cache restores before handing the context to it.
inline constexpr PipelineState kGlDefault{
    DepthState{false, true, CompareFunc::Less, false}, StencilState{}, BlendState{},
    RasterState{CullMode::None, true, ColorMask{}, PolygonMode::Fill, 0.0F, 0.0F, true}};

/// Premultiplied-alpha "over" blending: dst = src + (1 − src.a)·dst.
inline constexpr BlendState kBlendPremultipliedOver{true,
                                                    BlendFactor::One,
                                                    BlendFactor::OneMinusSrcAlpha,
                                                    BlendFactor::One,
                                                    BlendFactor::OneMinusSrcAlpha,
                                                    BlendEquation::Add,
                                                    BlendEquation::Add};

std::string toString(CompareFunc f);
std::string toString(StencilOp op);
/// A readable multi-line description, for test failure output.
std::string toString(const PipelineState& state);

}  // namespace gis::gfx
