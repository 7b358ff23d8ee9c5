#include "station/app/session_commit.h"

#include <csignal>
#include <cstdlib>
#include <iostream>

#include "station/app/run_sync.h"
#include "station/sync/outbox.h"

namespace ves::station {
namespace {

constexpr const char* kName = kRunName;
constexpr char kKillAfterCommitEnv[] = "VES_STATION_KILL_AFTER_COMMIT";

}  // namespace

void KillAfterCommitIfAsked() {
  if (std::getenv(kKillAfterCommitEnv) != nullptr) std::raise(SIGKILL);
}

bool DeliverCommitted(const RunOptions& o, const sync::StationPaths& paths,
                      const std::vector<std::string>& uuids) {
  if (!o.server) {
    std::cout << "no --server: the session waits in the outbox (ves-station sync delivers it)\n";
    return true;
  }
  try {
    sync::Outbox outbox(paths.outbox_db());
    const DeliveryReport report = DeliverOutbox(*o.server, outbox, o.upload_attempts);
    std::cout << "uploaded " << report.acknowledged << " session(s) to " << o.server->address;
    if (report.rejected > 0) std::cout << ", " << report.rejected << " refused by the server";
    std::cout << "; " << report.still_pending << " pending\n";
    for (const auto& pending : outbox.Pending()) {
      for (const auto& uuid : uuids) {
        if (pending.uuid != uuid) continue;
        std::cout << "server unreachable (" << report.last_error << "): session " << uuid
                  << " stays in the outbox; `ves-station status` lists it, `ves-station sync` "
                     "or a later run delivers it\n";
      }
    }
    if (report.rejected > 0) {
      std::cerr << kName << ": the server refused a session: " << report.last_error << "\n";
    }
    return true;
  } catch (const std::exception& error) {
    std::cerr << kName << ": cannot open the outbox to deliver it: " << error.what() << "\n";
    return false;
  }
}

bool CommitRecord(const sync::StationPaths& paths, const ves::v1::SessionRecord& record) {
  try {
    sync::Outbox outbox(paths.outbox_db());
    outbox.Commit(record);
    std::cout << "session " << record.uuid() << " committed to the outbox\n" << std::flush;
    return true;
  } catch (const std::exception& error) {
    std::cerr << kName << ": cannot commit session " << record.uuid()
              << " to the outbox: " << error.what() << "\n";
    return false;
  }
}

bool CommitAndDeliver(const RunOptions& o, const sync::StationPaths& paths,
                      const std::vector<ves::v1::SessionRecord>& records) {
  std::vector<std::string> uuids;
  for (const auto& record : records) {
    if (!CommitRecord(paths, record)) return false;
    uuids.push_back(record.uuid());
  }
  KillAfterCommitIfAsked();
  return DeliverCommitted(o, paths, uuids);
}

}  // namespace ves::station
