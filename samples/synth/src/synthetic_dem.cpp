#include "synth/synthetic_dem.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <mutex>
#include <numbers>
#include <optional>
#include <thread>

#include <cpl_error.h>
#include <cpl_string.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include "gdal_util.hpp"

namespace gis::synth {
namespace {

using detail::parseCrs;
using detail::QuietGdal;

// ---- the relief ----
constexpr double kBaseLevel = 120.0;      // height of the lowest possible relief post
constexpr double kContrast = 2.2;         // tanh contrast applied to the normalised fBm
constexpr double kBaseFrequency = 3.0;    // lattice cells across the raster, coarsest octave
constexpr double kFinestFrequency = 0.4;  // lattice cells per post, finest octave (>= 2.5 posts)
constexpr int kMaxOctaves = 16;
// Largest |gradient| of gradientNoise() (normalised to [-1, 1]) per lattice unit: 2.09 measured
// over 10^8 random points; with margin. Bounds the post-to-post change of the relief.
constexpr double kNoiseGradientBound = 2.5;

// ---- the stiff cases ----
constexpr double kCliffMinJump = 400.0;  // + the relief's slope bound: >= 300 m across every cliff
constexpr double kCliffMaxJump = 600.0;
constexpr double kSpikeMin = 550.0;  // above the highest of the 8 neighbours
constexpr double kSpikeMax = 800.0;
constexpr int kCliffCount = 4;
constexpr int kSpikeCount = 8;
constexpr int kHoleCount = 3;
constexpr int kPlacementTries = 4000;

// ---- the file ----
constexpr int kTile = 256;  // tile size and rows per block
constexpr float kNodataF = static_cast<float>(kSyntheticNodata);

/// SplitMix64's finaliser: a good 64-bit mixer, used for hashing lattice points and as an RNG.
std::uint64_t mix(std::uint64_t z) {
  z = (z ^ (z >> 30U)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27U)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31U);
}

/// SplitMix64, one independent stream per purpose so that features of one kind do not move when
/// another kind is switched off.
class Rng {
 public:
  Rng(std::uint64_t seed, std::uint64_t stream) : state_(mix(seed ^ mix(stream * 0x9E3779B97F4A7C15ULL + 1U))) {}
  std::uint64_t next() {
    state_ += 0x9E3779B97F4A7C15ULL;
    return mix(state_);
  }
  double uniform() { return static_cast<double>(next() >> 11U) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  double sign() { return (next() >> 63U) != 0 ? 1.0 : -1.0; }

 private:
  std::uint64_t state_;
};

enum Stream : std::uint64_t { kRelief = 1, kBorder, kCliffs, kPlains, kHoles, kSpikes };

struct Grad {
  double x, y;
};

double fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }
double smoothstep(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

/// One octave: noise coordinates = rotation·frequency·(col, row) + offset.
struct Octave {
  double m00, m01, m10, m11, ox, oy, amplitude;
  std::uint64_t seed;
};

/// A closed curve r(θ) = radius·(1 + Σ a_k sin(kθ + φ_k)), k = 2, 3, ...: an irregular blob.
struct Blob {
  double col = 0.0, row = 0.0, radius = 0.0, inner = 0.0, outer = 0.0;
  std::vector<double> amplitude, phase;

  Blob(Rng& rng, double c, double r, double rad, int harmonics, double wobble) : col(c), row(r), radius(rad) {
    double sum = 0.0;
    for (int k = 0; k < harmonics; ++k) {
      amplitude.push_back(rng.uniform(0.3, 1.0));
      phase.push_back(rng.uniform(0.0, 2.0 * std::numbers::pi));
      sum += amplitude.back();
    }
    for (double& a : amplitude) a *= wobble / sum;
    inner = radius * (1.0 - wobble);
    outer = radius * (1.0 + wobble);
  }

  [[nodiscard]] bool inside(double c, double r) const {
    const double dc = c - col, dr = r - row;
    const double d2 = dc * dc + dr * dr;
    if (d2 <= inner * inner) return true;
    if (d2 > outer * outer) return false;
    const double theta = std::atan2(dr, dc);
    double f = 1.0;
    for (std::size_t k = 0; k < amplitude.size(); ++k)
      f += amplitude[k] * std::sin(static_cast<double>(k + 2) * theta + phase[k]);
    return d2 <= radius * radius * f * f;
  }
};

/// Posts and extrema counted while generating (one per worker thread, merged after each block).
struct Tally {
  std::vector<std::size_t> plainPosts, holePosts;
  std::size_t borderPosts = 0, valid = 0, nodata = 0;
  float min = std::numeric_limits<float>::infinity();
  float max = -std::numeric_limits<float>::infinity();

  Tally(std::size_t plains, std::size_t holes) : plainPosts(plains, 0), holePosts(holes, 0) {}
  void merge(const Tally& o) {
    for (std::size_t i = 0; i < plainPosts.size(); ++i) plainPosts[i] += o.plainPosts[i];
    for (std::size_t i = 0; i < holePosts.size(); ++i) holePosts[i] += o.holePosts[i];
    borderPosts += o.borderPosts;
    valid += o.valid;
    nodata += o.nodata;
    min = std::min(min, o.min);
    max = std::max(max, o.max);
  }
};

/// A disc a placed feature occupies (with its surroundings), for keeping features apart.
struct Footprint {
  double col, row, radius;
};

}  // namespace

// ---------------------------------------------------------------------------------------------

struct SyntheticTerrain::Model {
  SyntheticDemOptions options;
  SyntheticDemSummary layout;
  std::array<Grad, 16> gradients{};
  std::vector<Octave> octaves;
  double slopeBound = 0.0;  // largest height difference of the relief between 4-neighbours
  std::optional<Blob> border;
  std::vector<Blob> holes;
  std::vector<double> plainRing;   // width of the blend into each plain
  std::vector<double> plainReach;  // radius of a disc around each plain containing plain and ring

