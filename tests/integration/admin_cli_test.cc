// ves-admin run as a process against an in-process server: init, the remote
// subcommands, and errors as one line with a non-zero exit status.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <thread>

#include "patient_db/case_bundle.h"
#include "patient_db/case_format.h"
#include "tests/integration/plaintext_probe.h"
#include "tests/integration/test_server.h"

namespace ves::server::testing {
namespace {

using patient_db::StoreRole;

struct AdminRun {
  int exit_status = -1;
  std::string out;
  std::string err;
};

AdminRun Admin(const std::filesystem::path& dir, const std::string& args) {
  const auto err_path = dir / "stderr.txt";
  const std::string command =
      std::string(VES_ADMIN_PATH) + " " + args + " 2>'" + err_path.string() + "'";
  AdminRun run;
  FILE* pipe = ::popen(command.c_str(), "r");
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, pipe)) > 0) run.out.append(buf, n);
  const int status = ::pclose(pipe);
  run.exit_status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream err(err_path);
  std::stringstream text;
  text << err.rdbuf();
  run.err = text.str();
  return run;
}

int Lines(const std::string& s) { return static_cast<int>(std::count(s.begin(), s.end(), '\n')); }

TEST(AdminCli, InitPrintsTheFirstAdminTokenOnce) {
  const auto dir = MakeTempDir("admin_init");
  const std::string db = "sqlite:" + (dir / "ves.db").string();
  AdminRun first = Admin(dir, "init --db " + db + " --institution north");
  ASSERT_EQ(first.exit_status, 0) << first.err;
  ASSERT_EQ(first.out.size(), 65u);  // 64 hex digits and a newline
  auto store = patient_db::OpenStore(db);
  auto token = store->FindToken(Sha256Hex(first.out.substr(0, 64)));
  ASSERT_TRUE(token.ok());
  EXPECT_EQ(token.value.role, StoreRole::kAdmin);
  AdminRun second = Admin(dir, "init --db " + db + " --institution north");
  EXPECT_EQ(second.exit_status, 1);
  EXPECT_EQ(second.out, "");
  EXPECT_EQ(Lines(second.err), 1) << second.err;
  std::filesystem::remove_all(dir);
}

