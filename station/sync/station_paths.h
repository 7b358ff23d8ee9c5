#pragma once

#include <filesystem>
#include <string>

namespace ves::sync {

// Where a station keeps its offline state: the case cache and the outbox.
struct StationPaths {
  std::filesystem::path root;
  std::filesystem::path cases() const { return root / "cases"; }
  std::filesystem::path outbox_db() const { return root / "outbox.db"; }
  std::filesystem::path lessons() const { return root / "lessons"; }  // docs/lessons.md
  // Running sessions' inputs (sync/session_journal.h, docs/station-run.md).
  std::filesystem::path journal() const { return root / "journal"; }
};

// `--data-dir` when given, else $VES_STATION_DIR, else $HOME/.ves-station,
// else ./ves-station-data.
StationPaths ResolveStationPaths(const std::string& data_dir_option);

}  // namespace ves::sync
