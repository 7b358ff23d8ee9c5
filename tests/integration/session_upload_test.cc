// Sessions.UploadSession: idempotency both ways, concurrency with repeats,
// bad input, and the supervisor's read side.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <grpcpp/generic/generic_stub.h>

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <limits>
#include <mutex>
#include <set>
#include <thread>

#include "patient_db/case_format.h"
#include "tests/integration/test_server.h"

namespace ves::server::testing {
namespace {

using patient_db::StoreRole;

class SessionUpload : public ::testing::Test {
 protected:
  void SetUp() override {
    server_.AddTrainee("t1", "north");
    PutSampleCase(server_.store(), "north");
    station_ = server_.Client(server_.MakeToken(StoreRole::kStation, "north"));
    supervisor_ = server_.Client(server_.MakeToken(StoreRole::kSupervisor, "north"));
  }
  grpc::Status Get(const std::string& uuid, ves::v1::GetSessionResponse* r) {
    grpc::ClientContext ctx;
    PrepareContext(&ctx, supervisor_);
    ves::v1::GetSessionRequest q;
    q.set_uuid(uuid);
    return ves::v1::Trainees::NewStub(MakeClientChannel(supervisor_))->GetSession(&ctx, q, r);
  }
  TestServer server_;
  ClientOptions station_;
  ClientOptions supervisor_;
  std::mt19937_64 rng_{7};
};

TEST_F(SessionUpload, SameUuidAndBodyAgainGivesTheFirstResult) {
  const auto record = MakeRecord(NewUuid(rng_), "t1", 3);
  ves::v1::UploadSessionResponse first, second;
  ASSERT_TRUE(UploadSession(station_, record, &first).ok());
  std::this_thread::sleep_for(std::chrono::milliseconds(5));  // a later stored time if re-stored
  ASSERT_TRUE(UploadSession(station_, record, &second).ok());
  EXPECT_EQ(first.SerializeAsString(), second.SerializeAsString());
  EXPECT_EQ(first.uuid(), record.uuid());
  EXPECT_EQ(server_.store().CountSessions().value, 1);
}

TEST_F(SessionUpload, SameUuidWithOtherBodyIsRefusedAndFirstKept) {
  const auto record = MakeRecord(NewUuid(rng_), "t1", 3);
  auto changed = record;
  changed.set_score(record.score() + 1);
  ves::v1::UploadSessionResponse r;
  ASSERT_TRUE(UploadSession(station_, record, &r).ok());
  auto status = UploadSession(station_, changed, &r);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::ALREADY_EXISTS);
  EXPECT_NE(status.error_message().find(record.uuid()), std::string::npos);
  ves::v1::GetSessionResponse got;
  ASSERT_TRUE(Get(record.uuid(), &got).ok());
  EXPECT_EQ(got.record().SerializeAsString(), record.SerializeAsString());  // whole, unchanged
}

TEST_F(SessionUpload, ConcurrentUploadsWithRepeatsStoreExactlyTheDistinctRecords) {
  constexpr int kClients = 32;
  constexpr int kUploads = 1000;
  constexpr int kDistinct = 600;  // uploads k and k+600 carry the same record
  std::vector<ves::v1::SessionRecord> records;
  for (int i = 0; i < kDistinct; ++i) records.push_back(MakeRecord(NewUuid(rng_), "t1", i));
  std::atomic<int> next{0};
  std::atomic<int> failures{0};
  std::vector<std::thread> clients;
  for (int c = 0; c < kClients; ++c) {
    clients.emplace_back([&] {
      auto stub = ves::v1::Sessions::NewStub(MakeClientChannel(station_));
      for (int k = next++; k < kUploads; k = next++) {
        grpc::ClientContext ctx;
        PrepareContext(&ctx, station_);
        ves::v1::UploadSessionRequest q;
        *q.mutable_record() = records[k % kDistinct];
        ves::v1::UploadSessionResponse r;
        if (!stub->UploadSession(&ctx, q, &r).ok() || r.uuid() != q.record().uuid()) ++failures;
      }
    });
  }
  for (auto& t : clients) t.join();
  EXPECT_EQ(failures.load(), 0);
  EXPECT_EQ(server_.store().CountSessions().value, kDistinct);
  auto listed = server_.store().ListSessions("t1", "").value;
  std::set<std::string> uuids;
  for (const auto& row : listed) uuids.insert(row.uuid);
  EXPECT_EQ(uuids.size(), static_cast<size_t>(kDistinct));
  EXPECT_GT(server_.server().commit_batches(), 0u);
}

TEST_F(SessionUpload, NonFiniteMetricIsRefusedNamingTheField) {
  auto record = MakeRecord(NewUuid(rng_), "t1", 1);
  record.mutable_metrics()->set_pain_s(std::numeric_limits<double>::quiet_NaN());
  ves::v1::UploadSessionResponse r;
  auto status = UploadSession(station_, record, &r);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("record.metrics.pain_s"), std::string::npos)
      << status.error_message();
  record = MakeRecord(NewUuid(rng_), "t1", 1);
  record.mutable_events(2)->set_value(std::numeric_limits<double>::infinity());
  status = UploadSession(station_, record, &r);
  EXPECT_NE(status.error_message().find("record.events[2].value"), std::string::npos)
      << status.error_message();
  EXPECT_TRUE(UploadSession(station_, MakeRecord(NewUuid(rng_), "t1", 2), &r).ok());
}

