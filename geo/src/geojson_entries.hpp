#pragma once
// GDAL's GeoJSON driver skips an entry of a FeatureCollection's "features" array that is not an
// object (a number, a string, null) without a word. This finds them, streaming the file (a SAX
// parse: memory does not grow with the file), so that each can be named.
#include <array>
#include <cstddef>
#include <istream>
#include <streambuf>
#include <string>
#include <vector>

#include <cpl_vsi.h>
#include <nlohmann/json.hpp>

namespace gis::geo::detail {

/// An entry of the top-level "features" array that is not an object.
struct NonObjectEntry {
  std::size_t index = 0;  ///< its place in the array, from 0
  std::string kind;       ///< "a number", "a string", "null", "a boolean", "an array"
};

class FeatureEntryScanner final : public nlohmann::json::json_sax_t {
 public:
  bool null() override { return value("null"); }
  bool boolean(bool) override { return value("a boolean"); }
  bool number_integer(number_integer_t) override { return value("a number"); }
  bool number_unsigned(number_unsigned_t) override { return value("a number"); }
  bool number_float(number_float_t, const string_t&) override { return value("a number"); }
  bool string(string_t&) override { return value("a string"); }
  bool binary(binary_t&) override { return value("binary data"); }
  bool start_object(std::size_t) override {
    if (inFeatures()) ++entry_;
    ++depth_;
    return true;
  }
  bool end_object() override {
    --depth_;
    return true;
  }
  bool key(string_t& k) override {
    if (depth_ == 1) featuresKey_ = k == "features";
    return true;
  }
  bool start_array(std::size_t) override {
    if (inFeatures()) {
      found_.push_back({entry_++, "an array"});
    } else if (depth_ == 1 && featuresKey_) {
      featuresArrayDepth_ = depth_ + 1;
    }
    ++depth_;
    return true;
  }
  bool end_array() override {
    --depth_;
    if (depth_ + 1 == featuresArrayDepth_) featuresArrayDepth_ = 0;
    return true;
  }
  bool parse_error(std::size_t, const std::string&, const nlohmann::json::exception&) override { return false; }

  [[nodiscard]] const std::vector<NonObjectEntry>& found() const { return found_; }

 private:
  [[nodiscard]] bool inFeatures() const { return featuresArrayDepth_ != 0 && depth_ == featuresArrayDepth_; }
  bool value(const char* kind) {
    if (inFeatures()) found_.push_back({entry_++, kind});
    return true;
  }
  int depth_ = 0;
  bool featuresKey_ = false;
  int featuresArrayDepth_ = 0;  ///< depth inside the top-level "features" array; 0 = not in it
  std::size_t entry_ = 0;
  std::vector<NonObjectEntry> found_;
};

/// A std::streambuf over a file read through GDAL's virtual file system (/vsimem/, /vsizip/, …).
class VsiStreamBuffer final : public std::streambuf {
 public:
  explicit VsiStreamBuffer(const std::string& path) : file_(VSIFOpenL(path.c_str(), "rb")) {}
  ~VsiStreamBuffer() override {
    if (file_ != nullptr) VSIFCloseL(file_);
  }
  VsiStreamBuffer(const VsiStreamBuffer&) = delete;
  VsiStreamBuffer& operator=(const VsiStreamBuffer&) = delete;
  [[nodiscard]] bool open() const { return file_ != nullptr; }

 protected:
  int_type underflow() override {
    if (file_ == nullptr) return traits_type::eof();
    const std::size_t n = VSIFReadL(buffer_.data(), 1, buffer_.size(), file_);
    if (n == 0) return traits_type::eof();
    setg(buffer_.data(), buffer_.data(), buffer_.data() + n);
    return traits_type::to_int_type(buffer_[0]);
  }

 private:
  VSILFILE* file_;
  std::array<char, 1 << 16> buffer_{};
};

/// The non-object entries of a GeoJSON file's top-level "features" array (none when the file
/// cannot be read as JSON: GDAL has said why already).
inline std::vector<NonObjectEntry> nonObjectFeatureEntries(const std::string& path) {
  VsiStreamBuffer buffer(path);
  if (!buffer.open()) return {};
  std::istream in(&buffer);
  FeatureEntryScanner scanner;
  nlohmann::json::sax_parse(in, &scanner, nlohmann::json::input_format_t::json, false);
  return scanner.found();
}

}  // namespace gis::geo::detail
