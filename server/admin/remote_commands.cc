// ves-admin subcommands against a running server: token, trainee, scores,
// session, audit, and `case upload|list|download` (docs/server.md).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <iostream>

#include "patient_db/case_format.h"
#include "patient_db/limits.h"
#include "server/admin/remote.h"
#include "server/auth.h"
#include "server/web_api.h"
#include "ves/v1/services.grpc.pb.h"

namespace ves::admin {

namespace po = boost::program_options;
using ves::server::ClientOptions;

void AddRemoteOptions(po::options_description* options, ClientOptions* client, int* deadline_s) {
  options->add_options()("help,h", "show this help")(
      "server", po::value(&client->address)->required(), "server address host:port")(
      "token", po::value(&client->token), "bearer token (default: $VES_TOKEN)")(
      "tls-ca", po::value(&client->tls_ca_file), "CA of the server certificate (PEM); "
                                                "without it only a loopback --server is allowed "
                                                "(plaintext)")(
      "tls-cert", po::value(&client->tls_cert_file), "client certificate (PEM)")(
      "tls-key", po::value(&client->tls_key_file), "client key (PEM)")(
      "deadline-s", po::value(deadline_s)->default_value(30), "deadline of each call, seconds");
}

int ParseRemote(const std::string& name, const std::string& usage, const CommandArgs& args,
                const po::options_description& options,
                const po::positional_options_description* positional, po::variables_map* vm,
                ClientOptions* client, int deadline_s) {
  try {
    auto parser = po::command_line_parser(args).options(options);
    if (positional) parser.positional(*positional);
    po::store(parser.run(), *vm);
    if (vm->count("help")) {
      std::cout << "usage: ves-admin " << usage << "\n" << options;
      return kExitOk;
    }
    po::notify(*vm);
  } catch (const po::error& e) {
    std::cerr << "ves-admin " << name << ": " << e.what() << "\n";
    return kExitUsage;
  }
  deadline_s = (*vm)["deadline-s"].as<int>();
  if (deadline_s < 1 || deadline_s > 3600) {
    std::cerr << "ves-admin " << name << ": --deadline-s " << deadline_s
              << ": must be in 1..3600\n";
    return kExitUsage;
  }
  client->deadline = std::chrono::seconds(deadline_s);
  if (client->token.empty()) {
    const char* env = std::getenv("VES_TOKEN");
    if (env) client->token = env;
  }
  if (client->token.empty()) {
    std::cerr << "ves-admin " << name << ": no token (give --token or set VES_TOKEN)\n";
    return kExitUsage;
  }
  try {
    ves::server::CheckClientOptions(*client);
  } catch (const std::invalid_argument& e) {
    std::cerr << "ves-admin " << name << ": " << e.what() << "\n";
    return kExitUsage;
  }
  return -1;
}

std::string Shown(const std::string& text) { return patient_db::PrintableExcerpt(text, 256); }

int ReportRpcError(const std::string& name, int code, const std::string& message) {
  static const char* const kNames[] = {
      "OK",        "CANCELLED",         "UNKNOWN",   "INVALID_ARGUMENT", "DEADLINE_EXCEEDED",
      "NOT_FOUND", "ALREADY_EXISTS",    "PERMISSION_DENIED", "RESOURCE_EXHAUSTED",
      "FAILED_PRECONDITION", "ABORTED", "OUT_OF_RANGE", "UNIMPLEMENTED", "INTERNAL",
      "UNAVAILABLE", "DATA_LOSS", "UNAUTHENTICATED"};
  std::string first_line = Shown(message.substr(0, message.find('\n')));
  std::cerr << "ves-admin " << name << ": " << (code >= 0 && code <= 16 ? kNames[code] : "ERROR")
            << ": " << first_line << "\n";
  return kExitFailed;
}

std::string FormatUtcMinute(int64_t unix_ms) {
  const std::time_t t = static_cast<std::time_t>(unix_ms / 1000);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M", &tm);
  return buf;
}

namespace {

// The station's names (`outcome=` of its summary line).
const char* OutcomeName(ves::v1::Outcome o) {
  switch (o) {
    case ves::v1::OUTCOME_CECUM_REACHED: return "cecum_reached";
    case ves::v1::OUTCOME_ABORTED: return "aborted";
    case ves::v1::OUTCOME_TIMED_OUT: return "timed_out";
    default: return "-";
  }
}

std::string FormatUtcSecond(int64_t unix_ms) {
  const std::time_t t = static_cast<std::time_t>(unix_ms / 1000);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[40];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S UTC", &tm);
  return buf;
}

std::string Fixed(double value, int digits) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*f", digits, value);
  return buf;
}

const char* EventKindName(ves::v1::EventKind kind) {
  switch (kind) {
    case ves::v1::EVENT_KIND_EXCESSIVE_FORCE: return "excessive force";
    case ves::v1::EVENT_KIND_PAIN: return "pain";
    case ves::v1::EVENT_KIND_LOOP: return "loop";
    case ves::v1::EVENT_KIND_DAMAGE: return "damage";
    case ves::v1::EVENT_KIND_REDOUT: return "red-out";
    case ves::v1::EVENT_KIND_VIEW_MODE: return "view mode";
    case ves::v1::EVENT_KIND_FLUOROSCOPY: return "fluoroscopy";
    case ves::v1::EVENT_KIND_CECUM_REACHED: return "cecum reached";
    case ves::v1::EVENT_KIND_REPEAT: return "repeat";
    default: return "other";
  }
}

// `ves-admin session show`: what a supervisor reads, not the whole record
// (no case centreline, no input log bytes; --raw has them).
void PrintSessionSummary(const ves::v1::SessionRecord& r, std::ostream& out) {
  const ves::v1::SessionMetrics& m = r.metrics();
  const auto line = [&out](const std::string& name, const std::string& value) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "  %-24s ", name.c_str());
    out << buf << value << "\n";
  };
  const std::string none = "-";
  out << "session " << r.uuid() << "\n";
  line("trainee", r.trainee_id());
  line("operator", r.operator_kind().empty() ? none : r.operator_kind());
  line("case", r.case_id() + " v" + std::to_string(r.case_version()) +
                   (r.case_sha256_hex().empty() ? "" : " sha256=" + r.case_sha256_hex().substr(0, 16) + "…"));
  line("scope", r.scope().title().empty() ? (r.scope().id().empty() ? none : r.scope().id())
                                           : r.scope().title());
  line("station", r.station_id().empty() ? none : r.station_id());
  line("lesson", r.lesson_id().empty() ? none : r.lesson_id());
  line("started", FormatUtcSecond(r.start_unix_ms()));
  line("ended", FormatUtcSecond(r.end_unix_ms()));
  line("outcome", OutcomeName(r.outcome()));
  line("score", Fixed(r.score(), 1) + " / 100");
  out << "metrics:\n";
  line("duration_s", Fixed(m.duration_s(), 1));
  line("time_to_cecum_s", m.completed() ? Fixed(m.time_to_cecum_s(), 1) : none);
  line("inserted_at_cecum_m", m.completed() ? Fixed(m.inserted_at_cecum_m(), 3) : none);
  line("deepest_tip_arc_m", Fixed(m.max_tip_arc_m(), 3));
  line("max_insertion_m", Fixed(m.max_insertion_m(), 3));
  line("peak_insertion_force_N", Fixed(m.peak_insertion_force_n(), 2));
  line("mean_insertion_force_N", Fixed(m.mean_insertion_force_n(), 2));
  line("excessive_force", std::to_string(m.excessive_force_episodes()) + " episodes, " +
                              Fixed(m.excessive_force_s(), 1) + " s");
  line("pain_s", Fixed(m.pain_s(), 1));
  line("peak_stretch_m", Fixed(m.peak_stretch_m(), 3));
  line("loop", std::to_string(m.loop_count()) + " loops, " + Fixed(m.loop_s(), 1) + " s");
  line("redout_s", Fixed(m.redout_s(), 1));
  line("mucosa_seen", Fixed(100.0 * m.mucosa_seen_fraction(), 0) + " %");
  line("xray_s", Fixed(m.xray_s(), 1));
  line("tip_path_m", Fixed(m.tip_path_m(), 2));
  line("damage", std::to_string(m.damage_events()) + " events, " +
                     Fixed(m.damage_impulse_n_s(), 2) + " N·s");
  line("abdominal_press", "left lower quadrant " + Fixed(m.press_llq_s(), 1) + " s, mid-abdomen " +
                              Fixed(m.press_mid_s(), 1) + " s");
  line("patient_position", std::to_string(m.position_changes()) + " changes, left lateral " +
                               Fixed(m.left_lateral_s(), 1) + " s, right lateral " +
                               Fixed(m.right_lateral_s(), 1) + " s");
  out << "events: " << r.events_size() << "\n";
  for (const auto& e : r.events()) {
    out << "  t=" << Fixed(e.t_s(), 1) << " s  " << EventKindName(e.kind());
    if (e.duration_s() > 0.0) out << "  for " << Fixed(e.duration_s(), 1) << " s";
    if (e.arc_m() > 0.0) out << "  at " << Fixed(e.arc_m(), 3) << " m";
    if (!e.detail().empty()) out << "  " << e.detail();
    out << "\n";
  }
  out << "input log: " << r.input_log().sample_count() << " samples at "
      << Fixed(r.input_log().dt_s() * 1e3, 1) << " ms, " << r.input_log().encoded().size()
      << " bytes; software " << (r.software_version().empty() ? none : r.software_version())
      << "\n";
}

