// Cache files that check themselves (geo/checked_file.hpp): every single-bit flip, every cut and
// every zeroed block of a file is found before a byte of the damaged section is used; a file's
// sections read back as written, through one descriptor whatever is renamed over the path.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "geo/binary_io.hpp"
#include "geo/checked_file.hpp"
#include "test_paths.hpp"

namespace gis::test {
namespace {

namespace fs = std::filesystem;
using geo::io::CheckedFile;
using geo::io::CheckedStatus;

fs::path outputDir() {
  const fs::path dir = fs::path(STENCIL_GIS_TEST_OUTPUT_DIR) / ("checked_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir;
}

const std::vector<std::string> kSections = {"header", std::string(300, 'x') + "features", "index and messages"};

bool writeSample(const fs::path& file, const std::vector<std::string>& sections = kSections) {
  return geo::io::writeCheckedFile(file,
                                   [&](std::ostream& out, geo::io::SectionMarks& marks) {
                                     for (const std::string& s : sections) {
                                       marks.begin();
                                       out << s;
                                     }
                                   })
      .written;
}

std::string bytesOf(const fs::path& f) {
  std::ifstream in(f, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Whether the file opens with every section verified and as written.
bool whole(const fs::path& file) {
  CheckedStatus status = CheckedStatus::Missing;
  std::string why;
  const auto f = CheckedFile::open(file, status, why);
  if (!f || f->sections() != kSections.size()) return false;
  for (std::size_t i = 0; i < kSections.size(); ++i) {
    const std::optional<std::string> s = f->read(i);
    if (!f->verify(i) || !s || *s != kSections[i]) return false;
  }
  return true;
}

TEST(CheckedFile, SectionsReadBackAsWritten) {
  const fs::path file = outputDir() / "sample.bin";
  ASSERT_TRUE(writeSample(file));
  EXPECT_TRUE(whole(file));
  CheckedStatus status = CheckedStatus::Ok;
  std::string why;
  EXPECT_EQ(CheckedFile::open(outputDir() / "missing.bin", status, why), nullptr);
  EXPECT_EQ(status, CheckedStatus::Missing);
  // A stream over a section reads its bytes at the file's offsets.
  const auto f = CheckedFile::open(file, status, why);
  ASSERT_NE(f, nullptr);
  geo::io::SectionStream in(*f, 1);
  EXPECT_EQ(static_cast<std::uint64_t>(in.tellg()), f->section(1).offset);
  std::string read(kSections[1].size(), '\0');
  in.read(read.data(), static_cast<std::streamsize>(read.size()));
  EXPECT_EQ(read, kSections[1]);
  EXPECT_EQ(in.get(), std::char_traits<char>::eof()) << "a section stream ends with its section";
  // Whatever is renamed over the path, the open file reads what was verified.
  ASSERT_TRUE(writeSample(file, {"other", "sections", "entirely"}));
  EXPECT_EQ(f->read(1), kSections[1]);
}

TEST(CheckedFile, EveryFlipCutAndZeroedBlockIsFound) {
  const fs::path file = outputDir() / "sample.bin";
  ASSERT_TRUE(writeSample(file));
  const std::string clean = bytesOf(file);
  const fs::path damaged = outputDir() / "damaged.bin";
  const auto check = [&](const std::string& bytes, const std::string& what) {
    std::ofstream(damaged, std::ios::binary | std::ios::trunc) << bytes;
    CheckedStatus status = CheckedStatus::Ok;
    std::string why;
    const auto f = CheckedFile::open(damaged, status, why);
    bool allVerified = f != nullptr;
    for (std::size_t i = 0; f && i < f->sections(); ++i) allVerified = allVerified && f->verify(i) && f->read(i);
    EXPECT_FALSE(allVerified) << what << " was not found";
    if (!f) {
      EXPECT_EQ(status, CheckedStatus::Damaged) << what;
    }
  };
  for (std::size_t at = 0; at < clean.size(); ++at) {
    for (int bit = 0; bit < 8; ++bit) {
      std::string bytes = clean;
      bytes[at] = static_cast<char>(bytes[at] ^ (1 << bit));
      check(bytes, "bit " + std::to_string(bit) + " of byte " + std::to_string(at));
    }
    check(clean.substr(0, at), "a cut at " + std::to_string(at));
  }
  std::string zeroed = clean;
  std::fill(zeroed.begin() + 20, zeroed.begin() + 120, '\0');
  check(zeroed, "a zeroed block");
  check(std::string(clean.size(), '\0'), "a zeroed file");
}

TEST(CheckedFile, AWriteThatFailsLeavesNothing) {
  // A folder where the file should be: the write fails, no temporary file stays.
  const fs::path dir = outputDir() / "is-a-folder";
  fs::create_directories(dir / "inner");
  const geo::io::WriteOutcome outcome =
      geo::io::writeCheckedFile(dir, [](std::ostream& out, geo::io::SectionMarks& marks) {
        marks.begin();
        out << "x";
      });
  EXPECT_FALSE(outcome.written);
  EXPECT_FALSE(outcome.error.empty());
  for (const fs::directory_entry& e : fs::directory_iterator(outputDir()))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

TEST(CheckedFile, StaleTemporariesAreRemoved) {
  const fs::path dir = outputDir() / "temporaries";
  fs::create_directories(dir / "sub");
  std::ofstream(dir / "sub" / "a.tile.tmp-1-2-3") << "old";
  std::ofstream(dir / "b.layer.tmp-4-5-6") << "new";
  std::ofstream(dir / "c.layer") << "kept";
  fs::last_write_time(dir / "sub" / "a.tile.tmp-1-2-3", fs::file_time_type::clock::now() - std::chrono::hours(2));
  EXPECT_EQ(geo::io::removeStaleTemporaries(dir, std::chrono::hours(1)), 1u);
  EXPECT_FALSE(fs::exists(dir / "sub" / "a.tile.tmp-1-2-3"));
  EXPECT_TRUE(fs::exists(dir / "b.layer.tmp-4-5-6"));
  EXPECT_TRUE(fs::exists(dir / "c.layer"));
}

}  // namespace
}  // namespace gis::test
