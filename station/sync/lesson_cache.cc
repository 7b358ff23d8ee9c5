#include "station/sync/lesson_cache.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace ves::sync {
namespace {

namespace fs = std::filesystem;

std::string HexOf(const std::string& text) {
  static const char kHex[] = "0123456789abcdef";
  std::string out;
  for (unsigned char c : text) {
    out += kHex[c >> 4];
    out += kHex[c & 0xf];
  }
  return out;
}

// A session UUID is lower-case hex and dashes; anything else never names a file.
bool IsSafeName(const std::string& name) {
  if (name.empty() || name.size() > 64) return false;
  for (char c : name) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || c == '-')) return false;
  }
  return true;
}

void WriteDurably(const fs::path& path, const std::string& bytes) {
  fs::create_directories(path.parent_path());
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << bytes;
    if (!out.flush()) throw std::runtime_error("cannot write '" + tmp.string() + "'");
  }
  const int fd = ::open(tmp.c_str(), O_RDONLY);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
  fs::rename(tmp, path);
}

std::optional<std::string> ReadBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

}  // namespace

LessonCache::LessonCache(std::filesystem::path dir) : dir_(std::move(dir)) {}

void LessonCache::PutNext(const std::string& trainee_id,
                          const ves::v1::GetNextLessonResponse& next) {
  WriteDurably(dir_ / "next" / (HexOf(trainee_id) + ".pb"), next.SerializeAsString());
}

std::optional<ves::v1::GetNextLessonResponse> LessonCache::FindNext(
    const std::string& trainee_id) const {
  auto bytes = ReadBytes(dir_ / "next" / (HexOf(trainee_id) + ".pb"));
  ves::v1::GetNextLessonResponse next;
  if (!bytes || !next.ParseFromString(*bytes)) return std::nullopt;
  return next;
}

void LessonCache::AddAwaited(const AwaitedVerdict& awaited) {
  if (!IsSafeName(awaited.session_uuid)) {
    throw std::invalid_argument("session uuid '" + awaited.session_uuid + "' is not a UUID");
  }
  WriteDurably(dir_ / "awaiting" / awaited.session_uuid, awaited.lesson_id);
}

std::vector<AwaitedVerdict> LessonCache::Awaited() const {
  std::vector<AwaitedVerdict> out;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir_ / "awaiting", ec)) {
    const std::string name = entry.path().filename().string();
    if (!IsSafeName(name)) continue;  // *.tmp of an interrupted write
    out.push_back({name, ReadBytes(entry.path()).value_or("")});
  }
  std::sort(out.begin(), out.end(),
            [](const auto& a, const auto& b) { return a.session_uuid < b.session_uuid; });
  return out;
}

void LessonCache::PutVerdict(const ves::v1::LessonVerdict& verdict) {
  if (!IsSafeName(verdict.session_uuid())) {
    throw std::invalid_argument("session uuid '" + verdict.session_uuid() + "' is not a UUID");
  }
  WriteDurably(dir_ / "verdicts" / (verdict.session_uuid() + ".pb"), verdict.SerializeAsString());
  std::error_code ec;
  fs::remove(dir_ / "awaiting" / verdict.session_uuid(), ec);
}

std::optional<ves::v1::LessonVerdict> LessonCache::FindVerdict(
    const std::string& session_uuid) const {
  if (!IsSafeName(session_uuid)) return std::nullopt;
  auto bytes = ReadBytes(dir_ / "verdicts" / (session_uuid + ".pb"));
  ves::v1::LessonVerdict verdict;
  if (!bytes || !verdict.ParseFromString(*bytes)) return std::nullopt;
  return verdict;
}

std::vector<ves::v1::LessonVerdict> LessonCache::Verdicts(std::vector<std::string>* damaged) const {
  std::vector<ves::v1::LessonVerdict> out;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir_ / "verdicts", ec)) {
    if (entry.path().extension() != ".pb") continue;  // *.tmp of an interrupted write
    auto bytes = ReadBytes(entry.path());
    ves::v1::LessonVerdict verdict;
    if (!bytes || !verdict.ParseFromString(*bytes) || verdict.session_uuid().empty()) {
      if (damaged) damaged->push_back(entry.path().string() + ": not a lesson verdict");
      continue;
    }
    out.push_back(std::move(verdict));
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return std::make_pair(a.judged_unix_ms(), a.session_uuid()) <
           std::make_pair(b.judged_unix_ms(), b.session_uuid());
  });
  return out;
}

}  // namespace ves::sync