// Admin.ListStations as `who`.
grpc::Status ListStations(const ClientOptions& who, const std::string& institution,
                          ves::v1::ListStationsResponse* r) {
  grpc::ClientContext ctx;
  PrepareContext(&ctx, who);
  ves::v1::ListStationsRequest q;
  q.set_institution(institution);
  return ves::v1::Admin::NewStub(MakeClientChannel(who))->ListStations(&ctx, q, r);
}

ves::v1::SessionRecord WithHealth(ves::v1::SessionRecord r, uint64_t hard_faults) {
  r.set_software_version("0.1.0");
  auto* h = r.mutable_station_health();
  h->set_device("can:can0");
  h->set_loop_cycles(300'000);
  h->set_loop_cycle_p99_us(380);
  h->set_loop_budget_us(1000);
  h->set_loop_overruns(2);
  h->set_hard_faults(hard_faults);
  h->set_can_bus_errors(4);
  return r;
}

TEST_F(SessionUpload, AnUploadWithHealthCreatesThenUpdatesItsStationRow) {
  ves::v1::UploadSessionResponse r;
  const auto first = WithHealth(MakeRecord(NewUuid(rng_), "t1", 1), 0);
  ASSERT_TRUE(UploadSession(station_, first, &r).ok());
  ves::v1::ListStationsResponse list;
  ASSERT_TRUE(ListStations(supervisor_, "", &list).ok());
  ASSERT_EQ(list.stations_size(), 1);
  const ves::v1::StationSummary& s = list.stations(0);
  EXPECT_EQ(s.station_id(), "station-1");
  EXPECT_EQ(s.institution(), "north");
  EXPECT_EQ(s.software_version(), "0.1.0");
  EXPECT_EQ(s.last_seen_unix_ms(), r.stored_unix_ms());
  EXPECT_EQ(s.health_session_uuid(), first.uuid());
  EXPECT_EQ(s.health().SerializeAsString(), first.station_health().SerializeAsString());

  // A newer session (seed 2 starts a minute later) replaces the health.
  const auto second = WithHealth(MakeRecord(NewUuid(rng_), "t1", 2), 3);
  ASSERT_TRUE(UploadSession(station_, second, &r).ok());
  ASSERT_TRUE(ListStations(supervisor_, "", &list).ok());
  ASSERT_EQ(list.stations_size(), 1);
  EXPECT_EQ(list.stations(0).health().hard_faults(), 3u);
  EXPECT_EQ(list.stations(0).health_session_uuid(), second.uuid());
  // Supervisors see their own institution only; trainees and stations none.
  EXPECT_EQ(ListStations(supervisor_, "south", &list).error_code(),
            grpc::StatusCode::PERMISSION_DENIED);
  const ClientOptions trainee =
      server_.Client(server_.MakeToken(StoreRole::kTrainee, "north", "t1"));
  EXPECT_EQ(ListStations(trainee, "", &list).error_code(), grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_EQ(ListStations(station_, "", &list).error_code(), grpc::StatusCode::PERMISSION_DENIED);
}

TEST_F(SessionUpload, MalformedHealthIsRefusedNamingTheFieldAndNothingIsStored) {
  ves::v1::UploadSessionResponse r;
  const auto good = WithHealth(MakeRecord(NewUuid(rng_), "t1", 1), 1);
  ASSERT_TRUE(UploadSession(station_, good, &r).ok());
  ves::v1::ListStationsResponse before;
  ASSERT_TRUE(ListStations(supervisor_, "", &before).ok());

  struct Case {
    const char* field;
    void (*spoil)(ves::v1::SessionRecord*);
  };
  const Case cases[] = {
      {"record.station_health.loop_cycle_p99_us = nan",
       [](ves::v1::SessionRecord* x) {
         x->mutable_station_health()->set_loop_cycle_p99_us(
             std::numeric_limits<double>::quiet_NaN());
       }},
      {"record.station_health.loop_cycle_p99_us = -5",
       [](ves::v1::SessionRecord* x) { x->mutable_station_health()->set_loop_cycle_p99_us(-5); }},
      {"record.station_health.can_bus_errors = 18446744073709551615",
       [](ves::v1::SessionRecord* x) {
         x->mutable_station_health()->set_can_bus_errors(UINT64_MAX);
       }},
      {"record.software_version = '0.1.0.0.0",
       [](ves::v1::SessionRecord* x) {
         std::string v = "0.1.0";
         while (v.size() < 80) v += ".0";
         x->set_software_version(v);
       }},
      // Control characters are refused by the request bounds, before the record's checks.
      {"request.record.software_version = '0.1\\x07'",
       [](ves::v1::SessionRecord* x) { x->set_software_version("0.1\a"); }},
  };
  for (const Case& c : cases) {
    auto bad = WithHealth(MakeRecord(NewUuid(rng_), "t1", 5), 9);
    c.spoil(&bad);
    const grpc::Status status = UploadSession(station_, bad, &r);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.field;
    EXPECT_EQ(status.error_message().rfind(c.field, 0), 0u) << status.error_message();
    ves::v1::GetSessionResponse got;
    EXPECT_EQ(Get(bad.uuid(), &got).error_code(), grpc::StatusCode::NOT_FOUND) << c.field;
  }
  // Nothing of the refused uploads reached the station row; the good one is whole.
  ves::v1::ListStationsResponse after;
  ASSERT_TRUE(ListStations(supervisor_, "", &after).ok());
  EXPECT_EQ(after.SerializeAsString(), before.SerializeAsString());
  EXPECT_EQ(server_.store().CountSessions().value, 1);
  ves::v1::GetSessionResponse stored;
  ASSERT_TRUE(Get(good.uuid(), &stored).ok());
  EXPECT_EQ(stored.record().station_health().SerializeAsString(),
            good.station_health().SerializeAsString());
}

TEST_F(SessionUpload, BadUuidAndUnknownTraineeAreRefused) {
  ves::v1::UploadSessionResponse r;
  auto status = UploadSession(station_, MakeRecord("NOT-A-UUID", "t1", 1), &r);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("record.uuid"), std::string::npos);
  status = UploadSession(station_, MakeRecord(NewUuid(rng_), "ghost", 1), &r);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_NE(status.error_message().find("ghost"), std::string::npos);
}

TEST_F(SessionUpload, OversizedMessageIsRefusedAndServerKeepsServing) {
  auto record = MakeRecord(NewUuid(rng_), "t1", 1);
  record.mutable_input_log()->set_encoded(std::string(17 << 20, 'x'));  // limit is 16 MiB
  ves::v1::UploadSessionResponse r;
  auto status = UploadSession(station_, record, &r);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_TRUE(UploadSession(station_, MakeRecord(NewUuid(rng_), "t1", 2), &r).ok());
}

TEST_F(SessionUpload, GarbageBytesOnThePortDoNotStopTheServer) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(server_.server().port()));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  std::string garbage(4096, '\0');
  for (auto& ch : garbage) ch = static_cast<char>(rng_());
  ASSERT_GT(::send(fd, garbage.data(), garbage.size(), MSG_NOSIGNAL), 0);
  char buf[1024];
  // The server answers with an HTTP/2 GOAWAY (or nothing) and closes.
  timeval tv{5, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  while (::recv(fd, buf, sizeof buf, 0) > 0) {
  }
  ::close(fd);
  ves::v1::UploadSessionResponse r;
  EXPECT_TRUE(UploadSession(station_, MakeRecord(NewUuid(rng_), "t1", 2), &r).ok());
}