  explicit Model(const SyntheticDemOptions& o);

  /// Gradient noise in [-1, 1] on the integer lattice, gradients picked by hashing the corner.
  [[nodiscard]] double noise(double x, double y, std::uint64_t seed) const {
    const double xf = std::floor(x), yf = std::floor(y);
    const double fx = x - xf, fy = y - yf;
    const auto ix = static_cast<std::uint64_t>(static_cast<std::int64_t>(xf));
    const auto iy = static_cast<std::uint64_t>(static_cast<std::int64_t>(yf));
    auto corner = [&](std::uint64_t cx, std::uint64_t cy, double dx, double dy) {
      const std::uint64_t h = mix(seed ^ (cx * 0x9E3779B97F4A7C15ULL) ^ (cy * 0xC2B2AE3D27D4EB4FULL));
      const Grad& g = gradients[h >> 60U];
      return g.x * dx + g.y * dy;
    };
    const double n00 = corner(ix, iy, fx, fy);
    const double n10 = corner(ix + 1U, iy, fx - 1.0, fy);
    const double n01 = corner(ix, iy + 1U, fx, fy - 1.0);
    const double n11 = corner(ix + 1U, iy + 1U, fx - 1.0, fy - 1.0);
    const double u = fade(fx), v = fade(fy);
    const double a = n00 + u * (n10 - n00);
    const double b = n01 + u * (n11 - n01);
    return (a + v * (b - a)) * std::numbers::sqrt2;
  }

  /// The fractal relief alone: kBaseLevel .. kBaseLevel + relief, valleys flatter than ridges.
  [[nodiscard]] double relief(double c, double r) const {
    double n = 0.0;
    for (const Octave& o : octaves)
      n += o.amplitude * noise(o.m00 * c + o.m01 * r + o.ox, o.m10 * c + o.m11 * r + o.oy, o.seed);
    const double t = 0.5 + 0.5 * std::tanh(kContrast * n);
    return kBaseLevel + options.reliefMetres * t * std::sqrt(t);
  }

  /// Relief raised on the high side of each cliff.
  [[nodiscard]] double faulted(double c, double r) const {
    double h = relief(c, r);
    for (const SyntheticCliff& cliff : layout.cliffs) {
      if (cliff.signedDistance(c, r) > 0.0) h += cliff.jumpMetres;
    }
    return h;
  }