template <typename Service>
auto Stub(const ClientOptions& client) {
  return Service::NewStub(ves::server::MakeClientChannel(client));
}

}  // namespace

int RunTokenCommand(const CommandArgs& args) {
  std::string action, role, institution, trainee, label;
  RemoteCommandLine line;
  line.Add()("action", po::value(&action)->required(), "create")(
      "role", po::value(&role)->required(), "admin, supervisor, station or trainee")(
      "institution", po::value(&institution), "institution (default: the caller's)")(
      "trainee", po::value(&trainee), "trainee id (role trainee)")("label", po::value(&label),
                                                                   "who or what holds the token");
  line.Positional("action", 1);
  if (const int rc =
          line.Parse("token", "token create --role R [--institution I] --server A", args);
      rc >= 0)
    return rc;
  const ClientOptions& client = line.client();
  if (action != "create") {
    std::cerr << "ves-admin token: unknown action '" << action << "' (only: create)\n";
    return kExitUsage;
  }
  ves::server::StoreRole store_role;
  if (!patient_db::ParseRoleName(role, &store_role)) {
    std::cerr << "ves-admin token: --role '" << role
              << "' is not admin, supervisor, station or trainee\n";
    return kExitUsage;
  }
  ves::v1::CreateTokenRequest q;
  q.set_role(static_cast<ves::v1::Role>(store_role));
  q.set_institution(institution);
  q.set_trainee_id(trainee);
  q.set_label(label);
  ves::v1::CreateTokenResponse r;
  if (const int called = CallOnce("token", client, *Stub<ves::v1::Admin>(client),
                                  &ves::v1::Admin::Stub::CreateToken, q, &r);
      called != kExitOk) {
    return called;
  }
  std::cout << r.token() << "\n";
  std::cerr << "token " << r.token_id() << " (" << role
            << "): shown once, the server keeps only its hash\n";
  return kExitOk;
}

