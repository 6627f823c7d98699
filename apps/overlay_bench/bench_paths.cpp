// The paths the modes fly, in either frame: the projected fly-through and close-ups, and the
// globe's path from space to street level.
#include <cmath>
#include <limits>
#include <numbers>

#include "bench_common.hpp"
#include "globe/globe_view.hpp"
#include "scene/globe_scene.hpp"

namespace gis::bench {

namespace {

struct GlobeFrame {
  std::string segment;
  globe::Geodetic eye, target;
};

/// Where the path looks: the scene camera's target, else the middle of the data.
globe::Geodetic focusOf(const scene::LoadedGlobeScene& s) {
  if (s.description.camera && s.description.camera->targetLonLatH) {
    const glm::dvec3 t = *s.description.camera->targetLonLatH;
    return {t.x, t.y, 0.0};
  }
  const auto [west, south, east, north] = s.extent;
  return {0.5 * (west + std::min(east, west + 360.0)), 0.5 * (south + north), 0.0};
}

/// The point of the layers' rings nearest the focus (an edge to fly low over), else the focus.
globe::Geodetic edgeNear(const scene::LoadedGlobeScene& s, const globe::Geodetic& focus) {
  globe::Geodetic best = focus;
  double nearest = std::numeric_limits<double>::max();
  const glm::dvec3 f = globe::toEcef(focus);
  const auto nearestOf = [&](const std::vector<globe::GlobePolygon>& polygons, const globe::LonLatRect& within) {
    for (const globe::GlobePolygon& p : polygons) {
      for (const auto& ring : p.rings) {
        for (std::size_t k = 0; k < ring.size(); k += 16) {
          if (ring[k].x < within.west || ring[k].x > within.east || ring[k].y < within.south ||
              ring[k].y > within.north)
            continue;  // a point the cut added
          const double d = glm::length(globe::toEcef(ring[k].x, ring[k].y, 0.0) - f);
          if (d < nearest) {
            nearest = d;
            best = {ring[k].x, ring[k].y, 0.0};
          }
        }
      }
    }
  };
  // The areas within a few degrees of the focus, read for this (cut there); every area only if
  // none is.
  const globe::LonLatRect near{focus.lon - 5.0, std::max(-90.0, focus.lat - 5.0), focus.lon + 5.0,
                               std::min(90.0, focus.lat + 5.0)};
  for (const globe::GlobeLayer& layer : s.layers) nearestOf(layer.areasIn(near, globe::kMaxLevel), near);
  if (nearest == std::numeric_limits<double>::max()) {
    for (const globe::GlobeLayer& layer : s.layers)
      nearestOf(layer.polygons(), globe::LonLatRect{-1e9, -90.0, 1e9, 90.0});
  }
  return best;
}

/// The data's size, metres: the larger side of its box.
double extentMetres(const scene::LoadedGlobeScene& s) {
  const auto [west, south, east, north] = s.extent;
  const double midLat = 0.5 * (south + north) * 3.14159265358979323846 / 180.0;
  return 111320.0 * std::max((std::min(east, west + 360.0) - west) * std::cos(midLat), north - south);
}

/// The path over regional data (a city, a county: smaller than 200 km): from above it, obliquely
/// over it, low over its edge, and a few hundred metres above its middle.
std::vector<GlobeFrame> regionalPath(const scene::LoadedGlobeScene& s, int frames) {
  const globe::Geodetic focus = focusOf(s);
  const globe::Geodetic edge = edgeNear(s, focus);
  const double size = extentMetres(s), degrees = size / 111320.0;
  const int per = std::max(1, frames / 4);
  std::vector<GlobeFrame> out;
  const auto ground = [&](double lon, double lat) { return std::max(s.heights->heightAt(lon, lat), 0.0); };
  const auto segment = [&](const std::string& name, auto&& at) {
    for (int k = 0; k < per; ++k) {
      GlobeFrame f = at(per == 1 ? 0.0 : static_cast<double>(k) / (per - 1));
      f.segment = name;
      out.push_back(f);
    }
  };
  segment("above the data", [&](double t) {
    const double l = focus.lon + degrees * (t - 0.5) * 0.2;
    return GlobeFrame{{}, {l, focus.lat, 1.2 * size}, {l, focus.lat, 0.0}};
  });
  segment("oblique over the data", [&](double t) {
    const double l = focus.lon + degrees * (t - 0.5) * 0.3;
    return GlobeFrame{{}, {l, focus.lat - 0.6 * degrees, 0.3 * size}, {l, focus.lat, ground(l, focus.lat)}};
  });
  segment("low over an edge", [&](double t) {
    const double l = edge.lon + degrees * (t - 0.5) * 0.05;
    const double h = ground(l, edge.lat);
    return GlobeFrame{{}, {l, edge.lat - 0.02 * degrees, h + 0.02 * size}, {l, edge.lat, h}};
  });
  segment("street level", [&](double t) {
    const double l = focus.lon + degrees * (t - 0.5) * 0.02;
    const double h = ground(l, focus.lat);
    return GlobeFrame{{}, {l, focus.lat - 0.004 * degrees, h + 100.0}, {l, focus.lat, h}};
  });
  return out;
}

/// The path: six segments of frames, each moving a little across the data (regionalPath for data
/// smaller than 200 km).
std::vector<GlobeFrame> globePath(const scene::LoadedGlobeScene& s, int frames) {
  if (extentMetres(s) < 2e5) return regionalPath(s, frames);
  const globe::Geodetic focus = focusOf(s);
  const globe::Geodetic edge = edgeNear(s, focus);
  const double lon = focus.lon, lat = focus.lat;
  const int per = std::max(1, frames / 6);
  std::vector<GlobeFrame> out;
  const auto segment = [&](const std::string& name, auto&& at) {
    for (int k = 0; k < per; ++k) {
      const double t = per == 1 ? 0.0 : static_cast<double>(k) / (per - 1);
      GlobeFrame f = at(t);
      f.segment = name;
      out.push_back(f);
    }
  };
  segment("space 9000 km", [&](double t) {
    const double l = lon - 20.0 + 40.0 * t;
    return GlobeFrame{{}, {l, lat, 9e6}, {l, lat, 0.0}};
  });
  segment("continent 3000 km", [&](double t) {
    const double l = lon - 10.0 + 20.0 * t;
    return GlobeFrame{{}, {l, lat - 25.0, 3e6}, {l, lat, 0.0}};
  });
  segment("regional 500 km", [&](double t) {
    const double l = edge.lon - 2.0 + 4.0 * t;
    return GlobeFrame{{}, {l, edge.lat - 4.0, 5e5}, {l, edge.lat, 0.0}};
  });
  segment("low 5 km over an edge", [&](double t) {
    const double l = edge.lon - 0.1 + 0.2 * t;
    const double ground = std::max(s.heights->heightAt(l, edge.lat), 0.0);
    return GlobeFrame{{}, {l, edge.lat - 0.2, ground + 5000.0}, {l, edge.lat, ground}};
  });
  segment("antimeridian 1500 km", [&](double t) {
    const double l = 170.0 + 20.0 * t;
    return GlobeFrame{{}, {l, 60.0, 1.5e6}, {l, 66.0, 0.0}};
  });
  segment("south pole 2000 km", [&](double t) {
    const double l = -180.0 + 90.0 * t;
    return GlobeFrame{{}, {l, -75.0, 2e6}, {l + 180.0, -88.0, 0.0}};
  });
  return out;
}

}  // namespace

std::vector<scene::PathFrame> closeUpPath(const BenchSetup& setup, int frames) {
  struct Spot {
    glm::dvec2 point, direction;
  };
  std::vector<Spot> roads, areas;
  for (const scene::LoadedLayer& layer : setup.scene.projected().layers) {
    for (const geo::Feature& f : layer.features.all()) {
      for (const geo::LineString& line : f.lines) {
        const std::size_t i = line.size() / 2;
        if (i == 0) continue;
        const glm::dvec2 d = line[i] - line[i - 1];
        if (glm::length(d) > 0.0) roads.push_back({0.5 * (line[i] + line[i - 1]), glm::normalize(d)});
      }
      for (const geo::Polygon& p : f.polygons) {
        if (p.outer.size() < 3) continue;
        glm::dvec2 c(0.0);
        for (const glm::dvec2& v : p.outer) c += v;
        areas.push_back({c / static_cast<double>(p.outer.size()), glm::dvec2(1.0, 0.0)});
      }
    }
  }
  std::vector<scene::PathFrame> path;
  const auto& bounds = *setup.scene.projected().bounds;
  for (int k = 0; k < frames * 4 && static_cast<int>(path.size()) < frames; ++k) {
    const std::vector<Spot>& list = (k % 2 == 0 && !roads.empty()) || areas.empty() ? roads : areas;
    if (list.empty()) break;
    // Spread over the list: a fixed stride through it.
    const Spot& spot = list[(static_cast<std::size_t>(k) * 7919u) % list.size()];
    const double ground = bounds.fullResolutionHeightAt(spot.point);
    if (!std::isfinite(ground)) continue;
    scene::Camera c;
    c.eye = glm::dvec3(spot.point, ground + 1.5);
    const double down = 10.0 * std::numbers::pi / 180.0;
    c.target = c.eye + glm::dvec3(std::cos(down) * spot.direction, -std::sin(down));
    c.nearPlane = 0.1;
    path.push_back({c, "close-up"});
  }
  return path;
}

std::vector<BenchFrame> flightPath(const Options& o, const BenchSetup& setup) {
  std::vector<BenchFrame> all;
  if (setup.scene.onGlobe()) {
    const scene::LoadedGlobeScene& s = setup.scene.globe();
    for (const GlobeFrame& f : globePath(s, o.frames)) {
      const double ground = s.heights->heightAt(f.eye.lon, f.eye.lat);
      all.push_back(
          {globe::GlobeView::looking(globe::toEcef(f.eye), globe::toEcef(f.target), 45.0, o.width, o.height, ground),
           f.segment});
    }
    return all;
  }
  for (scene::PathFrame& f : flyThroughOf(o, setup)) all.push_back({f.camera, f.segment});
  return all;
}

std::vector<BenchFrame> methodsPath(const Options& o, const BenchSetup& setup) {
  std::vector<BenchFrame> all = flightPath(o, setup);
  if (setup.scene.onGlobe()) return all;  // the globe's segments are its own (--segments is the fly-through's)
  for (scene::PathFrame& f : closeUpPath(setup, std::max(o.frames / 3, 1))) all.push_back({f.camera, f.segment});
  if (o.segments.empty()) return all;
  std::vector<BenchFrame> kept;
  for (BenchFrame& f : all) {
    if (std::find(o.segments.begin(), o.segments.end(), f.segment) != o.segments.end()) kept.push_back(std::move(f));
  }
  return kept;
}

}  // namespace gis::bench
