#include "station/sync/session_journal.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <optional>

namespace ves::sync {
namespace {

constexpr std::string_view kMagic = "VES-JOURNAL-1\n";

std::string ErrnoText() { return std::strerror(errno); }

void PutU32(std::uint32_t v, char* out) {
  for (int i = 0; i < 4; ++i) out[i] = static_cast<char>((v >> (8 * i)) & 0xffu);
}
std::uint32_t GetU32(const char* in) {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i)
    v |= static_cast<std::uint32_t>(static_cast<unsigned char>(in[i])) << (8 * i);
  return v;
}
std::uint32_t Crc32(std::string_view bytes) {
  return static_cast<std::uint32_t>(::crc32(::crc32(0L, Z_NULL, 0),
                                            reinterpret_cast<const Bytef*>(bytes.data()),
                                            static_cast<uInt>(bytes.size())));
}

void WriteAll(int fd, std::string_view bytes, const std::filesystem::path& path) {
  while (!bytes.empty()) {
    const ssize_t n = ::write(fd, bytes.data(), bytes.size());
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      throw std::runtime_error("journal '" + path.string() + "': write failed: " + ErrnoText());
    }
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
}

}  // namespace

std::filesystem::path JournalPath(const std::filesystem::path& dir, const std::string& uuid) {
  return dir / (uuid + ".journal");
}

SessionJournalWriter::SessionJournalWriter(const std::filesystem::path& dir,
                                           const ves::v1::SessionRecord& header)
    : path_(JournalPath(dir, header.uuid())) {
  if (header.uuid().empty() || header.uuid().find('/') != std::string::npos) {
    throw std::runtime_error("journal: the session has no usable UUID ('" + header.uuid() + "')");
  }
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) {
    throw std::runtime_error("journal: cannot create '" + dir.string() + "': " + error.message());
  }
  if (std::filesystem::exists(path_, error)) {
    throw std::runtime_error("journal '" + path_.string() + "': already exists");
  }
  // Written and locked under a temporary name, then renamed: a journal that
  // ListJournals sees is whole from its header on, and locked while its
  // writer lives (JournalInUse).
  const std::filesystem::path part = path_.string() + ".part";
  fd_ = ::open(part.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_APPEND | O_CLOEXEC, 0600);
  if (fd_ < 0) {
    throw std::runtime_error("journal '" + part.string() + "': cannot create: " + ErrnoText());
  }
  try {
    if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      throw std::runtime_error("journal '" + part.string() + "': cannot lock: " + ErrnoText());
    }
    WriteAll(fd_, kMagic, part);
    WriteFrame(header.SerializeAsString());
    Sync();
    if (::rename(part.c_str(), path_.c_str()) != 0) {
      throw std::runtime_error("journal '" + path_.string() + "': cannot rename: " + ErrnoText());
    }
    // The file's folder entry too, so that the journal survives a power cut.
    const int dir_fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dir_fd >= 0) {
      ::fsync(dir_fd);
      ::close(dir_fd);
    }
  } catch (...) {
    ::close(fd_);
    fd_ = -1;
    std::filesystem::remove(part, error);
    throw;
  }
}

SessionJournalWriter::~SessionJournalWriter() {
  if (fd_ < 0) return;
  if (unsynced_) ::fdatasync(fd_);
  ::close(fd_);
}

void SessionJournalWriter::WriteFrame(std::string_view payload) {
  if (payload.size() > kMaxJournalFrameBytes) {
    throw std::runtime_error("journal '" + path_.string() + "': a chunk of " +
                             std::to_string(payload.size()) + " bytes is over the limit");
  }
  WriteAll(fd_, EncodeJournalFrame(payload), path_);  // one write per frame
  unsynced_ = true;
}

void SessionJournalWriter::Append(std::string_view chunk) {
  WriteFrame(chunk);
  if (std::chrono::steady_clock::now() - last_sync_ >= kSyncInterval) Sync();
}

void SessionJournalWriter::Sync() {
  if (::fdatasync(fd_) != 0) {
    throw std::runtime_error("journal '" + path_.string() + "': fdatasync failed: " + ErrnoText());
  }
  last_sync_ = std::chrono::steady_clock::now();
  unsynced_ = false;
}