  /// Height of a post that is not a feature: faulted relief, blended into nearby plains.
  [[nodiscard]] double ground(int c, int r) const {
    double h = faulted(c, r);
    for (std::size_t i = 0; i < layout.plains.size(); ++i) {
      const SyntheticPlain& p = layout.plains[i];
      const double dc = std::abs(c - p.col), dr = std::abs(r - p.row);
      if (dc > plainReach[i] || dr > plainReach[i]) continue;
      double outside = 0.0;  // distance from the plain's edge
      if (p.shape == PlainShape::Disc) {
        outside = std::max(0.0, std::hypot(dc, dr) - p.radius);
      } else {
        outside = std::hypot(std::max(0.0, dc - p.halfWidth), std::max(0.0, dr - p.halfHeight));
      }
      if (outside < plainRing[i]) h = p.height + (h - p.height) * smoothstep(outside / plainRing[i]);
    }
    return h;
  }

  [[nodiscard]] static float stored(double h) {
    return static_cast<float>(std::clamp(h, kSyntheticMinHeight, kSyntheticMaxHeight));
  }

  /// The value of post (col, row): NaN for nodata. Counts into `tally` when given.
  [[nodiscard]] float height(int col, int row, Tally* tally) const {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    if (border && !border->inside(col, row)) {
      if (tally != nullptr) {
        ++tally->borderPosts;
        ++tally->nodata;
      }
      return nan;
    }
    for (std::size_t i = 0; i < holes.size(); ++i) {
      if (holes[i].inside(col, row)) {
        if (tally != nullptr) {
          ++tally->holePosts[i];
          ++tally->nodata;
        }
        return nan;
      }
    }
    float h = 0.0F;
    bool done = false;
    for (const SyntheticSpike& s : layout.spikes) {
      if (s.col == col && s.row == row) {
        h = s.height;
        done = true;
        break;
      }
    }
    for (std::size_t i = 0; !done && i < layout.plains.size(); ++i) {
      if (layout.plains[i].contains(col, row)) {
        h = layout.plains[i].height;
        done = true;
        if (tally != nullptr) ++tally->plainPosts[i];
      }
    }
    if (!done) h = stored(ground(col, row));
    if (tally != nullptr) {
      ++tally->valid;
      tally->min = std::min(tally->min, h);
      tally->max = std::max(tally->max, h);
    }
    return h;
  }

