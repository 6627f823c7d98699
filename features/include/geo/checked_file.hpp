#pragma once
// Cache files that check themselves (issue 40): a file is a run of sections followed by a table
// of them — each section's offset, length and XXH3-64 digest — the table's own digest, and a
// fixed tail (the table's offset and a magic). A reader opens the file once, checks the table,
// and verifies a section's digest before it uses any byte of it, so a bit flip, a zeroed block,
// a file cut short, an empty file or one of another format is found and named ("damaged"), and
// the cache rebuilds it from the source. Every read goes through the one descriptor opened
// first, so a writer renaming a new file into place meanwhile changes nothing that is read.
//
// Writes go to a unique temporary name in the same folder and are renamed into place: a reader
// or a crash never sees half a file, two writers never share one.
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <istream>
#include <memory>
#include <optional>
#include <ostream>
#include <streambuf>
#include <string>
#include <vector>

namespace gis::geo::io {

/// XXH3-64 of a byte range.
std::uint64_t digest(const void* data, std::size_t bytes);

/// A whole file's length and XXH3-64 digest, for cache files another library writes and reads by
/// path (GDAL's VRT and overviews): kept in a checked file beside them and compared before use.
struct FileDigest {
  std::uint64_t bytes = 0, digest = 0;
  bool operator==(const FileDigest&) const = default;
};
/// The digest of `file`, read through in slices (counted in verifiedSoFar); none when it cannot
/// be read.
std::optional<FileDigest> digestOfFile(const std::filesystem::path& file);

/// Marks where a writer's sections start: call begin() at the start of each section (the first
/// at the stream's start, or wherever the first byte to check is); a section ends where the next
/// begins, the last at the end of what was written.
class SectionMarks {
 public:
  explicit SectionMarks(std::ostream& out) : out_(out) {}
  void begin() { starts_.push_back(static_cast<std::uint64_t>(out_.tellp())); }
  [[nodiscard]] const std::vector<std::uint64_t>& starts() const { return starts_; }

 private:
  std::ostream& out_;
  std::vector<std::uint64_t> starts_;
};

/// How a write went: written, or why not (errno's text: "No space left on device", …).
struct WriteOutcome {
  bool written = false;
  std::string error;
  explicit operator bool() const { return written; }
};

/// Writes `file` whole or not at all, as checked sections: `write` fills a temporary file
/// (unique per process, thread and call) marking its sections; their digests and the table are
/// appended, the file is flushed (and fsync'd when `durable`), then renamed into place. A failed
/// write (full disk, read-only folder, a path that is a file) removes the temporary file.
WriteOutcome writeCheckedFile(const std::filesystem::path& file,
                              const std::function<void(std::ostream&, SectionMarks&)>& write, bool durable = false);

/// Why a checked file was not used.
enum class CheckedStatus {
  Ok,
  Missing,  ///< no such file (or not readable): build it, say nothing
  Damaged,  ///< a file that is not whole: rebuild it, and say so
};

/// A checked file opened for reading: its table checked, its sections verified on demand.
class CheckedFile {
 public:
  struct Section {
    std::uint64_t offset = 0, length = 0, digest = 0;
  };

  /// Opens `file` and checks its tail and table (not its sections). `status` says why not;
  /// `why` the damage found.
  static std::shared_ptr<const CheckedFile> open(const std::filesystem::path& file, CheckedStatus& status,
                                                 std::string& why);
  CheckedFile(const CheckedFile&) = delete;
  CheckedFile& operator=(const CheckedFile&) = delete;
  ~CheckedFile();

  [[nodiscard]] std::size_t sections() const { return sections_.size(); }
  [[nodiscard]] const Section& section(std::size_t i) const { return sections_.at(i); }
  /// Whether section i's bytes match its digest (read through in slices, never held whole).
  [[nodiscard]] bool verify(std::size_t i) const;
  /// Section i's bytes, verified; none when they cannot be read or do not match.
  [[nodiscard]] std::optional<std::string> read(std::size_t i) const;
  /// Reads [at, at + bytes) of the file; false when it cannot.
  bool readAt(std::uint64_t at, void* into, std::size_t bytes) const;
  /// The descriptor (owned by this file); dup() it to keep it beyond.
  [[nodiscard]] int descriptor() const { return fd_; }
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }

 private:
  CheckedFile() = default;
  std::filesystem::path path_;
  int fd_ = -1;
  std::vector<Section> sections_;
};

/// An input stream buffer over [begin, end) of a descriptor, read with pread a block at a time;
/// positions are the file's offsets (so a reader's tellg() is where a byte is in the file).
class DescriptorBuf : public std::streambuf {
 public:
  DescriptorBuf(int fd, std::uint64_t begin, std::uint64_t end);

 protected:
  int_type underflow() override;
  pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode which) override;
  pos_type seekpos(pos_type pos, std::ios_base::openmode which) override;

 private:
  int fd_;
  std::uint64_t begin_, end_;
  std::uint64_t bufferAt_;  ///< the file offset of the buffer's first byte
  std::vector<char> buffer_;
};

/// An istream over a section of a checked file (verify it first).
class SectionStream : public std::istream {
 public:
  SectionStream(const CheckedFile& file, std::size_t section)
      : std::istream(nullptr),
        buf_(file.descriptor(), file.section(section).offset,
             file.section(section).offset + file.section(section).length) {
    rdbuf(&buf_);
    seekg(static_cast<std::streamoff>(file.section(section).offset));
  }

 private:
  DescriptorBuf buf_;
};

/// What this process has verified so far (every CheckedFile's verify and read): bytes and the
/// seconds spent reading and hashing them — what the checks cost a start.
struct VerifiedSoFar {
  std::uint64_t bytes = 0;
  double seconds = 0.0;
};
VerifiedSoFar verifiedSoFar();

/// Removes temporary files of writers that ended without renaming them (killed, or out of disk)
/// from `directory` and its sub-folders: those older than `age`. Returns how many.
std::size_t removeStaleTemporaries(const std::filesystem::path& directory, std::chrono::seconds age);

}  // namespace gis::geo::io