int RunTraineeCommand(const CommandArgs& args) {
  std::string action, id, name, institution;
  RemoteCommandLine line;
  line.Add()("action", po::value(&action)->required(), "add or list")(
      "id", po::value(&id), "trainee id (add)")("name", po::value(&name), "display name (add)")(
      "institution", po::value(&institution), "institution (default: the caller's)");
  line.Positional("action", 1);
  if (const int rc = line.Parse("trainee", "trainee add --id ID [--name N] | list", args); rc >= 0)
    return rc;
  const ClientOptions& client = line.client();
  auto stub = Stub<ves::v1::Trainees>(client);
  if (action == "add") {
    if (id.empty()) {
      std::cerr << "ves-admin trainee add: --id is required\n";
      return kExitUsage;
    }
    ves::v1::AddTraineeRequest q;
    q.mutable_trainee()->set_trainee_id(id);
    q.mutable_trainee()->set_display_name(name);
    q.mutable_trainee()->set_institution(institution);
    ves::v1::AddTraineeResponse r;
    if (const int called =
            CallOnce("trainee", client, *stub, &ves::v1::Trainees::Stub::AddTrainee, q, &r);
        called != kExitOk) {
      return called;
    }
    std::cout << "added " << Shown(r.trainee().trainee_id()) << " ("
              << Shown(r.trainee().institution())
              << ")\n";
    return kExitOk;
  }
  if (action == "list") {
    ves::v1::ListTraineesRequest q;
    q.set_institution(institution);
    return ListAllPages("trainee", client, *stub, &ves::v1::Trainees::Stub::ListTrainees, q,
                        [](const ves::v1::ListTraineesResponse& r) {
                          for (const auto& t : r.trainees()) {
                            std::printf("%-24s %-20s %s\n", Shown(t.trainee_id()).c_str(),
                                        Shown(t.institution()).c_str(),
                                        Shown(t.display_name()).c_str());
                          }
                          return true;
                        });
  }
  std::cerr << "ves-admin trainee: unknown action '" << action << "' (add or list)\n";
  return kExitUsage;
}

