#include "geo/checked_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <system_error>
#include <thread>

#define XXH_INLINE_ALL
#include <xxhash.h>

namespace gis::geo::io {
namespace {

namespace fs = std::filesystem;

constexpr std::uint32_t kTableMagic = 0x4B434753;  // "SGCK"
constexpr std::uint32_t kTableVersion = 1;
/// The tail: the table's offset, the magic.
constexpr std::size_t kTailBytes = sizeof(std::uint64_t) + sizeof(std::uint32_t);
/// No cache file has more sections than this (a damaged count must not allocate).
constexpr std::uint64_t kMaxSections = 1U << 16U;
constexpr std::size_t kSliceBytes = std::size_t{1} << 20U;

template <typename T>
void put(std::string& out, const T& v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof(T));
}

template <typename T>
bool get(const std::string& in, std::size_t& at, T& v) {
  if (in.size() - at < sizeof(T)) return false;
  std::memcpy(&v, in.data() + at, sizeof(T));
  at += sizeof(T);
  return true;
}

bool preadAll(int fd, void* into, std::size_t bytes, std::uint64_t at) {
  auto* out = static_cast<char*>(into);
  std::size_t got = 0;
  while (got < bytes) {
    const ssize_t n = ::pread(fd, out + got, bytes - got, static_cast<off_t>(at + got));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    got += static_cast<std::size_t>(n);
  }
  return true;
}

bool writeAll(int fd, const char* data, std::size_t bytes) {
  std::size_t done = 0;
  while (done < bytes) {
    const ssize_t n = ::write(fd, data + done, bytes - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<std::size_t>(n);
  }
  return true;
}

/// The digest of [at, at + bytes) of `fd`, read in slices; none when it cannot be read.
std::optional<std::uint64_t> digestOf(int fd, std::uint64_t at, std::uint64_t bytes) {
  XXH3_state_t* state = XXH3_createState();
  if (state == nullptr) return std::nullopt;
  XXH3_64bits_reset(state);
  std::vector<char> buffer(static_cast<std::size_t>(std::min<std::uint64_t>(bytes, kSliceBytes)));
  bool ok = true;
  for (std::uint64_t done = 0; done < bytes && ok;) {
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(buffer.size(), bytes - done));
    ok = preadAll(fd, buffer.data(), n, at + done);
    if (ok) XXH3_64bits_update(state, buffer.data(), n);
    done += n;
  }
  const std::uint64_t d = XXH3_64bits_digest(state);
  XXH3_freeState(state);
  if (!ok) return std::nullopt;
  return d;
}

std::atomic<std::uint64_t> verifiedBytes{0};
std::atomic<std::uint64_t> verifiedNanoseconds{0};

/// Counts a verification into verifiedSoFar.
class VerifyClock {
 public:
  explicit VerifyClock(std::uint64_t bytes) : bytes_(bytes), start_(std::chrono::steady_clock::now()) {}
  VerifyClock(const VerifyClock&) = delete;
  VerifyClock& operator=(const VerifyClock&) = delete;
  ~VerifyClock() {
    verifiedBytes += bytes_;
    verifiedNanoseconds += static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - start_).count());
  }

 private:
  std::uint64_t bytes_;
  std::chrono::steady_clock::time_point start_;
};

std::string temporaryName(const fs::path& file) {
  static std::atomic<std::uint64_t> counter{0};
  return file.string() + ".tmp-" + std::to_string(::getpid()) + "-" +
         std::to_string(std::hash<std::thread::id>{}(std::this_thread::get_id()) % 1000000U) + "-" +
         std::to_string(counter.fetch_add(1));
}

}  // namespace

std::uint64_t digest(const void* data, std::size_t bytes) { return XXH3_64bits(data, bytes); }

std::optional<FileDigest> digestOfFile(const fs::path& file) {
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return std::nullopt;
  struct stat st {};
  std::optional<FileDigest> out;
  if (::fstat(fd, &st) == 0) {
    const auto bytes = static_cast<std::uint64_t>(st.st_size);
    const VerifyClock clock(bytes);
    if (const std::optional<std::uint64_t> d = digestOf(fd, 0, bytes)) out = FileDigest{bytes, *d};
  }
  ::close(fd);
  return out;
}

