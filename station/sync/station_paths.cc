#include "station/sync/station_paths.h"

#include <cstdlib>

namespace ves::sync {

StationPaths ResolveStationPaths(const std::string& data_dir_option) {
  if (!data_dir_option.empty()) return {data_dir_option};
  if (const char* env = std::getenv("VES_STATION_DIR"); env && *env) return {env};
  if (const char* home = std::getenv("HOME"); home && *home) {
    return {std::filesystem::path(home) / ".ves-station"};
  }
  return {"ves-station-data"};
}

}  // namespace ves::sync