std::string EncodeJournalFrame(std::string_view payload) {
  std::string frame(8, '\0');
  PutU32(static_cast<std::uint32_t>(payload.size()), frame.data());
  PutU32(Crc32(payload), frame.data() + 4);
  frame.append(payload);
  return frame;
}

std::string EncodeSessionJournal(const ves::v1::SessionRecord& header,
                                 const std::vector<std::string>& chunks) {
  std::string bytes(kMagic);
  bytes += EncodeJournalFrame(header.SerializeAsString());
  for (const std::string& chunk : chunks) bytes += EncodeJournalFrame(chunk);
  return bytes;
}

JournalContents ParseSessionJournal(std::string_view bytes, const std::string& name) {
  if (bytes.substr(0, kMagic.size()) != kMagic) {
    throw JournalError("journal '" + name + "': not a session journal (bad magic)");
  }
  std::size_t at = kMagic.size();
  // The next whole frame's payload, or nothing (end of file, or a torn or
  // damaged frame: *torn set).
  const auto next_frame = [&](bool* torn) -> std::optional<std::string_view> {
    if (at == bytes.size()) return std::nullopt;
    if (bytes.size() - at < 8) {
      *torn = true;
      return std::nullopt;
    }
    const std::uint32_t length = GetU32(bytes.data() + at);
    const std::uint32_t crc = GetU32(bytes.data() + at + 4);
    if (length > kMaxJournalFrameBytes || bytes.size() - at - 8 < length) {
      *torn = true;
      return std::nullopt;
    }
    const std::string_view payload = bytes.substr(at + 8, length);
    if (Crc32(payload) != crc) {
      *torn = true;
      return std::nullopt;
    }
    at += 8 + length;
    return payload;
  };
  JournalContents contents;
  bool torn = false;
  const std::optional<std::string_view> header = next_frame(&torn);
  if (!header ||
      !contents.header.ParseFromArray(header->data(), static_cast<int>(header->size()))) {
    throw JournalError("journal '" + name + "': its header is missing or damaged");
  }
  while (const std::optional<std::string_view> chunk = next_frame(&torn)) {
    contents.chunks.emplace_back(*chunk);
  }
  contents.torn_tail = torn;
  return contents;
}

JournalContents ReadSessionJournal(const std::filesystem::path& path) {
  std::error_code error;
  const std::uintmax_t size = std::filesystem::file_size(path, error);
  if (error)
    throw JournalError("journal '" + path.string() + "': cannot open it: " + error.message());
  if (size > kMaxJournalBytes) {
    throw JournalError("journal '" + path.string() + "': " + std::to_string(size) +
                       " bytes, more than any session writes (" + std::to_string(kMaxJournalBytes) +
                       ")");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw JournalError("journal '" + path.string() + "': cannot open it");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  JournalContents contents = ParseSessionJournal(bytes, path.string());
  if (JournalPath(path.parent_path(), contents.header.uuid()) != path) {
    throw JournalError("journal '" + path.string() + "': its header names session '" +
                       contents.header.uuid() + "'");
  }
  return contents;
}

bool JournalInUse(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool locked = ::flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);  // releases a lock it took
  return locked;
}

int RemoveStaleJournalParts(const std::filesystem::path& dir) {
  int removed = 0;
  std::error_code error;
  for (std::filesystem::directory_iterator it(dir, error), end; !error && it != end;
       it.increment(error)) {
    const std::string name = it->path().filename().string();
    const bool part = name.ends_with(".journal.part");
    if (!part || !it->is_regular_file() || JournalInUse(it->path())) continue;
    std::error_code ignored;
    if (std::filesystem::remove(it->path(), ignored)) ++removed;
  }
  return removed;
}

std::vector<std::filesystem::path> ListJournals(const std::filesystem::path& dir) {
  std::vector<std::filesystem::path> found;
  std::error_code error;
  for (std::filesystem::directory_iterator it(dir, error), end; !error && it != end;
       it.increment(error)) {
    if (it->path().extension() == ".journal" && it->is_regular_file()) found.push_back(it->path());
  }
  std::sort(found.begin(), found.end());
  return found;
}

}  // namespace ves::sync
