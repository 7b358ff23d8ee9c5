#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "ves/v1/lesson.pb.h"
#include "ves/v1/services.pb.h"

namespace ves::sync {

// A lesson session the station uploaded (or will) whose server verdict it
// has not seen yet.
struct AwaitedVerdict {
  std::string session_uuid;
  std::string lesson_id;
};

// The station's offline lesson state (docs/lessons.md), in <data-dir>/lessons:
//   next/<hex trainee id>.pb  the server's last answer to GetNextLesson
//   awaiting/<uuid>           a lesson session whose verdict is still to fetch
//   verdicts/<uuid>.pb        the server's verdict once fetched
// Files are written to a temporary name, fsynced and renamed, so a station
// killed mid-write keeps the previous state.
class LessonCache {
 public:
  explicit LessonCache(std::filesystem::path dir);

  void PutNext(const std::string& trainee_id, const ves::v1::GetNextLessonResponse& next);
  // The cached answer, or nullopt (never fetched, or unreadable).
  std::optional<ves::v1::GetNextLessonResponse> FindNext(const std::string& trainee_id) const;

  void AddAwaited(const AwaitedVerdict& awaited);
  std::vector<AwaitedVerdict> Awaited() const;
  // Stores the verdict and stops awaiting it.
  void PutVerdict(const ves::v1::LessonVerdict& verdict);
  std::optional<ves::v1::LessonVerdict> FindVerdict(const std::string& session_uuid) const;
  // Every stored verdict, oldest judgement first; unreadable files are named
  // in `damaged` (when given) and skipped.
  std::vector<ves::v1::LessonVerdict> Verdicts(std::vector<std::string>* damaged = nullptr) const;

  const std::filesystem::path& dir() const { return dir_; }

 private:
  std::filesystem::path dir_;
};

}  // namespace ves::sync