// Bytes no UploadSessionRequest parses from: gRPC's own answer was
// UNIMPLEMENTED with no message; now INVALID_ARGUMENT saying why.
TEST_F(SessionUpload, AMalformedRequestIsInvalidArgumentWithAMessage) {
  // record { station_id: "\xff" }: field 1 (message) holding field 6 (string).
  const std::string not_utf8("\x0a\x03\x32\x01\xff", 5);
  const std::string not_protobuf("\xff\xff\xff\xff", 4);
  for (const std::string& bytes : {not_utf8, not_protobuf}) {
    grpc::GenericStub stub(MakeClientChannel(station_));
    grpc::ClientContext ctx;
    PrepareContext(&ctx, station_);
    grpc::Slice slice(bytes);
    grpc::ByteBuffer request(&slice, 1), reply;
    grpc::Status status;
    std::mutex mutex;
    std::condition_variable done_cv;
    bool done = false;
    stub.UnaryCall(&ctx, "/ves.v1.Sessions/UploadSession", grpc::StubOptions(), &request, &reply,
                   [&](grpc::Status s) {
                     std::lock_guard lock(mutex);
                     status = s;
                     done = true;
                     done_cv.notify_one();
                   });
    std::unique_lock lock(mutex);
    done_cv.wait(lock, [&] { return done; });
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(status.error_message().find("/ves.v1.Sessions/UploadSession: malformed protobuf"),
              std::string::npos)
        << status.error_message();
    if (bytes == not_utf8) {
      EXPECT_NE(status.error_message().find("ves.v1.SessionRecord.station_id"), std::string::npos)
          << status.error_message();
    }
  }
  EXPECT_EQ(server_.store().CountSessions().value, 0);
}