int RunScoresCommand(const CommandArgs& args) {
  std::string trainee, case_id;
  RemoteCommandLine line;
  line.Add()("trainee", po::value(&trainee)->required(), "trainee id")("case", po::value(&case_id),
                                                                       "only this case");
  if (const int rc = line.Parse("scores", "scores --trainee ID [--case C]", args); rc >= 0)
    return rc;
  const ClientOptions& client = line.client();
  ves::v1::ListSessionsRequest q;
  q.set_trainee_id(trainee);
  q.set_case_id(case_id);
  q.set_page_size(1000);
  auto stub = Stub<ves::v1::Trainees>(client);
  bool header = false;
  return ListAllPages(
      "scores", client, *stub, &ves::v1::Trainees::Stub::ListSessions, q,
      [&](const ves::v1::ListSessionsResponse& r) {
        // One session a line, oldest first; `session show SESSION` reads one.
        if (!header) {
          std::printf("%-16s  %-36s  %-12s  %-8s  %-18s  %-13s  %9s  %8s  %8s  %7s\n",
                      "date (UTC)", "session", "trainee", "operator", "case", "outcome",
                      "depth (m)", "cecum (s)", "pain (s)", "score");
          header = true;
        }
        for (const auto& s : r.sessions()) {
          const std::string to_cecum = s.completed() ? Fixed(s.time_to_cecum_s(), 1) : "-";
          const std::string depth = s.max_tip_arc_m() > 0.0 ? Fixed(s.max_tip_arc_m(), 2) : "-";
          const std::string case_label =
              Shown(s.case_id()) + " v" + std::to_string(s.case_version());
          const std::string operator_kind =
              s.operator_kind().empty() ? "-" : Shown(s.operator_kind());
          std::printf("%-16s  %-36s  %-12s  %-8s  %-18s  %-13s  %9s  %8s  %8.1f  %7s\n",
                      FormatUtcMinute(s.start_unix_ms()).c_str(), Shown(s.uuid()).c_str(),
                      Shown(s.trainee_id()).c_str(), operator_kind.c_str(), case_label.c_str(),
                      OutcomeName(s.outcome()), depth.c_str(), to_cecum.c_str(), s.pain_s(),
                      (Fixed(s.score(), 1) + "/100").c_str());
        }
        return true;
      });
}

int RunSessionCommand(const CommandArgs& args) {
  std::string action, uuid;
  bool raw = false;
  RemoteCommandLine line;
  line.Add()("action", po::value(&action)->required(), "show")("uuid", po::value(&uuid)->required(),
                                                               "session uuid")(
      "raw", po::bool_switch(&raw), "the whole record (text format) instead of the summary");
  line.Positional("action", 1).Positional("uuid", 1);
  if (const int rc = line.Parse("session", "session show UUID [--raw]", args); rc >= 0) return rc;
  const ClientOptions& client = line.client();
  if (action != "show") {
    std::cerr << "ves-admin session: unknown action '" << action << "' (only: show)\n";
    return kExitUsage;
  }
  ves::v1::GetSessionRequest q;
  q.set_uuid(uuid);
  ves::v1::GetSessionResponse r;
  if (const int called = CallOnce("session", client, *Stub<ves::v1::Trainees>(client),
                                  &ves::v1::Trainees::Stub::GetSession, q, &r);
      called != kExitOk) {
    return called;
  }
  if (!raw) {
    PrintSessionSummary(r.record(), std::cout);
    return kExitOk;
  }
  // The whole record except the input log's bytes (binary, only a replay
  // reads them).
  ves::v1::SessionRecord shown = r.record();
  const size_t log_bytes = shown.input_log().encoded().size();
  shown.mutable_input_log()->clear_encoded();
  std::cout << shown.DebugString() << "# input_log.encoded: " << log_bytes << " bytes\n";
  return kExitOk;
}

