#pragma once
// Binary streams for the caches on disk (the overlay's tiles, the scene's layers as read): plain
// values, arrays of them, text, and features' geometry and attributes. Host byte order: a cache
// is read by the machine that wrote it. The files are checked sections (checked_file.hpp), verified
// before they are read; counts are still checked against what is left, so that no bytes, whatever
// they are, make a reader allocate without bound.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <istream>
#include <optional>
#include <ostream>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "geo/feature.hpp"

namespace gis::geo::io {

/// Counts beyond this mean a damaged file (no cache holds 2^32 of anything).
constexpr std::uint64_t kMaxCount = std::uint64_t{1} << 32U;

class Writer {
 public:
  explicit Writer(std::ostream& out) : out_(out) {}
  template <typename T>
  void value(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    out_.write(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  template <typename T>
  void array(const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    value(static_cast<std::uint64_t>(v.size()));
    out_.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(v.size() * sizeof(T)));
  }
  void text(const std::string& s) {
    value(static_cast<std::uint64_t>(s.size()));
    out_.write(s.data(), static_cast<std::streamsize>(s.size()));
  }

 private:
  std::ostream& out_;
};

class Reader {
 public:
  /// The stream's end is found once (where it can seek), so that a damaged count never makes
  /// an array larger than the bytes that are left.
  explicit Reader(std::istream& in) : in_(in) {
    const std::istream::pos_type here = in_.tellg();
    if (here == std::istream::pos_type(-1)) return;
    in_.seekg(0, std::ios::end);
    const std::istream::pos_type end = in_.tellg();
    in_.seekg(here);
    if (end != std::istream::pos_type(-1) && end >= here) left_ = static_cast<std::uint64_t>(end - here);
  }
  template <typename T>
  bool value(T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    in_.read(reinterpret_cast<char*>(&v), sizeof(T));
    consumed(sizeof(T));
    return static_cast<bool>(in_);
  }
  template <typename T>
  bool array(std::vector<T>& v) {
    std::size_t n = 0;
    if (!count(n) || !left(n, sizeof(T))) return false;
    v.resize(n);
    in_.read(reinterpret_cast<char*>(v.data()), static_cast<std::streamsize>(v.size() * sizeof(T)));
    consumed(n * sizeof(T));
    return static_cast<bool>(in_);
  }
  bool text(std::string& s) {
    std::size_t n = 0;
    if (!count(n) || !left(n, 1)) return false;
    s.resize(n);
    in_.read(s.data(), static_cast<std::streamsize>(n));
    consumed(n);
    return static_cast<bool>(in_);
  }
  /// Skips `bytes` bytes; false when fewer are left.
  bool skip(std::uint64_t bytes) {
    if (left_ && bytes > *left_) return false;
    in_.seekg(static_cast<std::streamoff>(bytes), std::ios::cur);
    consumed(bytes);
    return static_cast<bool>(in_);
  }
  /// An array left where it is: its count (items of `size` bytes, no more than are left) and
  /// where its items start in the stream (`at`), skipped, for a positioned read later.
  bool skipArray(std::size_t& n, std::size_t size, std::uint64_t& at) {
    if (!count(n) || !left(n, size)) return false;
    const std::istream::pos_type here = in_.tellg();
    if (here == std::istream::pos_type(-1)) return false;
    at = static_cast<std::uint64_t>(here);
    return skip(static_cast<std::uint64_t>(n) * size);
  }
  /// A count of items each at least `minBytes` long in the stream: false beyond what is left
  /// (a damaged count never allocates more than a few times the file's size).
  bool count(std::size_t& n, std::size_t minBytes = 1) {
    std::uint64_t c = 0;
    if (!value(c) || c >= kMaxCount) return false;
    n = static_cast<std::size_t>(c);
    return left(n, minBytes);
  }

  /// Whether `count` items of `size` bytes may still be in the stream (always, where its end
  /// is unknown).
  [[nodiscard]] bool left(std::size_t count, std::size_t size) const {
    return !left_ || size == 0 || count <= *left_ / size;
  }

 private:
  void consumed(std::uint64_t bytes) {
    if (left_) *left_ = bytes > *left_ ? 0 : *left_ - bytes;
  }
  std::istream& in_;
  std::optional<std::uint64_t> left_;  ///< bytes left in the stream, where its end is known
};

/// A feature's fid, polygons and lines (not its attributes).
inline void writeGeometry(Writer& w, const Feature& f) {
  w.value(f.fid);
  w.value(static_cast<std::uint64_t>(f.polygons.size()));
  for (const Polygon& p : f.polygons) {
    w.array(p.outer);
    w.value(static_cast<std::uint64_t>(p.holes.size()));
    for (const Ring& h : p.holes) w.array(h);
  }
  w.value(static_cast<std::uint64_t>(f.lines.size()));
  for (const LineString& l : f.lines) w.array(l);
}

inline bool readGeometry(Reader& r, Feature& f) {
  std::size_t n = 0;
  if (!r.value(f.fid) || !r.count(n, 16)) return false;  // an outer ring's count, a hole count
  f.polygons.resize(n);
  for (Polygon& p : f.polygons) {
    std::size_t holes = 0;
    if (!r.array(p.outer) || !r.count(holes, 8)) return false;
    p.holes.resize(holes);
    for (Ring& h : p.holes)
      if (!r.array(h)) return false;
  }
  if (!r.count(n, 8)) return false;
  f.lines.resize(n);
  for (LineString& l : f.lines)
    if (!r.array(l)) return false;
  return true;
}

inline void writeAttributes(Writer& w, const Feature& f) {
  w.value(static_cast<std::uint64_t>(f.attributes.size()));
  for (const auto& [name, value] : f.attributes) {
    w.text(name);
    w.value(static_cast<std::uint8_t>(value.index()));
    if (const auto* i = std::get_if<std::int64_t>(&value)) w.value(*i);
    if (const auto* d = std::get_if<double>(&value)) w.value(*d);
    if (const auto* s = std::get_if<std::string>(&value)) w.text(*s);
  }
}

inline bool readAttributes(Reader& r, Feature& f) {
  std::size_t n = 0;
  if (!r.count(n)) return false;
  f.attributes.clear();
  for (std::size_t k = 0; k < n; ++k) {
    std::string name;
    std::uint8_t kind = 0;
    if (!r.text(name) || !r.value(kind)) return false;
    AttributeValue value;
    if (kind == 1) {
      std::int64_t i = 0;
      if (!r.value(i)) return false;
      value = i;
    } else if (kind == 2) {
      double d = 0.0;
      if (!r.value(d)) return false;
      value = d;
    } else if (kind == 3) {
      std::string s;
      if (!r.text(s)) return false;
      value = std::move(s);
    } else if (kind != 0) {
      return false;
    }
    f.attributes.emplace(std::move(name), std::move(value));
  }
  return true;
}

}  // namespace gis::geo::io