// Issue #20: one trainee's sessions made ListSessions outgrow the message
// limit for good. Replies are pages now: walked with next_page_token they
// give every session once, in order; a token of another listing is refused.
TEST_F(SessionUpload, ListSessionsComesInPages) {
  patient_db::WriteBatch batch;
  for (int i = 0; i < 250; ++i) {
    patient_db::SessionRow row;
    row.uuid = NewUuid(rng_);
    row.trainee_id = "t1";
    row.institution = "north";
    row.case_id = "standard-adult";
    row.start_unix_ms = 1'700'000'000'000 + i / 3;  // ties broken by uuid
    row.body = "x";
    row.body_sha256_hex = Sha256Hex(row.uuid);
    batch.sessions.push_back(row);
  }
  ASSERT_TRUE(server_.store().CommitBatch(batch).ok());
  auto stub = ves::v1::Trainees::NewStub(MakeClientChannel(supervisor_));
  ves::v1::ListSessionsRequest q;
  q.set_trainee_id("t1");
  q.set_page_size(100);
  std::vector<std::pair<int64_t, std::string>> seen;
  int pages = 0;
  do {
    grpc::ClientContext ctx;
    PrepareContext(&ctx, supervisor_);
    ves::v1::ListSessionsResponse r;
    ASSERT_TRUE(stub->ListSessions(&ctx, q, &r).ok());
    EXPECT_LE(r.sessions_size(), 100);
    for (const auto& s : r.sessions()) seen.emplace_back(s.start_unix_ms(), s.uuid());
    q.set_page_token(r.next_page_token());
    ++pages;
  } while (!q.page_token().empty());
  EXPECT_EQ(pages, 3);
  ASSERT_EQ(seen.size(), 250u);
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
  EXPECT_EQ(std::set(seen.begin(), seen.end()).size(), 250u);
  grpc::ClientContext ctx;
  PrepareContext(&ctx, supervisor_);
  q.set_page_token("cases:1:standard-adult");
  ves::v1::ListSessionsResponse r;
  const grpc::Status bad = stub->ListSessions(&ctx, q, &r);
  EXPECT_EQ(bad.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(bad.error_message().find("page_token"), std::string::npos);
}

TEST_F(SessionUpload, SupervisorSeesScoresAndLearningCurvePerCase) {
  PutTestCase(server_.store(),
              patient_db::LoadCaseFile(std::string(VES_SOURCE_DIR) +
                                       "/patient_db/cases/paper-sigmoid.textproto"),
              "north");
  ves::v1::UploadSessionResponse r;
  for (int i = 0; i < 3; ++i) {
    auto record = MakeRecord(NewUuid(rng_), "t1", i);
    if (i == 1) record.set_case_id("paper-sigmoid");
    ASSERT_TRUE(UploadSession(station_, record, &r).ok());
  }
  grpc::ClientContext ctx;
  PrepareContext(&ctx, supervisor_);
  ves::v1::LearningCurveRequest q;
  q.set_trainee_id("t1");
  ves::v1::LearningCurveResponse curve;
  ASSERT_TRUE(ves::v1::Trainees::NewStub(MakeClientChannel(supervisor_))
                  ->GetLearningCurve(&ctx, q, &curve)
                  .ok());
  ASSERT_EQ(curve.curves_size(), 2);
  EXPECT_EQ(curve.curves(0).case_id(), "paper-sigmoid");
  EXPECT_EQ(curve.curves(0).points_size(), 1);
  ASSERT_EQ(curve.curves(1).points_size(), 2);  // standard-adult: seeds 0 and 2
  EXPECT_EQ(curve.curves(1).points(1).attempt(), 2u);
  EXPECT_DOUBLE_EQ(curve.curves(1).points(1).score(), 52.0);  // 50 + 2 % 50
}

}  // namespace
}  // namespace ves::server::testing