int RunAuditCommand(const CommandArgs& args) {
  int64_t since_unix_ms = 0;
  unsigned limit = 1000;
  RemoteCommandLine line;
  line.Add()("since", po::value(&since_unix_ms), "Unix time in ms (default: all)")(
      "limit", po::value(&limit), "most entries shown (default 1000)");
  if (const int rc = line.Parse("audit", "audit [--since UNIX_MS] [--limit N]", args); rc >= 0)
    return rc;
  const ClientOptions& client = line.client();
  ves::v1::ListAuditRequest q;
  q.set_since_unix_ms(since_unix_ms);
  q.set_limit(std::min(limit, 1000u));  // a page; --limit bounds the total shown
  auto stub = Stub<ves::v1::Admin>(client);
  unsigned shown = 0;
  return ListAllPages(
      "audit", client, *stub, &ves::v1::Admin::Stub::ListAudit, q,
      [&](const ves::v1::ListAuditResponse& r) {
        for (const auto& e : r.entries()) {
          if (shown == limit) return false;
          ++shown;
          std::printf("%s  %-12s %-10s %-12s %-18s %-40s %s\n",
                      FormatUtcMinute(e.at_unix_ms()).c_str(), Shown(e.actor()).c_str(),
                      ves::v1::Role_Name(e.role()).c_str() + 5, Shown(e.institution()).c_str(),
                      Shown(e.action()).c_str(), Shown(e.target()).c_str(),
                      Shown(e.result()).c_str());
        }
        return shown < limit;
      });
}

int RunStationsCommand(const CommandArgs& args) {
  std::string institution;
  RemoteCommandLine line;
  line.Add()("institution", po::value(&institution), "institution (default: the token's)");
  if (const int rc = line.Parse("stations", "stations [--institution I]", args); rc >= 0) return rc;
  const ClientOptions& client = line.client();
  ves::v1::ListStationsRequest q;
  q.set_institution(institution);
  q.set_page_size(1000);
  auto stub = Stub<ves::v1::Admin>(client);
  std::printf("%-24s %-17s %-12s %-10s %-14s %-10s %-12s %-10s %s\n", "station", "last seen UTC",
              "version", "device", "p99/budget us", "overruns", "safe-state", "CAN errors",
              "flags");
  return ListAllPages(
      "stations", client, *stub, &ves::v1::Admin::Stub::ListStations, q,
      [&](const ves::v1::ListStationsResponse& r) {
        for (const auto& st : r.stations()) {
          std::string device = "-", loop = "-", overruns = "-", safe = "-", can = "-", flags;
          if (st.has_health()) {
            const ves::v1::StationHealth& h = st.health();
            char text[64];
            device = h.device();
            if (h.loop_cycles() > 0) {
              std::snprintf(text, sizeof text, "%.0f/%.0f", h.loop_cycle_p99_us(),
                            h.loop_budget_us());
              loop = text;
              overruns = std::to_string(h.loop_overruns());
            } else {
              loop = "not timed";
            }
            safe = std::to_string(h.hard_faults() + h.transient_faults());
            can = std::to_string(h.can_bus_errors() + h.can_lost_frames() + h.can_send_failures() +
                                 h.can_malformed_frames());
            for (const std::string& f : ves::server::StationHealthFlags(h)) {
              flags += (flags.empty() ? "" : ",") + f;
            }
          }
          std::printf("%-24s %-17s %-12s %-10s %-14s %-10s %-12s %-10s %s\n",
                      Shown(st.station_id()).c_str(),
                      FormatUtcMinute(st.last_seen_unix_ms()).c_str(),
                      Shown(st.software_version().empty() ? "-" : st.software_version()).c_str(),
                      Shown(device).c_str(), loop.c_str(), overruns.c_str(), safe.c_str(),
                      can.c_str(), flags.empty() ? "-" : flags.c_str());
        }
        return true;
      });
}

}  // namespace ves::admin
