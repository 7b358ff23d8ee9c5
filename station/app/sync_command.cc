// ves-station sync: recovers interrupted sessions from the journal, queues
// session files (--add), then drains the outbox to the server in bounded
// passes and collects the verdicts of lesson sessions (docs/station-run.md).
#include <boost/program_options.hpp>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "station/app/command_line.h"
#include "station/app/commands.h"
#include "station/app/journal_recovery.h"
#include "station/app/run_lesson.h"
#include "station/app/run_options.h"
#include "station/app/run_sync.h"
#include "station/sync/lesson_cache.h"
#include "station/sync/outbox.h"
#include "station/sync/station_paths.h"
#include "station/training/session_file.h"

namespace ves::station {
namespace {

namespace po = boost::program_options;

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace

int RunSyncCommand(const CommandArgs& args) {
  po::options_description desc("options");
  desc.add_options()("help,h", "show this help")(
      "server", po::value<std::string>(), "server address host:port")(
      "token", po::value<std::string>(), "station bearer token")(
      "tls-ca", po::value<std::string>(), "CA of the server certificate (PEM)")(
      "data-dir", po::value<std::string>()->default_value(""),
      "station data folder (default $VES_STATION_DIR or ~/.ves-station)")(
      "attempts", po::value<int>()->default_value(3), "passes (with backoff) before giving up")(
      "verdict-wait-s", po::value<double>()->default_value(30.0),
      "how long to wait for the server's verdicts on uploaded lesson sessions")(
      "add", po::value<std::vector<std::string>>()->composing(),
      "queue this session file (e.g. from `sim --session-out`) in the outbox first; "
      "repeatable. Without --server: only queue");
  sync::ServerEndpoint endpoint;
  std::string data_dir;
  int attempts = 3;
  double verdict_wait_s = 30.0;
  po::variables_map vm;
  if (auto stop = ParseCommandLine(
          "ves-station sync",
          "usage: ves-station sync --server ADDR --token T [--tls-ca FILE] [--data-dir DIR]\n"
          "                        [--add FILE.session]...\n"
          "   or: ves-station sync --add FILE.session... [--data-dir DIR]   (queue only)\n\n"
          "Uploads the outbox's pending sessions. --add first queues session files (as\n"
          "`sim --operator ... --session-out` writes them) like a finished run. Exit status 0\n"
          "when none is left pending (or, queue only, when all were queued), 1 when some are\n"
          "(server unreachable), 2 for a bad file.",
          args, desc, &vm)) {
    return *stop;
  }
  std::vector<std::string> to_add;
  if (vm.count("add")) to_add = vm["add"].as<std::vector<std::string>>();
  const bool queue_only = !to_add.empty() && !vm.count("server") && !vm.count("token");
  try {
    if (!queue_only && (!vm.count("server") || !vm.count("token"))) {
      throw UsageError("--server ADDR and --token T are required (or only --add FILE to queue)");
    }
    if (!queue_only) {
      endpoint.address = vm["server"].as<std::string>();
      endpoint.token = vm["token"].as<std::string>();
      if (vm.count("tls-ca")) endpoint.tls_ca_file = vm["tls-ca"].as<std::string>();
    }
    data_dir = vm["data-dir"].as<std::string>();
    attempts = vm["attempts"].as<int>();
    verdict_wait_s = vm["verdict-wait-s"].as<double>();
    if (attempts < 1 || attempts > 20) {
      throw UsageError("--attempts " + std::to_string(attempts) + " must be in [1, 20]");
    }
    // Queuing only talks to no server: there is no endpoint to check.
    if (!queue_only) sync::CheckEndpoint(endpoint);
  } catch (const std::exception& e) {
    std::cerr << "ves-station sync: " << e.what() << "\n";
    return kExitUsage;
  }
  // A session an interrupted run left in the journal goes to the outbox
  // first, so that this sync delivers it too.
  RecoverInterruptedSessions(sync::ResolveStationPaths(data_dir));
  // Session files to queue: each read whole and checked (a truncated or
  // damaged file, a record without trainee) before any is committed.
  std::vector<ves::v1::SessionRecord> added;
  for (const std::string& file : to_add) {
    try {
      std::ifstream in(file, std::ios::binary);
      if (!in) throw std::runtime_error("cannot read it");
      std::ostringstream bytes;
      bytes << in.rdbuf();
      ves::v1::SessionRecord record = training::DecodeSessionFile(bytes.str());
      if (record.trainee_id().empty()) {
        throw std::runtime_error("the session names no trainee (write it with `sim ... --trainee ID`)");
      }
      added.push_back(std::move(record));
    } catch (const std::exception& error) {
      std::cerr << "ves-station sync: --add " << file << ": " << error.what() << "\n";
      return kExitUsage;
    }
  }
  try {
    sync::Outbox outbox(sync::ResolveStationPaths(data_dir).outbox_db());
    for (const auto& record : added) {
      outbox.Commit(record);
      std::cout << "session " << record.uuid() << " (trainee " << record.trainee_id() << ", case "
                << record.case_id() << ") queued in the outbox\n";
    }
    if (queue_only) {
      std::cout << outbox.PendingCount() << " pending; `ves-station sync --server ADDR --token T` "
                   "uploads them\n";
      return kExitOk;
    }
    const DeliveryReport report = DeliverOutbox(endpoint, outbox, attempts);
    std::cout << "uploaded " << report.acknowledged << " session(s), " << report.rejected
              << " refused, " << report.still_pending << " pending\n";
    // Lesson sessions uploaded now or earlier: their server verdicts arrive here.
    sync::LessonCache lessons(sync::ResolveStationPaths(data_dir).lessons());
    if (!lessons.Awaited().empty()) {
      CollectServerVerdicts(endpoint, lessons, "*", verdict_wait_s, std::cout);
    }
    if (report.still_pending > 0) {
      std::cerr << "ves-station sync: still pending: " << report.last_error << "\n";
      return kExitFailed;
    }
    return kExitOk;
  } catch (const std::exception& error) {
    std::cerr << "ves-station sync: " << error.what() << "\n";
    return kExitFailed;
  }
}

}  // namespace ves::station
