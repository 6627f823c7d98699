// The cache may cost time, never a pixel or a run (issue 40). The real overlay_render on the
// Olinda sample copied to scratch folders, its cache damaged the way disks, crashes and copies
// damage files — bits flipped, files cut short, 4 KB blocks zeroed, files emptied, files replaced
// by others of the cache — at many seeds; runs killed with SIGKILL at moments spread over a cold
// run; four cold runs at once on one cache; a read-only scene folder; a cache path that is a
// file; a full disk (a small tmpfs, or a file-size limit where mounting is not allowed). Every
// run exits 0 with mask.png identical to a clean run's; damage is named in a warning, and the
// next run finds the cache whole again.
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <signal.h>
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "gfx/image_io.hpp"
#include "program_output.hpp"
#include "test_paths.hpp"

namespace gis::test {
namespace {

namespace fs = std::filesystem;

const std::string kSamples = STENCIL_GIS_SAMPLES_DIR;
const std::string kSize = "--width 128 --height 96";

/// Copies the Olinda sample (not a cache of it) into `dir`; returns its scene file.
fs::path copyOlinda(const fs::path& dir) {
  fs::create_directories(dir);
  for (const fs::directory_entry& e : fs::directory_iterator(kSamples + "/olinda"))
    if (e.is_regular_file()) fs::copy_file(e.path(), dir / e.path().filename(), fs::copy_options::overwrite_existing);
  return dir / "scene.json";
}

/// overlay_render on `scene` into `out`, its output in `log`; `prefix` before the command (an
/// environment, a shell trap). The exit status, -1 when it did not exit.
int render(const fs::path& scene, const fs::path& out, const fs::path& log, const std::string& extra = {},
           const std::string& prefix = {}) {
  const std::string command = prefix + " " + std::string(OVERLAY_RENDER_EXE) + " --scene " + scene.string() + " " +
                              kSize + " --out " + out.string() + " " + extra + " > " + log.string() + " 2>&1";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::vector<std::uint8_t> maskOf(const fs::path& out) {
  Result<gfx::Image8> mask = gfx::readImage8((out / "mask.png").string());
  return mask ? mask->pixels : std::vector<std::uint8_t>();
}

/// The regular files of a cache, in name order.
std::vector<fs::path> cacheFiles(const fs::path& cache) {
  std::vector<fs::path> files;
  std::error_code ec;
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(cache, ec))
    if (e.is_regular_file(ec)) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

std::string bytesOf(const fs::path& file) { return readText(file); }
void writeBytes(const fs::path& file, const std::string& bytes) {
  std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
}

/// Whether a line of `log` holds both `a` and `b`.
bool lineWith(const std::string& log, const std::string& a, const std::string& b) {
  std::istringstream in(log);
  for (std::string line; std::getline(in, line);)
    if (line.find(a) != std::string::npos && line.find(b) != std::string::npos) return true;
  return false;
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
  return n;
}

class CacheFaults : public ::testing::Test {
 protected:
  // One clean cold run per process (ctest runs each case in its own): the reference mask and a
  // whole cache to damage.
  static void SetUpTestSuite() {
    root_ = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("faults_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    const fs::path scene = copyOlinda(root_ / "clean");
    const auto start = std::chrono::steady_clock::now();
    ASSERT_EQ(render(scene, root_ / "clean-out", root_ / "clean.log"), 0) << readText(root_ / "clean.log");
    coldSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    reference_ = maskOf(root_ / "clean-out");
    ASSERT_FALSE(reference_.empty());
    ASSERT_FALSE(cacheFiles(root_ / "clean" / ".stencil-gis-cache").empty());
    // The same view draws something of both layers, so a lost feature would show.
    std::size_t drawn = 0;
    for (const std::uint8_t m : reference_) drawn += m != 0 ? 1 : 0;
    ASSERT_GT(drawn, reference_.size() / 20);
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  /// The clean scene with its whole cache as the clean run left it (its files are named by what
  /// they were made from, the sources' absolute paths included: a cache copied beside another
  /// copy of the scene would never be read).
  static fs::path sceneWithCache() {
    const fs::path cache = root_ / "clean" / ".stencil-gis-cache";
    if (!fs::exists(root_ / "pristine-cache")) fs::copy(cache, root_ / "pristine-cache", fs::copy_options::recursive);
    fs::remove_all(cache);
    fs::copy(root_ / "pristine-cache", cache, fs::copy_options::recursive);
    return root_ / "clean" / "scene.json";
  }

  /// Runs and checks: exit 0, the clean mask. Returns the log.
  static std::string renderSame(const fs::path& scene, const std::string& name, const std::string& extra = {},
                                const std::string& prefix = {}) {
    const fs::path out = root_ / (name + "-out"), log = root_ / (name + ".log");
    const int status = render(scene, out, log, extra, prefix);
    const std::string text = readText(log);
    EXPECT_EQ(status, 0) << name << ":\n" << text;
    EXPECT_TRUE(maskOf(out) == reference_) << name << ": mask.png differs from the clean run's\n" << text;
    return text;
  }

  static inline fs::path root_;
  static inline double coldSeconds_ = 0.0;
  static inline std::vector<std::uint8_t> reference_;
};

enum class Damage { Flip, Truncate, ZeroBlock, Empty, Replace };
const char* nameOf(Damage d) {
  switch (d) {
    case Damage::Flip:
      return "bits flipped";
    case Damage::Truncate:
      return "cut short";
    case Damage::ZeroBlock:
      return "a 4 KB block zeroed";
    case Damage::Empty:
      return "emptied";
    case Damage::Replace:
      return "replaced by another cache file";
  }
  return "";
}

TEST_F(CacheFaults, DamagedFilesAreRebuiltWithAWarningAndNeverChangeAPixel) {
  std::size_t damagedTilesFound = 0;
  for (unsigned seed = 1; seed <= 12; ++seed) {
    const std::string name = "seed-" + std::to_string(seed);
    const fs::path scene = sceneWithCache();
    const std::vector<fs::path> files = cacheFiles(scene.parent_path() / ".stencil-gis-cache");
    std::mt19937 random(seed);
    std::vector<fs::path> damaged = files;
    std::shuffle(damaged.begin(), damaged.end(), random);
    damaged.resize((files.size() + 1) / 2);
    std::string what;
    for (const fs::path& f : damaged) {
      std::string bytes = bytesOf(f);
      const auto d = static_cast<Damage>(random() % 5);
      const auto at = [&](std::size_t n) { return n == 0 ? 0 : static_cast<std::size_t>(random() % n); };
      switch (d) {
        case Damage::Flip:
          for (int k = 0, n = 1 + static_cast<int>(random() % 8); k < n && !bytes.empty(); ++k)
            bytes[at(bytes.size())] ^= static_cast<char>(1U << (random() % 8));
          break;
        case Damage::Truncate:
          bytes.resize(at(bytes.size()));
          break;
        case Damage::ZeroBlock: {
          const std::size_t from = at(bytes.size()) / 4096 * 4096;
          std::fill(bytes.begin() + static_cast<std::ptrdiff_t>(from),
                    bytes.begin() + static_cast<std::ptrdiff_t>(std::min(bytes.size(), from + 4096)), '\0');
          break;
        }
        case Damage::Empty:
          bytes.clear();
          break;
        case Damage::Replace:
          bytes = bytesOf(files[at(files.size())]);
          break;
      }
      writeBytes(f, bytes);
      what += "  " + f.filename().string() + ": " + nameOf(d) + "\n";
    }
    SCOPED_TRACE(name + ", damaged:\n" + what);
    const std::string log = renderSame(scene, name);
    // A layer file is read whole at every start: each damaged one is named, with its source.
    for (const fs::path& f : damaged) {
      if (f.extension() != ".layer" ||
          bytesOf(root_ / "pristine-cache" / f.parent_path().filename() / f.filename()) == bytesOf(f))
        continue;
      EXPECT_TRUE(lineWith(log, f.filename().string(), "cache file damaged (")) << f << "\n" << log;
    }
    EXPECT_EQ(log.find("internal error"), std::string::npos) << log;
    // Every damaged tile file the run found is in stats.json too (said while drawing).
    const std::string stats = readText(root_ / (name + "-out") / "stats.json");
    for (const fs::path& f : damaged) {
      if (f.extension() == ".tile" && lineWith(log, f.filename().string(), "cache file damaged (")) {
        EXPECT_NE(stats.find(f.filename().string()), std::string::npos) << f << " is not in stats.json";
        ++damagedTilesFound;
      }
    }
    // The next run finds every file it reads whole: nothing damaged, the same picture.
    const std::string again = renderSame(scene, name + "-again");
    EXPECT_EQ(again.find("damaged"), std::string::npos) << again;
  }
  std::printf("%zu damaged tile files found while drawing, each in its run's stats.json\n", damagedTilesFound);
  EXPECT_GT(damagedTilesFound, 0U) << "no seed damaged a tile the run read";
}

TEST_F(CacheFaults, DamagedChecksOfTheDeferredLookupAreRebuilt) {
  // The deferred lookup keeps the features' checks in the cache (vector-checks/).
  const fs::path scene = copyOlinda(root_ / "deferred");
  // Its own picture: the lookup draws lines in metres, the tiles at least a pixel wide.
  const fs::path cleanOut = root_ / "deferred-clean-out";
  ASSERT_EQ(render(scene, cleanOut, root_ / "deferred-clean.log", "--method deferred"), 0);
  const std::string clean = readText(root_ / "deferred-clean.log");
  const std::vector<std::uint8_t> reference = maskOf(cleanOut);
  ASSERT_FALSE(reference.empty());
  std::vector<fs::path> checks;
  for (const fs::path& f : cacheFiles(scene.parent_path() / ".stencil-gis-cache"))
    if (f.extension() == ".checks") checks.push_back(f);
  ASSERT_FALSE(checks.empty()) << clean;
  for (const fs::path& f : checks) {
    std::string bytes = bytesOf(f);
    ASSERT_GT(bytes.size(), 16U);
    bytes[bytes.size() / 3] ^= 0x10;
    writeBytes(f, bytes);
  }
  for (const std::string name : {"deferred-damaged", "deferred-again"}) {
    const fs::path out = root_ / (name + "-out");
    EXPECT_EQ(render(scene, out, root_ / (name + ".log"), "--method deferred"), 0);
    EXPECT_TRUE(maskOf(out) == reference) << name;
  }
  const std::string log = readText(root_ / "deferred-damaged.log");
  EXPECT_EQ(count(log, "cache file damaged"), checks.size()) << log;
  const std::string again = readText(root_ / "deferred-again.log");
  EXPECT_EQ(again.find("damaged"), std::string::npos) << again;
}

TEST_F(CacheFaults, ARunKilledAtAnyMomentLeavesACacheTheNextRunUses) {
  const fs::path exe = OVERLAY_RENDER_EXE;
  for (int k = 0; k < 6; ++k) {
    const std::string name = "killed-" + std::to_string(k);
    const fs::path scene = copyOlinda(root_ / name);
    const fs::path out = root_ / (name + "-out");
    fs::create_directories(out);
    // Moments spread over the cold run, from its start to its end.
    const auto wait = std::chrono::duration<double>(coldSeconds_ * (0.05 + 0.9 * k / 5.0));
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      const std::string log = (root_ / (name + "-killed.log")).string();
      std::freopen(log.c_str(), "w", stdout);
      std::freopen(log.c_str(), "a", stderr);
      ::execl(exe.c_str(), exe.c_str(), "--scene", scene.c_str(), "--width", "128", "--height", "96", "--out",
              out.c_str(), static_cast<char*>(nullptr));
      std::_Exit(127);
    }
    std::this_thread::sleep_for(wait);
    ::kill(child, SIGKILL);
    int status = 0;
    ::waitpid(child, &status, 0);
    const std::string log = renderSame(scene, name);
    EXPECT_EQ(log.find("damaged"), std::string::npos) << name << ": a killed writer left a file under its name\n"
                                                      << log;
    fs::remove_all(scene.parent_path());
  }
}

TEST_F(CacheFaults, ConcurrentColdRunsShareOneCache) {
  const fs::path scene = copyOlinda(root_ / "concurrent");
  std::vector<std::thread> runs;
  std::vector<int> status(4, -1);
  for (int k = 0; k < 4; ++k) {
    runs.emplace_back([&, k] {
      const std::string name = "concurrent-" + std::to_string(k);
      status[static_cast<std::size_t>(k)] = render(scene, root_ / (name + "-out"), root_ / (name + ".log"));
    });
  }
  for (std::thread& t : runs) t.join();
  for (int k = 0; k < 4; ++k) {
    const std::string name = "concurrent-" + std::to_string(k);
    const std::string log = readText(root_ / (name + ".log"));
    EXPECT_EQ(status[static_cast<std::size_t>(k)], 0) << log;
    EXPECT_TRUE(maskOf(root_ / (name + "-out")) == reference_) << name << "\n" << log;
    EXPECT_EQ(log.find("damaged"), std::string::npos) << log;
  }
  // And a warm run after them.
  const std::string log = renderSame(scene, "concurrent-warm");
  EXPECT_EQ(log.find("damaged"), std::string::npos) << log;
}

/// Makes `dir` read-only: a read-only bind mount where we may mount (root: EROFS for everyone),
/// else its permissions. Returns how to undo it.
std::function<void()> makeReadOnly(const fs::path& dir) {
  if (::mount(dir.c_str(), dir.c_str(), nullptr, MS_BIND, nullptr) == 0) {
    if (::mount(nullptr, dir.c_str(), nullptr, MS_REMOUNT | MS_BIND | MS_RDONLY, nullptr) == 0)
      return [dir] { ::umount(dir.c_str()); };
    ::umount(dir.c_str());
  }
  fs::permissions(dir, fs::perms::owner_write | fs::perms::group_write | fs::perms::others_write,
                  fs::perm_options::remove);
  return [dir] { fs::permissions(dir, fs::perms::owner_write, fs::perm_options::add); };
}

TEST_F(CacheFaults, AReadOnlySceneFolderUsesTheUserCacheOrNone) {
  const fs::path scene = copyOlinda(root_ / "readonly");
  const fs::path userCache = root_ / "user-cache";
  const std::function<void()> undo = makeReadOnly(scene.parent_path());
  const std::string env = "XDG_CACHE_HOME=" + userCache.string();
  const std::string log = renderSame(scene, "readonly-user", {}, env);
  EXPECT_EQ(count(log, "cannot be written"), 1U) << log;
  EXPECT_NE(log.find("using " + (userCache / "stencil-gis").string()), std::string::npos) << log;
  EXPECT_FALSE(cacheFiles(userCache / "stencil-gis").empty()) << "the user cache was not used";
  // Warm from the user's cache.
  const std::string warm = renderSame(scene, "readonly-user-warm", {}, env);
  EXPECT_EQ(warm.find("damaged"), std::string::npos) << warm;
  // Neither the scene's folder nor a user cache: no cache, the same picture, one warning.
  const fs::path notAFolder = root_ / "not-a-folder";
  writeBytes(notAFolder, "a file");
  const std::string none =
      renderSame(scene, "readonly-none", {}, "XDG_CACHE_HOME=" + notAFolder.string() + " HOME=" + notAFolder.string());
  EXPECT_EQ(count(none, "running without a cache"), 1U) << none;
  undo();
  EXPECT_FALSE(fs::exists(scene.parent_path() / ".stencil-gis-cache"));
}

TEST_F(CacheFaults, ACachePathThatIsAFileFallsBack) {
  const fs::path scene = copyOlinda(root_ / "cache-is-file");
  const fs::path file = root_ / "cache-is-file" / "cache";
  writeBytes(file, "not a folder");
  const fs::path userCache = root_ / "user-cache-2";
  const std::string log =
      renderSame(scene, "cache-is-file", "--cache-dir " + file.string(), "XDG_CACHE_HOME=" + userCache.string());
  EXPECT_EQ(count(log, "cannot be written"), 1U) << log;
  EXPECT_FALSE(cacheFiles(userCache / "stencil-gis").empty());
  // --no-cache: nothing written anywhere.
  const fs::path nothing = root_ / "user-cache-3";
  renderSame(scene, "no-cache", "--no-cache", "XDG_CACHE_HOME=" + nothing.string());
  EXPECT_FALSE(fs::exists(nothing / "stencil-gis"));  // (Mesa keeps its shader cache there)
  EXPECT_FALSE(fs::exists(scene.parent_path() / ".stencil-gis-cache"));
}

TEST_F(CacheFaults, AFullDiskCostsTheCacheNotTheRun) {
  // The clean cache's size: disks that fill at a quarter, half and three quarters of it.
  std::uintmax_t total = 0;
  for (const fs::path& f : cacheFiles(root_ / "clean" / ".stencil-gis-cache")) total += fs::file_size(f);
  ASSERT_GT(total, 16U * 4096U);
  for (const int quarter : {1, 2, 3}) {
    const std::string name = "full-" + std::to_string(quarter);
    const fs::path scene = copyOlinda(root_ / name);
    const fs::path disk = root_ / (name + "-disk");
    fs::create_directories(disk);
    const std::uintmax_t bytes = std::max<std::uintmax_t>(4096, total * static_cast<unsigned>(quarter) / 4);
    const bool mounted = ::mount("tmpfs", disk.c_str(), "tmpfs", 0, ("size=" + std::to_string(bytes)).c_str()) == 0;
    // Without the right to mount: a file-size limit (writes past it fail, SIGXFSZ ignored) makes
    // the larger cache files fail mid-write; the outputs are smaller than it.
    const std::string prefix =
        mounted ? std::string()
                : "trap '' XFSZ; ulimit -f " + std::to_string(std::max<std::uintmax_t>(bytes, 65536) / 1024) + ";";
    for (int run = 0; run < 2; ++run) {
      const std::string log =
          renderSame(scene, name + "-" + std::to_string(run), "--cache-dir " + (disk / "cache").string(), prefix);
      EXPECT_EQ(log.find("damaged"), std::string::npos) << log;
      EXPECT_EQ(log.find("internal error"), std::string::npos) << log;
    }
    // No temporary file of a failed write is left behind.
    for (const fs::path& f : cacheFiles(disk)) EXPECT_EQ(f.filename().string().find(".tmp"), std::string::npos) << f;
    if (mounted) ::umount(disk.c_str());
  }
}

}  // namespace
}  // namespace gis::test