 private:
  void planRelief();
  void planBorder();
  void planCliffs();
  void planPlains(std::vector<Footprint>& taken);
  void planHoles(std::vector<Footprint>& taken);
  void planSpikes(std::vector<Footprint>& taken);
  /// Whether a feature occupying `f` fits: inside the data, clear of cliffs and other features.
  [[nodiscard]] bool fits(const Footprint& f, const std::vector<Footprint>& taken) const;
  /// A random centre for a feature of the given radius (not yet checked by fits()).
  [[nodiscard]] std::array<double, 2> randomCentre(Rng& rng) const;
  [[nodiscard]] double extent() const { return static_cast<double>(options.size - 1); }
};

SyntheticTerrain::Model::Model(const SyntheticDemOptions& o) : options(o) {
  for (std::size_t i = 0; i < gradients.size(); ++i) {
    const double a = (static_cast<double>(i) + 0.5) * std::numbers::pi / 8.0;
    gradients[i] = {std::cos(a), std::sin(a)};
  }
  layout.size = o.size;
  layout.spacing = o.spacing;
  layout.seed = o.seed;
  layout.crs = o.crs;
  layout.geoTransform = {o.originX, o.spacing, 0.0, o.originY, 0.0, -o.spacing};
  layout.nodata = kSyntheticNodata;

  planRelief();
  planBorder();
  planCliffs();
  // Largest first: plains, then holes, then single-post spikes.
  std::vector<Footprint> taken;
  planPlains(taken);
  planHoles(taken);
  planSpikes(taken);
}

void SyntheticTerrain::Model::planRelief() {
  Rng rng(options.seed, kRelief);
  double frequency = kBaseFrequency / extent();
  double amplitude = 1.0, amplitudeSum = 0.0, slope = 0.0;
  for (int k = 0; k < kMaxOctaves && (k == 0 || frequency <= kFinestFrequency); ++k) {
    const double angle = rng.uniform(0.0, 2.0 * std::numbers::pi);
    const double cs = std::cos(angle) * frequency, sn = std::sin(angle) * frequency;
    octaves.push_back({cs, -sn, sn, cs, rng.uniform(0.0, 4096.0), rng.uniform(0.0, 4096.0), amplitude, rng.next()});
    amplitudeSum += amplitude;
    slope += amplitude * frequency;
    frequency *= 2.0;
    amplitude *= 0.5;
  }
  for (Octave& oct : octaves) oct.amplitude /= amplitudeSum;
  // |d relief / d n| <= relief · 1.5 · 0.5 · contrast; |Δn| per post <= Σ a_k f_k · bound.
  slopeBound = options.reliefMetres * 0.75 * kContrast * kNoiseGradientBound * slope / amplitudeSum;
}

void SyntheticTerrain::Model::planBorder() {
  if (!options.nodataBorder) return;
  Rng rng(options.seed, kBorder);
  const double e = extent();
  // Radius 0.40·E ± 14 %: 0.344·E .. 0.456·E from the centre, never reaching the edge (0.5·E).
  border.emplace(rng, e / 2.0, e / 2.0, 0.40 * e, 6, 0.14);
  layout.border = {true, border->col, border->row, border->inner, border->outer, 0};
}

void SyntheticTerrain::Model::planCliffs() {
  if (!options.cliffs) return;
  Rng rng(options.seed, kCliffs);
  const double e = extent();
  // Heights must stay below kSyntheticMaxHeight: relief + all jumps + a spike.
  const double budget = kSyntheticMaxHeight - 50.0 - (kBaseLevel + options.reliefMetres + kSpikeMax);
  double used = 0.0;
  for (int i = 0; i < kCliffCount; ++i) {
    SyntheticCliff c;
    c.jumpMetres = std::round(rng.uniform(kCliffMinJump, kCliffMaxJump) + slopeBound);
    const double side = rng.sign();
    if (i == 0) {  // between two post columns
      c.col = std::floor(rng.uniform(0.25, 0.45) * e) + 0.5;
      c.row = e / 2.0;
      c.normalCol = side;
      c.normalRow = 0.0;
      c.axisAligned = true;
    } else if (i == 1) {  // between two post rows
      c.col = e / 2.0;
      c.row = std::floor(rng.uniform(0.55, 0.75) * e) + 0.5;
      c.normalCol = 0.0;
      c.normalRow = side;
      c.axisAligned = true;
    } else {  // diagonal through the middle part, rising to the right or to the left
      c.col = rng.uniform(0.35, 0.65) * e;
      c.row = rng.uniform(0.35, 0.65) * e;
      const double angle = (i == 2 ? rng.uniform(25.0, 65.0) : rng.uniform(115.0, 155.0)) * std::numbers::pi / 180.0;
      c.normalCol = -std::sin(angle) * side;
      c.normalRow = std::cos(angle) * side;
    }
    if (used + c.jumpMetres > budget) break;
    used += c.jumpMetres;
    // Where the line enters and leaves [0, E]²: clip col/row = point + t·direction.
    const double dc = -c.normalRow, dr = c.normalCol;
    double t0 = -std::numeric_limits<double>::infinity(), t1 = std::numeric_limits<double>::infinity();
    for (const auto& [p, d] : {std::pair{c.col, dc}, std::pair{c.row, dr}}) {
      if (std::abs(d) < 1e-12) continue;
      const double a = (0.0 - p) / d, b = (e - p) / d;
      t0 = std::max(t0, std::min(a, b));
      t1 = std::min(t1, std::max(a, b));
    }
    c.startCol = c.col + t0 * dc;
    c.startRow = c.row + t0 * dr;
    c.endCol = c.col + t1 * dc;
    c.endRow = c.row + t1 * dr;
    layout.cliffs.push_back(c);
  }
}

std::array<double, 2> SyntheticTerrain::Model::randomCentre(Rng& rng) const {
  const double e = extent();
  return {rng.uniform(0.05, 0.95) * e, rng.uniform(0.05, 0.95) * e};
}

bool SyntheticTerrain::Model::fits(const Footprint& f, const std::vector<Footprint>& taken) const {
  const double e = extent();
  const double margin = 2.0;
  if (border) {
    if (std::hypot(f.col - border->col, f.row - border->row) + f.radius > border->inner - margin) return false;
  } else {
    const double edge = 0.04 * e + margin;
    if (f.col - f.radius < edge || f.row - f.radius < edge || f.col + f.radius > e - edge ||
        f.row + f.radius > e - edge)
      return false;
  }
  for (const SyntheticCliff& c : layout.cliffs) {
    if (std::abs(c.signedDistance(f.col, f.row)) < f.radius + margin) return false;
  }
  for (const Footprint& t : taken) {
    if (std::hypot(f.col - t.col, f.row - t.row) < f.radius + t.radius + margin) return false;
  }
  return true;
}

void SyntheticTerrain::Model::planPlains(std::vector<Footprint>& taken) {
  if (!options.plains) return;
  Rng rng(options.seed, kPlains);
  const double e = extent();
  for (int i = 0; i < 3; ++i) {
    SyntheticPlain p;
    double size = 0.0;  // radius or larger half side
    if (i < 2) {        // a lake and a pond
      p.shape = PlainShape::Disc;
      p.radius = std::max(2.0, (i == 0 ? rng.uniform(0.04, 0.06) : rng.uniform(0.025, 0.04)) * e);
      size = p.radius;
    } else {  // a levelled field
      p.shape = PlainShape::Rectangle;
      p.halfWidth = std::max(2.0, std::floor(rng.uniform(0.025, 0.05) * e));
      p.halfHeight = std::max(2.0, std::floor(rng.uniform(0.02, 0.04) * e));
      size = std::hypot(p.halfWidth, p.halfHeight);
    }
    const double ring = 0.5 * size + 2.0;
    for (int attempt = 0; attempt < kPlacementTries; ++attempt) {
      const auto [c, r] = randomCentre(rng);
      p.col = p.shape == PlainShape::Rectangle ? std::round(c) : c;
      p.row = p.shape == PlainShape::Rectangle ? std::round(r) : r;
      const Footprint f{p.col, p.row, size + ring};
      if (!fits(f, taken)) continue;
      // A lake lies at the lowest point of its shore, a field at the height of its centre;
      // quarter metres are exact in Float32.
      double level = faulted(p.col, p.row);
      if (p.shape == PlainShape::Disc) {
        for (int k = 0; k < 24; ++k) {
          const double a = 2.0 * std::numbers::pi * k / 24.0;
          level = std::min(level, faulted(p.col + p.radius * std::cos(a), p.row + p.radius * std::sin(a)));
        }
      }
      p.height = stored(std::floor(level * 4.0) / 4.0);
      layout.plains.push_back(p);
      plainRing.push_back(ring);
      plainReach.push_back(size + ring);
      taken.push_back(f);
      break;
    }
  }
}

void SyntheticTerrain::Model::planHoles(std::vector<Footprint>& taken) {
  if (!options.nodataHoles) return;
  Rng rng(options.seed, kHoles);
  const double e = extent();
  for (int i = 0; i < kHoleCount; ++i) {
    const double radius = std::max(2.5, rng.uniform(0.02, 0.035) * e);
    for (int attempt = 0; attempt < kPlacementTries; ++attempt) {
      const auto [c, r] = randomCentre(rng);
      const Footprint f{c, r, radius * 1.25};
      if (!fits(f, taken)) continue;
      holes.emplace_back(rng, c, r, radius, 4, 0.25);
      layout.holes.push_back({c, r, holes.back().inner, holes.back().outer, 0});
      taken.push_back(f);
      break;
    }
  }
}

void SyntheticTerrain::Model::planSpikes(std::vector<Footprint>& taken) {
  if (!options.spikes) return;
  Rng rng(options.seed, kSpikes);
  for (int i = 0; i < kSpikeCount; ++i) {
    for (int attempt = 0; attempt < kPlacementTries; ++attempt) {
      const auto [c, r] = randomCentre(rng);
      const Footprint f{std::round(c), std::round(r), 2.0};  // the post and its 8 neighbours
      if (!fits(f, taken)) continue;
      SyntheticSpike s;
      s.col = static_cast<int>(f.col);
      s.row = static_cast<int>(f.row);
      s.neighbourMax = -std::numeric_limits<float>::infinity();
      for (int dr = -1; dr <= 1; ++dr) {
        for (int dc = -1; dc <= 1; ++dc) {
          if (dc != 0 || dr != 0) s.neighbourMax = std::max(s.neighbourMax, stored(ground(s.col + dc, s.row + dr)));
        }
      }
      s.height = stored(static_cast<double>(s.neighbourMax) + rng.uniform(kSpikeMin, kSpikeMax));
      layout.spikes.push_back(s);
      taken.push_back(f);
      break;
    }
  }
}

// ---------------------------------------------------------------------------------------------

std::string checkSyntheticDemOptions(const SyntheticDemOptions& o) {
  if (o.size < 33 || o.size > 65537) return "size must be between 33 and 65537 posts, not " + std::to_string(o.size);
  if (!std::isfinite(o.spacing) || o.spacing <= 0.0) return "spacing must be a positive number";
  if (!std::isfinite(o.reliefMetres) || o.reliefMetres < 0.0 || o.reliefMetres > 3000.0)
    return "relief must be between 0 and 3000 m";
  if (!std::isfinite(o.originX) || !std::isfinite(o.originY)) return "the origin must be finite";
  const double far = static_cast<double>(o.size) * o.spacing;
  if (!std::isfinite(std::abs(o.originX) + far) || !std::isfinite(std::abs(o.originY) + far))
    return "the raster does not fit into finite coordinates";
  if (!o.crs.empty()) {
    OGRSpatialReference srs;
    std::string error;
    if (!parseCrs(o.crs, srs, error)) return error;
  }
  return {};
}

bool isGeographicCrs(const std::string& crs) {
  OGRSpatialReference srs;
  std::string error;
  return parseCrs(crs, srs, error) && srs.IsGeographic() != 0;
}

Result<SyntheticTerrain> SyntheticTerrain::create(const SyntheticDemOptions& options) {
  if (std::string error = checkSyntheticDemOptions(options); !error.empty())
    return Result<SyntheticTerrain>::failure({Severity::Error, "", "", "", "invalid options: " + error});
  Result<SyntheticTerrain> r;
  r.value = SyntheticTerrain(std::make_shared<const Model>(options));
  return r;
}

float SyntheticTerrain::heightAt(int col, int row) const { return model_->height(col, row, nullptr); }
const SyntheticDemSummary& SyntheticTerrain::layout() const { return model_->layout; }
const SyntheticDemOptions& SyntheticTerrain::options() const { return model_->options; }

Result<SyntheticDemSummary> writeSyntheticDem(const std::string& path, const SyntheticDemOptions& options,
                                              const std::function<void(double)>& progress) {
  auto fail = [&](const std::string& message) {
    return Result<SyntheticDemSummary>::failure({Severity::Error, path, "", "", message});
  };
  if (std::string error = checkSyntheticDemOptions(options); !error.empty()) return fail("invalid options: " + error);
  if (path.empty()) return fail("no output file given");
  const SyntheticTerrain::Model model(options);
  const int n = options.size;

  static std::once_flag registered;
  std::call_once(registered, [] { GDALAllRegister(); });
  QuietGdal quiet;
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  if (driver == nullptr) return fail("GDAL has no GTiff driver");
  OGRSpatialReference srs;
  if (std::string error; !options.crs.empty() && !parseCrs(options.crs, srs, error)) return fail(error);

  CPLStringList create;
  create.SetNameValue("TILED", "YES");
  create.SetNameValue("BLOCKXSIZE", std::to_string(kTile).c_str());
  create.SetNameValue("BLOCKYSIZE", std::to_string(kTile).c_str());
  create.SetNameValue("COMPRESS", "DEFLATE");
  create.SetNameValue("PREDICTOR", "3");  // floating-point predictor for Float32
  create.SetNameValue("BIGTIFF", "IF_SAFER");
  create.SetNameValue("NUM_THREADS", "ALL_CPUS");
  GDALDataset* ds = driver->Create(path.c_str(), n, n, 1, GDT_Float32, create.List());
  if (ds == nullptr) return fail("cannot create GeoTIFF: " + QuietGdal::lastMessage("GDAL could not create the file"));

  // On any failure: close, remove the partial file, report.
  auto abandon = [&](const std::string& message) {
    const std::string detail = QuietGdal::lastMessage("unknown GDAL error");
    GDALClose(GDALDataset::ToHandle(ds));
    std::error_code ec;
    std::filesystem::remove(path, ec);
    return fail(message + ": " + detail);
  };
  SyntheticDemSummary summary = model.layout;
  summary.path = path;
  if (ds->SetGeoTransform(summary.geoTransform.data()) != CE_None) return abandon("cannot set the geotransform");
  if (!options.crs.empty() && ds->SetSpatialRef(&srs) != CE_None) return abandon("cannot set the CRS");
  GDALRasterBand* band = ds->GetRasterBand(1);
  if (band->SetNoDataValue(kSyntheticNodata) != CE_None) return abandon("cannot set the nodata value");

  const int blockRows = std::min(kTile, n);
  std::vector<float> buffer(static_cast<std::size_t>(n) * static_cast<std::size_t>(blockRows));
  const int threads = static_cast<int>(std::clamp(std::thread::hardware_concurrency(), 1U, 32U));
  Tally total(summary.plains.size(), summary.holes.size());
  if (progress) progress(0.0);
  for (int y0 = 0; y0 < n; y0 += blockRows) {
    const int rows = std::min(blockRows, n - y0);
    const int workers = std::min(threads, rows);
    std::vector<Tally> tallies(static_cast<std::size_t>(workers), Tally(summary.plains.size(), summary.holes.size()));
    auto work = [&](int w) {
      Tally& tally = tallies[static_cast<std::size_t>(w)];
      for (int r = w; r < rows; r += workers) {
        float* out = buffer.data() + static_cast<std::size_t>(r) * static_cast<std::size_t>(n);
        for (int c = 0; c < n; ++c) {
          const float h = model.height(c, y0 + r, &tally);
          out[c] = std::isnan(h) ? kNodataF : h;
        }
      }
    };
    {
      std::vector<std::jthread> pool;
      for (int w = 1; w < workers; ++w) pool.emplace_back(work, w);
      work(0);
    }
    for (const Tally& t : tallies) total.merge(t);
    if (band->RasterIO(GF_Write, 0, y0, n, rows, buffer.data(), n, rows, GDT_Float32, 0, 0, nullptr) != CE_None)
      return abandon("cannot write rows " + std::to_string(y0) + ".." + std::to_string(y0 + rows - 1));
    ds->FlushCache(false);  // hand complete tiles to the file: memory stays at one block of rows
    if (CPLGetLastErrorType() == CE_Failure)
      return abandon("cannot write rows " + std::to_string(y0) + ".." + std::to_string(y0 + rows - 1));
    if (progress) progress(static_cast<double>(y0 + rows) / static_cast<double>(n));
  }
  CPLErrorReset();
  GDALClose(GDALDataset::ToHandle(ds));
  if (CPLGetLastErrorType() == CE_Failure) {
    std::error_code ec;
    std::filesystem::remove(path, ec);
    return fail("cannot finish the file: " + QuietGdal::lastMessage("unknown GDAL error"));
  }

  for (std::size_t i = 0; i < summary.plains.size(); ++i) summary.plains[i].posts = total.plainPosts[i];
  for (std::size_t i = 0; i < summary.holes.size(); ++i) summary.holes[i].posts = total.holePosts[i];
  summary.border.posts = total.borderPosts;
  summary.validPosts = total.valid;
  summary.nodataPosts = total.nodata;
  summary.minHeight = total.valid > 0 ? static_cast<double>(total.min) : 0.0;
  summary.maxHeight = total.valid > 0 ? static_cast<double>(total.max) : 0.0;
  Result<SyntheticDemSummary> result;
  result.value = std::move(summary);
  return result;
}

}  // namespace gis::synth