WriteOutcome writeCheckedFile(const fs::path& file, const std::function<void(std::ostream&, SectionMarks&)>& write,
                              bool durable) {
  WriteOutcome outcome;
  std::error_code ec;
  fs::create_directories(file.parent_path(), ec);
  const fs::path temporary = temporaryName(file);
  const auto fail = [&](const std::string& why) {
    outcome.error = why;
    fs::remove(temporary, ec);
    return outcome;
  };
  std::vector<std::uint64_t> starts;
  std::uint64_t end = 0;
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) return fail(std::strerror(errno));
    SectionMarks marks(out);
    write(out, marks);
    out.flush();
    if (!out) return fail(errno != 0 ? std::strerror(errno) : "cannot be written");
    end = static_cast<std::uint64_t>(out.tellp());
    starts = marks.starts();
  }
  if (starts.empty() || starts.front() != 0) starts.insert(starts.begin(), 0);  // the bytes before the first mark
  // The table, from the bytes as they are in the file (read back from the page cache).
  const int fd = ::open(temporary.c_str(), O_RDWR | O_CLOEXEC);
  if (fd < 0) return fail(std::strerror(errno));
  std::string table;
  put(table, kTableMagic);
  put(table, kTableVersion);
  put(table, static_cast<std::uint64_t>(starts.size()));
  bool ok = true;
  for (std::size_t i = 0; i < starts.size() && ok; ++i) {
    const std::uint64_t stop = i + 1 < starts.size() ? starts[i + 1] : end;
    const std::optional<std::uint64_t> d = stop >= starts[i] ? digestOf(fd, starts[i], stop - starts[i]) : std::nullopt;
    ok = d.has_value();
    put(table, starts[i]);
    put(table, stop - starts[i]);
    put(table, d.value_or(0));
  }
  put(table, digest(table.data(), table.size()));
  put(table, end);
  put(table, kTableMagic);
  std::string why;
  if (ok && (::lseek(fd, static_cast<off_t>(end), SEEK_SET) < 0 || !writeAll(fd, table.data(), table.size())))
    why = std::strerror(errno), ok = false;
  if (ok && durable && ::fsync(fd) != 0) why = std::strerror(errno), ok = false;
  if (::close(fd) != 0 && ok) why = std::strerror(errno), ok = false;
  if (!ok) return fail(why.empty() ? "cannot be read back" : why);
  fs::rename(temporary, file, ec);
  if (ec) return fail(ec.message());
  outcome.written = true;
  return outcome;
}

std::shared_ptr<const CheckedFile> CheckedFile::open(const fs::path& file, CheckedStatus& status, std::string& why) {
  status = CheckedStatus::Missing;
  std::shared_ptr<CheckedFile> f(new CheckedFile());
  f->path_ = file;
  f->fd_ = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (f->fd_ < 0) {
    why = std::strerror(errno);
    return nullptr;
  }
  const auto damaged = [&](const std::string& what) {
    status = CheckedStatus::Damaged;
    why = what;
    return nullptr;
  };
  struct stat st {};
  if (::fstat(f->fd_, &st) != 0 || !S_ISREG(st.st_mode)) return damaged("not a file");
  const auto size = static_cast<std::uint64_t>(st.st_size);
  if (size < kTailBytes) return damaged(size == 0 ? "empty" : "cut short");
  std::string tail(kTailBytes, '\0');
  if (!preadAll(f->fd_, tail.data(), kTailBytes, size - kTailBytes)) return damaged("cannot be read");
  std::size_t at = 0;
  std::uint64_t tableAt = 0;
  std::uint32_t magic = 0;
  (void)get(tail, at, tableAt);
  (void)get(tail, at, magic);
  if (magic != kTableMagic) return damaged("no section table at its end (cut short, or not a cache file)");
  // The table: magic, version, count, (offset, length, digest) per section, its digest.
  constexpr std::uint64_t kFixed = 2 * sizeof(std::uint32_t) + 2 * sizeof(std::uint64_t);
  if (tableAt > size - kTailBytes || size - kTailBytes - tableAt < kFixed)
    return damaged("its section table is damaged");
  const std::uint64_t tableBytes = size - kTailBytes - tableAt;
  if ((tableBytes - kFixed) % (3 * sizeof(std::uint64_t)) != 0 ||
      (tableBytes - kFixed) / (3 * sizeof(std::uint64_t)) > kMaxSections)
    return damaged("its section table is damaged");
  std::string table(static_cast<std::size_t>(tableBytes), '\0');
  if (!preadAll(f->fd_, table.data(), table.size(), tableAt)) return damaged("cannot be read");
  std::uint64_t stored = 0;
  std::memcpy(&stored, table.data() + table.size() - sizeof(stored), sizeof(stored));
  if (stored != digest(table.data(), table.size() - sizeof(stored))) return damaged("its section table is damaged");
  at = 0;
  std::uint32_t version = 0;
  std::uint64_t count = 0;
  (void)get(table, at, magic);
  (void)get(table, at, version);
  (void)get(table, at, count);
  if (magic != kTableMagic || version != kTableVersion || count != (tableBytes - kFixed) / (3 * sizeof(std::uint64_t)))
    return damaged("its section table is of another format");
  f->sections_.resize(static_cast<std::size_t>(count));
  std::uint64_t next = 0;
  for (Section& s : f->sections_) {
    (void)get(table, at, s.offset);
    (void)get(table, at, s.length);
    (void)get(table, at, s.digest);
    // The sections tile the file up to the table.
    if (s.offset != next || s.length > tableAt - s.offset) return damaged("its section table is damaged");
    next = s.offset + s.length;
  }
  if (next != tableAt) return damaged("its section table is damaged");
  status = CheckedStatus::Ok;
  return f;
}

