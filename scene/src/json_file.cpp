#include "scene/json_file.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <vector>

namespace gis::scene {

bool writeJsonFile(const std::string& path, const nlohmann::json& j) {
  const std::string partial = path + ".part";
  {
    std::ofstream out(partial);
    out << jsonText(j) << "\n";
    out.flush();
    if (!out) {
      std::error_code ec;
      std::filesystem::remove(partial, ec);
      return false;
    }
  }
  std::error_code ec;
  std::filesystem::rename(partial, path, ec);
  if (!ec) return true;
  std::filesystem::remove(partial, ec);
  return false;
}

std::optional<nlohmann::json> readJsonFile(const std::string& path, Diagnostics& d) {
  // A folder opens as a stream on Linux, and reading it throws: say what it is instead.
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    d.add({Severity::Error, path, "", "", "is a folder, not a file"});
    return std::nullopt;
  }
  std::ifstream in(path);
  if (!in) {
    d.add({Severity::Error, path, "", "", "cannot open"});
    return std::nullopt;
  }
  try {
    nlohmann::json j;
    in >> j;
    return j;
  } catch (const nlohmann::json::exception& e) {
    d.add({Severity::Error, path, "", "", std::string("not JSON: ") + e.what()});
  } catch (const std::exception& e) {
    d.add({Severity::Error, path, "", "", std::string("cannot read: ") + e.what()});
  }
  return std::nullopt;
}

namespace {

/// Edits from `a` to `b`: insertions, deletions, substitutions and swaps of neighbours (optimal
/// string alignment distance).
std::size_t editDistance(std::string_view a, std::string_view b) {
  const std::size_t n = a.size(), m = b.size();
  std::vector<std::vector<std::size_t>> e(n + 1, std::vector<std::size_t>(m + 1, 0));
  for (std::size_t i = 0; i <= n; ++i) e[i][0] = i;
  for (std::size_t j = 0; j <= m; ++j) e[0][j] = j;
  for (std::size_t i = 1; i <= n; ++i) {
    for (std::size_t j = 1; j <= m; ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      e[i][j] = std::min({e[i - 1][j] + 1, e[i][j - 1] + 1, e[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        e[i][j] = std::min(e[i][j], e[i - 2][j - 2] + 1);
    }
  }
  return e[n][m];
}

}  // namespace

std::optional<std::string> closestKey(std::string_view key, std::initializer_list<std::string_view> known) {
  // Keys are short: a key of hundreds of letters is no slip, and costs nothing to refuse.
  if (key.empty() || key.size() > 64) return std::nullopt;
  std::optional<std::string> best;
  std::size_t bestDistance = 3;
  for (const std::string_view k : known) {
    const std::size_t d = editDistance(key, k);
    if (d < bestDistance && 2 * d < key.size()) {
      bestDistance = d;
      best = std::string(k);
    }
  }
  return best;
}

void warnUnknownKeys(const nlohmann::json& object, std::initializer_list<std::string_view> known,
                     const std::string& file, const std::string& where, Diagnostics& d) {
  if (!object.is_object()) return;
  for (const auto& item : object.items()) {
    const std::string& key = item.key();
    if (std::find(known.begin(), known.end(), key) != known.end()) continue;
    std::string message = "unknown key \"" + where + key + "\" (ignored)";
    if (const std::optional<std::string> meant = closestKey(key, known))
      message += "; did you mean \"" + *meant + "\"?";
    d.add({Severity::Warning, file, "", "", message});
  }
}

}  // namespace gis::scene