TEST(AdminCli, RemoteCommandsWorkAgainstAServer) {
  TestServer server;
  const auto& dir = server.dir();
  const std::string remote =
      " --server " + server.address() + " --token " + server.MakeToken(StoreRole::kAdmin, "north");
  ASSERT_EQ(Admin(dir, "trainee add --id alice --name Alice" + remote).exit_status, 0);
  AdminRun list = Admin(dir, "trainee list" + remote);
  EXPECT_NE(list.out.find("alice"), std::string::npos);

  const std::string case_file = std::string(VES_SOURCE_DIR) +
                                "/patient_db/cases/standard-adult.textproto";
  AdminRun up = Admin(dir, "case upload " + case_file + remote);
  ASSERT_EQ(up.exit_status, 0) << up.err;
  // Upload and list name the case by the hash `case validate` and the
  // station print (the payload's), not by the bundle's content address.
  const std::string payload_sha =
      patient_db::CasePayloadSha256Hex(patient_db::LoadCaseFile(case_file));
  EXPECT_NE(up.out.find("standard-adult v1 sha256=" + payload_sha), std::string::npos) << up.out;
  AdminRun cases = Admin(dir, "case list" + remote);
  EXPECT_NE(cases.out.find("standard-adult"), std::string::npos);
  EXPECT_NE(cases.out.find(payload_sha.substr(0, 12)), std::string::npos) << cases.out;
  const auto out = dir / "copy.vescase";
  AdminRun down = Admin(dir, "case download standard-adult -o " + out.string() + remote);
  ASSERT_EQ(down.exit_status, 0) << down.err;
  EXPECT_EQ(patient_db::ReadFileBytes(out),
            patient_db::EncodeCaseBundle(patient_db::LoadCaseFile(case_file)));

  std::mt19937_64 rng(3);
  const std::string uuid = NewUuid(rng);
  ves::v1::UploadSessionResponse r;
  ves::v1::SessionRecord record = MakeRecord(uuid, "alice", 7);
  record.mutable_metrics()->set_max_tip_arc_m(1.23456);
  record.mutable_metrics()->set_press_llq_s(12.34);
  record.mutable_metrics()->set_position_changes(2);
  record.mutable_metrics()->set_left_lateral_s(40.0);
  *record.mutable_replay_setup()->mutable_colon_case() = SampleCase();
  record.mutable_replay_setup()->set_time_limit_s(record.metrics().duration_s() + 60.0);
  const grpc::Status uploaded =
      UploadSession(server.Client(server.MakeToken(StoreRole::kStation, "north")), record, &r);
  ASSERT_TRUE(uploaded.ok()) << uploaded.error_message();
  AdminRun scores = Admin(dir, "scores --trainee alice" + remote);
  ASSERT_EQ(scores.exit_status, 0) << scores.err;
  EXPECT_EQ(Lines(scores.out), 2);  // header and one session
  // A line names the session (for `session show`), trainee, operator, case,
  // outcome, depth, time to the cecum and the score on its scale.
  const std::string row = scores.out.substr(scores.out.find('\n') + 1);
  for (const std::string& cell : {uuid, std::string("alice"), std::string("human"),
                                  std::string("standard-adult v1"), std::string("cecum_reached"),
                                  std::string("1.23"), std::string("207.0"),
                                  std::string("57.0/100")}) {
    EXPECT_NE(row.find(cell), std::string::npos) << cell << " missing in\n" << scores.out;
  }
  EXPECT_NE(scores.out.find("depth (m)"), std::string::npos) << scores.out;
  // session show: a summary people read (metrics, times in UTC, no case
  // centreline, no input log bytes); --raw: the record itself.
  AdminRun show = Admin(dir, "session show " + uuid + remote);
  ASSERT_EQ(show.exit_status, 0) << show.err;
  EXPECT_NE(show.out.find("session " + uuid), std::string::npos) << show.out;
  EXPECT_NE(show.out.find("2023-11-14 22:20:20 UTC"), std::string::npos) << show.out;
  EXPECT_NE(show.out.find("time_to_cecum_s          207.0"), std::string::npos) << show.out;
  EXPECT_NE(show.out.find("deepest_tip_arc_m        1.235"), std::string::npos) << show.out;
  EXPECT_NE(show.out.find("57.0 / 100"), std::string::npos) << show.out;
  // The loop-control toolkit's use, for the supervisor.
  EXPECT_NE(show.out.find("abdominal_press          left lower quadrant 12.3 s, mid-abdomen 0.0 s"),
            std::string::npos)
      << show.out;
  EXPECT_NE(show.out.find("patient_position         2 changes, left lateral 40.0 s, right lateral "
                          "0.0 s"),
            std::string::npos)
      << show.out;
  EXPECT_EQ(show.out.find("centerline"), std::string::npos) << show.out;
  EXPECT_LT(Lines(show.out), 60) << show.out;
  AdminRun raw = Admin(dir, "session show " + uuid + " --raw" + remote);
  ASSERT_EQ(raw.exit_status, 0) << raw.err;
  EXPECT_NE(raw.out.find("centerline"), std::string::npos);
  EXPECT_NE(raw.out.find("uuid: \"" + uuid + "\""), std::string::npos);
  // stations: the upload's station, seen, with no health reported; then one
  // whose health is out of range, flagged.
  AdminRun stations = Admin(dir, "stations" + remote);
  ASSERT_EQ(stations.exit_status, 0) << stations.err;
  EXPECT_EQ(Lines(stations.out), 2) << stations.out;
  EXPECT_NE(stations.out.find("station-1"), std::string::npos) << stations.out;
  ves::v1::SessionRecord faulty = MakeRecord(NewUuid(rng), "alice", 8);
  faulty.set_station_id("ward-3");
  faulty.set_software_version("0.1.0");
  faulty.mutable_station_health()->set_device("can:can0");
  faulty.mutable_station_health()->set_loop_cycles(2000);
  faulty.mutable_station_health()->set_loop_cycle_p99_us(1500);
  faulty.mutable_station_health()->set_loop_budget_us(1000);
  faulty.mutable_station_health()->set_can_lost_frames(3);
  ASSERT_TRUE(
      UploadSession(server.Client(server.MakeToken(StoreRole::kStation, "north")), faulty, &r)
          .ok());
  stations = Admin(dir, "stations" + remote);
  ASSERT_EQ(stations.exit_status, 0) << stations.err;
  const std::string ward = stations.out.substr(stations.out.find("ward-3"));
  for (const std::string& cell : {std::string("0.1.0"), std::string("can:can0"),
                                  std::string("1500/1000"), std::string("loop_p99,can_errors")}) {
    EXPECT_NE(ward.substr(0, ward.find('\n')).find(cell), std::string::npos) << cell << "\n"
                                                                             << stations.out;
  }
  AdminRun token = Admin(dir, "token create --role station" + remote);
  EXPECT_EQ(token.out.size(), 65u);
  // Reads are audited through the group commit, a moment after the answer:
  // polled until the last one is there, not a fixed wait.
  AdminRun audit;
  for (int i = 0; i < 500; ++i) {
    audit = Admin(dir, "audit" + remote);
    if (audit.out.find("session.read") != std::string::npos) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_NE(audit.out.find("case.upload"), std::string::npos);
  EXPECT_NE(audit.out.find("session.read"), std::string::npos);
}

// `case upload --share-with` of a case already stored shares it (it once
// printed "already stored" and shared nothing): south's station can then
// list and download it. Another institution cannot share north's case.
TEST(AdminCli, UploadingAStoredCaseAgainWithShareWithSharesIt) {
  TestServer server;
  const auto& dir = server.dir();
  const std::string remote =
      " --server " + server.address() + " --token " + server.MakeToken(StoreRole::kAdmin, "north");
  const std::string south_station = " --server " + server.address() + " --token " +
                                    server.MakeToken(StoreRole::kStation, "south");
  const std::string case_file =
      std::string(VES_SOURCE_DIR) + "/patient_db/cases/standard-adult.textproto";
  AdminRun first = Admin(dir, "case upload " + case_file + remote);
  ASSERT_EQ(first.exit_status, 0) << first.err;
  EXPECT_EQ(first.out.rfind("stored standard-adult v1", 0), 0u) << first.out;
  EXPECT_EQ(first.out.find("shared with"), std::string::npos) << first.out;
  AdminRun unseen = Admin(dir, "case list" + south_station);
  ASSERT_EQ(unseen.exit_status, 0) << unseen.err;
  EXPECT_EQ(unseen.out.find("standard-adult"), std::string::npos) << unseen.out;

  AdminRun again = Admin(dir, "case upload " + case_file + " --share-with south" + remote);
  ASSERT_EQ(again.exit_status, 0) << again.err;
  EXPECT_EQ(again.out.rfind("already stored standard-adult v1", 0), 0u) << again.out;
  EXPECT_NE(again.out.find("\nshared with south\n"), std::string::npos) << again.out;
  AdminRun seen = Admin(dir, "case list" + south_station);
  ASSERT_EQ(seen.exit_status, 0) << seen.err;
  EXPECT_NE(seen.out.find("standard-adult"), std::string::npos) << seen.out;
  const auto copy = dir / "south.vescase";
  AdminRun down = Admin(dir, "case download standard-adult -o " + copy.string() + south_station);
  ASSERT_EQ(down.exit_status, 0) << down.err;
  EXPECT_EQ(patient_db::ReadFileBytes(copy),
            patient_db::EncodeCaseBundle(patient_db::LoadCaseFile(case_file)));

  // An admin uploading it as south's cannot share north's case onward.
  ASSERT_TRUE(server.store().AddInstitution("west", 1).ok());
  AdminRun foreign =
      Admin(dir, "case upload " + case_file + " --institution south --share-with west" + remote);
  EXPECT_EQ(foreign.exit_status, 1) << foreign.out;
  EXPECT_EQ(Lines(foreign.err), 1) << foreign.err;
  EXPECT_NE(foreign.err.find("owned by institution 'north'"), std::string::npos) << foreign.err;
  AdminRun west = Admin(dir, "case list --server " + server.address() + " --token " +
                                 server.MakeToken(StoreRole::kStation, "west"));
  ASSERT_EQ(west.exit_status, 0) << west.err;
  EXPECT_EQ(west.out.find("standard-adult"), std::string::npos) << west.out;
}

TEST(AdminCli, ErrorsAreOneLineWithNonZeroStatus) {
  TestServer server;
  const auto& dir = server.dir();
  AdminRun bad_token = Admin(dir, "trainee list --server " + server.address() + " --token nope");
  EXPECT_EQ(bad_token.exit_status, 1);
  EXPECT_EQ(Lines(bad_token.err), 1);
  EXPECT_NE(bad_token.err.find("UNAUTHENTICATED"), std::string::npos);
  const std::string remote =
      " --server " + server.address() + " --token " + server.MakeToken(StoreRole::kTrainee,
                                                                       "north", "");
  AdminRun denied = Admin(dir, "audit" + remote);
  EXPECT_EQ(denied.exit_status, 1);
  EXPECT_NE(denied.err.find("PERMISSION_DENIED"), std::string::npos);
  AdminRun bad_role = Admin(dir, "token create --role boss" + remote);
  EXPECT_EQ(bad_role.exit_status, 2);
  EXPECT_EQ(Lines(bad_role.err), 1);
  AdminRun no_server = Admin(dir, "scores --trainee x --token t");
  EXPECT_EQ(no_server.exit_status, 2);
  EXPECT_NE(no_server.err.find("server"), std::string::npos);
}

// A display name with an ANSI escape: the server refuses it now, and one
// stored before (straight in the database) is printed escaped, not obeyed.
TEST(AdminCli, ControlCharactersFromTheServerAreNeverPrintedRaw) {
  TestServer server;
  const auto& dir = server.dir();
  const std::string remote =
      " --server " + server.address() + " --token " + server.MakeToken(StoreRole::kAdmin, "north");
  // popen's /bin/sh: printf makes the escape byte.
  AdminRun add =
      Admin(dir, "trainee add --id mallory --name \"$(printf '\\033[2J\\033[31mred')\"" + remote);
  EXPECT_EQ(add.exit_status, 1) << add.err;
  EXPECT_NE(add.err.find("INVALID_ARGUMENT"), std::string::npos) << add.err;
  EXPECT_NE(add.err.find("control character U+001B"), std::string::npos) << add.err;
  ASSERT_TRUE(server.store().AddTrainee({"eve", "north", "\x1b[2J\x1b[31mred", 1}).ok());
  AdminRun list = Admin(dir, "trainee list" + remote);
  ASSERT_EQ(list.exit_status, 0) << list.err;
  EXPECT_EQ(list.out.find('\x1b'), std::string::npos) << list.out;
  EXPECT_NE(list.out.find("\\x1b[2J\\x1b[31mred"), std::string::npos) << list.out;
}

// More sessions than one page holds: `scores` walks every page.
TEST(AdminCli, ScoresListsEverySessionAcrossPages) {
  TestServer server;
  server.AddTrainee("bulk", "north");
  patient_db::WriteBatch batch;
  std::mt19937_64 rng(5);
  for (int i = 0; i < 1205; ++i) {
    patient_db::SessionRow row;
    row.uuid = NewUuid(rng);
    row.trainee_id = "bulk";
    row.institution = "north";
    row.case_id = "standard-adult";
    row.start_unix_ms = 1'700'000'000'000 + i;
    row.body = "x";
    row.body_sha256_hex = Sha256Hex(row.uuid);
    batch.sessions.push_back(row);
  }
  ASSERT_TRUE(server.store().CommitBatch(batch).ok());
  AdminRun scores = Admin(server.dir(), "scores --trainee bulk --server " + server.address() +
                                            " --token " +
                                            server.MakeToken(StoreRole::kSupervisor, "north"));
  ASSERT_EQ(scores.exit_status, 0) << scores.err;
  EXPECT_EQ(Lines(scores.out), 1 + 1205);  // header and every session
}

TEST(AdminCli, RefusesToSendTheTokenInPlaintextOffLoopback) {
  const auto dir = MakeTempDir("admin_plaintext");
  ves::testing::NonLoopbackListener listener;
  const std::string address = listener.address().empty() ? "192.0.2.1:50051" : listener.address();
  for (const std::string command :
       {"trainee list", "scores --trainee x", "audit", "case list", "curriculum list"}) {
    AdminRun r = Admin(dir, command + " --server " + address + " --token secret --deadline-s 2");
    EXPECT_EQ(r.exit_status, 2) << command << ": " << r.err;
    EXPECT_EQ(Lines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find("refusing to send the token in plaintext to '" + address + "'"),
              std::string::npos)
        << r.err;
  }
  if (!listener.address().empty()) {
    EXPECT_EQ(listener.Connections(), 0);
  }
  std::filesystem::remove_all(dir);
}

TEST(AdminCli, FlagErrorsAreOneLineAndExitStatus2NeverAnAbort) {
  const auto dir = MakeTempDir("admin_flags");
  const std::string remote = " --server 127.0.0.1:1 --token t";
  for (const std::string& args : {
           "trainee list" + remote + " --tls-ca /nonexistent.pem",
           "trainee list" + remote + " --tls-cert /nonexistent.pem",
           "trainee list" + remote + " --tls-ca /etc/hostname --tls-key /nonexistent.pem",
           "case list" + remote + " --tls-ca /nonexistent.pem",
           "scores --trainee x" + remote + " --deadline-s 0",
           "scores --trainee x" + remote + " --deadline-s -5",
           "audit" + remote + " --limit many",
       }) {
    AdminRun r = Admin(dir, args);
    EXPECT_EQ(r.exit_status, 2) << args << ": " << r.err;
    EXPECT_EQ(Lines(r.err), 1) << args << ": " << r.err;
    EXPECT_EQ(r.err.find("terminate called"), std::string::npos) << r.err;
  }
  AdminRun ca = Admin(dir, "trainee list" + remote + " --tls-ca /nonexistent.pem");
  EXPECT_NE(ca.err.find("--tls-ca /nonexistent.pem: cannot read the file"), std::string::npos)
      << ca.err;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace ves::server::testing