CheckedFile::~CheckedFile() {
  if (fd_ >= 0) ::close(fd_);
}

VerifiedSoFar verifiedSoFar() { return {verifiedBytes.load(), static_cast<double>(verifiedNanoseconds.load()) * 1e-9}; }

bool CheckedFile::verify(std::size_t i) const {
  const Section& s = section(i);
  const VerifyClock clock(s.length);
  const std::optional<std::uint64_t> d = digestOf(fd_, s.offset, s.length);
  return d && *d == s.digest;
}

std::optional<std::string> CheckedFile::read(std::size_t i) const {
  const Section& s = section(i);
  const VerifyClock clock(s.length);
  std::string bytes(static_cast<std::size_t>(s.length), '\0');
  if (!preadAll(fd_, bytes.data(), bytes.size(), s.offset) || digest(bytes.data(), bytes.size()) != s.digest)
    return std::nullopt;
  return bytes;
}

bool CheckedFile::readAt(std::uint64_t at, void* into, std::size_t bytes) const {
  return preadAll(fd_, into, bytes, at);
}

DescriptorBuf::DescriptorBuf(int fd, std::uint64_t begin, std::uint64_t end)
    : fd_(fd), begin_(begin), end_(std::max(begin, end)), bufferAt_(begin), buffer_(64 * 1024) {
  setg(buffer_.data(), buffer_.data(), buffer_.data());
}

DescriptorBuf::int_type DescriptorBuf::underflow() {
  if (gptr() < egptr()) return traits_type::to_int_type(*gptr());
  const std::uint64_t at = bufferAt_ + static_cast<std::uint64_t>(egptr() - eback());
  if (at >= end_) return traits_type::eof();
  const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(buffer_.size(), end_ - at));
  if (!preadAll(fd_, buffer_.data(), n, at)) return traits_type::eof();
  bufferAt_ = at;
  setg(buffer_.data(), buffer_.data(), buffer_.data() + n);
  return traits_type::to_int_type(*gptr());
}

DescriptorBuf::pos_type DescriptorBuf::seekoff(off_type off, std::ios_base::seekdir dir,
                                               std::ios_base::openmode which) {
  if ((which & std::ios_base::in) == 0) return pos_type(off_type(-1));
  const std::uint64_t here = bufferAt_ + static_cast<std::uint64_t>(gptr() - eback());
  const auto base = static_cast<off_type>(dir == std::ios_base::beg ? 0 : dir == std::ios_base::cur ? here : end_);
  return seekpos(pos_type(base + off), which);
}

DescriptorBuf::pos_type DescriptorBuf::seekpos(pos_type pos, std::ios_base::openmode which) {
  const auto p = static_cast<off_type>(pos);
  if ((which & std::ios_base::in) == 0 || p < static_cast<off_type>(begin_) || p > static_cast<off_type>(end_))
    return pos_type(off_type(-1));
  const auto at = static_cast<std::uint64_t>(p);
  const std::uint64_t bufferEnd = bufferAt_ + static_cast<std::uint64_t>(egptr() - eback());
  if (at >= bufferAt_ && at < bufferEnd) {
    setg(eback(), eback() + (at - bufferAt_), egptr());
  } else {
    bufferAt_ = at;
    setg(buffer_.data(), buffer_.data(), buffer_.data());
  }
  return pos;
}

std::size_t removeStaleTemporaries(const fs::path& directory, std::chrono::seconds age) {
  std::error_code ec;
  std::size_t removed = 0;
  const fs::file_time_type now = fs::file_time_type::clock::now();
  std::vector<fs::path> stale;
  for (fs::recursive_directory_iterator it(directory, fs::directory_options::skip_permission_denied, ec), end;
       !ec && it != end; it.increment(ec)) {
    if (!it->is_regular_file(ec) || it->path().filename().string().find(".tmp") == std::string::npos) continue;
    const fs::file_time_type written = it->last_write_time(ec);
    if (!ec && now - written > age) stale.push_back(it->path());
  }
  for (const fs::path& p : stale)
    if (fs::remove(p, ec) && !ec) ++removed;
  return removed;
}

}  // namespace gis::geo::io
