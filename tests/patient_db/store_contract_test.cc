// The storage contract every Store implementation must keep (DESIGN.md §7:
// one suite, run against each backend). A new backend adds one line to
// INSTANTIATE_TEST_SUITE_P below with a factory for an empty store.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "patient_db/migrations/migrations.h"
#include "patient_db/sqlite_store.h"
#include "patient_db/store.h"

namespace ves::patient_db {
namespace {

struct Backend {
  std::string name;
  // Opens the store kept at `dir` (empty dir: a new store).
  std::function<std::unique_ptr<Store>(const std::filesystem::path& dir)> open;
};

void PrintTo(const Backend& backend, std::ostream* os) { *os << backend.name; }

class StoreContract : public ::testing::TestWithParam<Backend> {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("ves_store_" + GetParam().name + "_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    store_ = GetParam().open(dir_);
    ASSERT_TRUE(store_->AddInstitution("north", 1).ok());
    ASSERT_TRUE(store_->AddInstitution("south", 1).ok());
    ASSERT_TRUE(store_->AddTrainee({"t1", "north", "Trainee One", 10}).ok());
  }
  void TearDown() override {
    store_.reset();
    std::filesystem::remove_all(dir_);
  }
  void Reopen() {
    store_.reset();
    store_ = GetParam().open(dir_);
  }

  static SessionRow Session(const std::string& uuid, const std::string& body, int64_t start) {
    SessionRow r;
    r.uuid = uuid;
    r.trainee_id = "t1";
    r.institution = "north";
    r.case_id = "standard-adult";
    r.case_version = 1;
    r.station_id = "st-1";
    r.start_unix_ms = start;
    r.end_unix_ms = start + 1000;
    r.outcome = 1;
    r.completed = true;
    r.time_to_cecum_s = 120.5;
    r.pain_s = 3.25;
    r.score = 77.5;
    r.operator_kind = "novice";
    r.max_tip_arc_m = 0.8125;
    r.body = body;
    r.body_sha256_hex = "hash-of-" + body;
    r.stored_unix_ms = 5000 + start;
    return r;
  }

  static CaseRow Case(const std::string& id, uint32_t version, const std::string& sha) {
    CaseRow c;
    c.case_id = id;
    c.version = version;
    c.title = id + " v" + std::to_string(version);
    c.difficulty = 2;
    c.region_mask = (1u << 1) | (1u << 2);  // rectum, sigmoid
    c.institution = "north";
    c.sha256_hex = sha;
    c.payload_sha256_hex = "p" + sha;
    c.uploaded_by = "abc";
    c.stored_unix_ms = 42;
    return c;
  }

  std::filesystem::path dir_;
  std::unique_ptr<Store> store_;
};

TEST_P(StoreContract, TokensAreFoundByHashOnly) {
  TokenRow t{"aa11", StoreRole::kSupervisor, "north", "", "dr x", 7};
  ASSERT_TRUE(store_->AddToken(t).ok());
  auto found = store_->FindToken("aa11");
  ASSERT_TRUE(found.ok()) << found.status.message;
  EXPECT_EQ(found.value, t);
  EXPECT_EQ(store_->FindToken("aa12").status.code, StoreCode::kNotFound);
}

TEST_P(StoreContract, TokenForUnknownInstitutionIsRefused) {
  TokenRow t{"bb", StoreRole::kStation, "nowhere", "", "", 7};
  EXPECT_EQ(store_->AddToken(t).code, StoreCode::kInvalidArgument);
}

TEST_P(StoreContract, AccountsAreFoundByNameAndIdentityAndRevokedOnce) {
  AccountRow a{"alice", StoreRole::kSupervisor, "north", "$scrypt$hash", "sub-1", 5, 900, 0};
  AccountRow b{"bob", StoreRole::kAdmin, "south", "", "", 6, 0, 0};
  AccountRow c{"carol", StoreRole::kSupervisor, "north", "h", "", 7, 0, 0};
  ASSERT_TRUE(store_->AddAccount(a).ok());
  ASSERT_TRUE(store_->AddAccount(b).ok());
  ASSERT_TRUE(store_->AddAccount(c).ok());  // a second empty identity is no clash
  auto got = store_->GetAccount("alice");
  ASSERT_TRUE(got.ok()) << got.status.message;
  EXPECT_EQ(got.value, a);
  auto by_identity = store_->FindAccountByIdentity("sub-1");
  ASSERT_TRUE(by_identity.ok());
  EXPECT_EQ(by_identity.value.username, "alice");
  EXPECT_EQ(store_->FindAccountByIdentity("").status.code, StoreCode::kNotFound);
  EXPECT_EQ(store_->GetAccount("nobody").status.code, StoreCode::kNotFound);

  EXPECT_EQ(store_->AddAccount({"alice", StoreRole::kAdmin, "north", "", "", 8, 0, 0}).code,
            StoreCode::kAlreadyExists);
  EXPECT_EQ(store_->AddAccount({"dave", StoreRole::kAdmin, "north", "", "sub-1", 8, 0, 0}).code,
            StoreCode::kAlreadyExists);
  EXPECT_EQ(store_->AddAccount({"erin", StoreRole::kAdmin, "nowhere", "", "", 8, 0, 0}).code,
            StoreCode::kInvalidArgument);

  auto north = store_->ListAccounts("north");
  ASSERT_TRUE(north.ok());
  ASSERT_EQ(north.value.size(), 2u);
  EXPECT_EQ(north.value[0].username, "alice");
  EXPECT_EQ(north.value[1].username, "carol");
  auto all = store_->ListAccounts("");
  ASSERT_TRUE(all.ok());
  EXPECT_EQ(all.value.size(), 3u);

  ASSERT_TRUE(store_->RevokeAccount("alice", 1000).ok());
  ASSERT_TRUE(store_->RevokeAccount("alice", 2000).ok());  // the first time is kept
  EXPECT_EQ(store_->GetAccount("alice").value.revoked_unix_ms, 1000);
  EXPECT_EQ(store_->RevokeAccount("nobody", 1000).code, StoreCode::kNotFound);
  ASSERT_TRUE(store_->SetAccountPassword("bob", "$scrypt$new").ok());
  EXPECT_EQ(store_->GetAccount("bob").value.password_hash, "$scrypt$new");
  EXPECT_EQ(store_->SetAccountPassword("nobody", "x").code, StoreCode::kNotFound);
  Reopen();
  EXPECT_EQ(store_->GetAccount("alice").value.revoked_unix_ms, 1000);
}

TEST_P(StoreContract, TraineesAreListedPerInstitution) {
  ASSERT_TRUE(store_->AddTrainee({"t2", "south", "Two", 11}).ok());
  ASSERT_TRUE(store_->AddTrainee({"t0", "north", "Zero", 12}).ok());
  auto north = store_->ListTrainees("north");
  ASSERT_TRUE(north.ok());
  ASSERT_EQ(north.value.size(), 2u);
  EXPECT_EQ(north.value[0].trainee_id, "t0");  // ordered by id
  EXPECT_EQ(north.value[1].trainee_id, "t1");
  EXPECT_EQ(store_->AddTrainee({"t1", "north", "again", 13}).code, StoreCode::kAlreadyExists);
  EXPECT_EQ(store_->GetTrainee("nobody").status.code, StoreCode::kNotFound);
}

TEST_P(StoreContract, CaseVersionsAreKeptAndBlobsContentAddressed) {
  ASSERT_TRUE(store_->PutCase(Case("c", 1, "h1"), "bytes-1").ok());
  auto v2 = store_->PutCase(Case("c", 2, "h2"), "bytes-22");
  ASSERT_TRUE(v2.ok()) << v2.status.message;
  EXPECT_FALSE(v2.value.already_stored);
  EXPECT_EQ(v2.value.row.size_bytes, 8u);
  auto latest = store_->GetCase("c", 0);
  ASSERT_TRUE(latest.ok());
  EXPECT_EQ(latest.value.version, 2u);
  EXPECT_EQ(store_->GetCase("c", 1).value.sha256_hex, "h1");
  EXPECT_EQ(store_->GetBlob("h1").value, "bytes-1");
  EXPECT_EQ(store_->GetBlob("h2").value, "bytes-22");
  EXPECT_EQ(store_->GetCase("c", 3).status.code, StoreCode::kNotFound);
}

TEST_P(StoreContract, SameCaseVersionTwiceIsIdempotentOtherContentRefused) {
  ASSERT_TRUE(store_->PutCase(Case("c", 1, "h1"), "bytes-1").ok());
  auto again = store_->PutCase(Case("c", 1, "h1"), "bytes-1");
  ASSERT_TRUE(again.ok());
  EXPECT_TRUE(again.value.already_stored);
  auto other = store_->PutCase(Case("c", 1, "h9"), "other");
  EXPECT_EQ(other.status.code, StoreCode::kAlreadyExists);
  EXPECT_EQ(store_->GetBlob("h9").status.code, StoreCode::kNotFound);  // rolled back
}

// `ves-admin case upload --share-with` on a case stored before shares it:
// the owner's re-upload adds its shares (kept, never removed); another
// institution cannot share the owner's case.
TEST_P(StoreContract, ReuploadByTheOwnerAddsShares) {
  ASSERT_TRUE(store_->PutCase(Case("c", 1, "h1"), "bytes-1").ok());
  CaseRow again = Case("c", 1, "h1");
  again.shared_with = {"south", "north", "south"};  // the owner and a repeat are no share
  auto shared = store_->PutCase(again, "bytes-1");
  ASSERT_TRUE(shared.ok()) << shared.status.message;
  EXPECT_TRUE(shared.value.already_stored);
  EXPECT_EQ(shared.value.row.shared_with, std::vector<std::string>{"south"});
  CaseFilter south;
  south.visible_to = "south";
  auto seen = store_->ListCases(south);
  ASSERT_TRUE(seen.ok()) << seen.status.message;
  ASSERT_EQ(seen.value.size(), 1u);
  EXPECT_EQ(seen.value[0].case_id, "c");
  // A later upload without shares keeps them; one with another adds it.
  auto plain = store_->PutCase(Case("c", 1, "h1"), "bytes-1");
  ASSERT_TRUE(plain.ok());
  EXPECT_EQ(plain.value.row.shared_with, std::vector<std::string>{"south"});
  ASSERT_TRUE(store_->AddInstitution("east", 1).ok());
  CaseRow east = Case("c", 1, "h1");
  east.shared_with = {"east"};
  auto both = store_->PutCase(east, "bytes-1");
  ASSERT_TRUE(both.ok()) << both.status.message;
  EXPECT_EQ(both.value.row.shared_with, (std::vector<std::string>{"east", "south"}));
  Reopen();
  auto listed = store_->ListCases(CaseFilter{});
  ASSERT_TRUE(listed.ok());
  ASSERT_EQ(listed.value.size(), 1u);
  EXPECT_EQ(listed.value[0].shared_with, (std::vector<std::string>{"east", "south"}));
  // Not the owner: refused, nothing shared.
  CaseRow foreign = Case("c", 1, "h1");
  foreign.institution = "south";
  foreign.shared_with = {"west"};
  auto refused = store_->PutCase(foreign, "bytes-1");
  EXPECT_EQ(refused.status.code, StoreCode::kAlreadyExists);
  EXPECT_NE(refused.status.message.find("owned by institution 'north'"), std::string::npos)
      << refused.status.message;
  CaseFilter west;
  west.visible_to = "west";
  EXPECT_TRUE(store_->ListCases(west).value.empty());
  // Another institution's upload of the same content without shares stays
  // the idempotent repeat it was.
  foreign.shared_with.clear();
  EXPECT_TRUE(store_->PutCase(foreign, "bytes-1").ok());
}

TEST_P(StoreContract, CaseListFiltersAndVisibility) {
  CaseRow shared = Case("shared", 1, "hs");
  shared.shared_with = {"south"};
  ASSERT_TRUE(store_->PutCase(shared, "s").ok());
  CaseRow hard = Case("hard", 1, "hh");
  hard.difficulty = 3;
  hard.region_mask = 1u << 5;  // transverse only
  ASSERT_TRUE(store_->PutCase(hard, "h").ok());
  ASSERT_TRUE(store_->PutCase(Case("hard", 2, "hh2"), "h2").ok());

  CaseFilter latest;
  auto all = store_->ListCases(latest);
  ASSERT_TRUE(all.ok());
  ASSERT_EQ(all.value.size(), 2u);  // hard@2, shared@1
  EXPECT_EQ(all.value[0].case_id, "hard");
  EXPECT_EQ(all.value[0].version, 2u);

  CaseFilter versions;
  versions.all_versions = true;
  EXPECT_EQ(store_->ListCases(versions).value.size(), 3u);

  CaseFilter south;
  south.visible_to = "south";
  auto seen = store_->ListCases(south).value;
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0].case_id, "shared");
  EXPECT_EQ(seen[0].shared_with, std::vector<std::string>{"south"});

  CaseFilter transverse;
  transverse.region = 5;
  transverse.all_versions = true;
  auto t = store_->ListCases(transverse).value;
  ASSERT_EQ(t.size(), 1u);
  EXPECT_EQ(t[0].version, 1u);

  CaseFilter medium;
  medium.difficulty = 2;
  EXPECT_EQ(store_->ListCases(medium).value.size(), 2u);  // shared@1 and hard@2
}

TEST_P(StoreContract, BatchStoresNewDetectsDuplicateAndConflict) {
  WriteBatch first;
  first.sessions = {Session("u1", "body-a", 100), Session("u2", "body-b", 50)};
  auto r1 = store_->CommitBatch(first);
  ASSERT_TRUE(r1.ok()) << r1.status.message;
  ASSERT_EQ(r1.value.size(), 2u);
  EXPECT_EQ(r1.value[0].outcome, SessionPut::kStored);

  WriteBatch second;
  SessionRow dup = Session("u1", "body-a", 100);
  dup.stored_unix_ms = 999999;  // a later upload: the first one's time must come back
  second.sessions = {dup, Session("u2", "body-changed", 50), Session("u3", "c", 10),
                     Session("u3", "c", 10)};
  auto r2 = store_->CommitBatch(second);
  ASSERT_TRUE(r2.ok());
  EXPECT_EQ(r2.value[0].outcome, SessionPut::kDuplicate);
  EXPECT_EQ(r2.value[0].first.stored_unix_ms, 5100);
  EXPECT_EQ(r2.value[1].outcome, SessionPut::kConflict);
  EXPECT_EQ(r2.value[1].first.body_sha256_hex, "hash-of-body-b");
  EXPECT_EQ(r2.value[2].outcome, SessionPut::kStored);
  EXPECT_EQ(r2.value[3].outcome, SessionPut::kDuplicate);  // repeat inside one batch
  EXPECT_EQ(store_->CountSessions().value, 3);
}

TEST_P(StoreContract, SessionsSurviveReopenWithBodyAndOrder) {
  WriteBatch b;
  b.sessions = {Session("u1", "body-a", 300), Session("u2", "body-b", 100)};
  ASSERT_TRUE(store_->CommitBatch(b).ok());
  Reopen();
  auto one = store_->GetSession("u1");
  ASSERT_TRUE(one.ok());
  SessionRow expected = Session("u1", "body-a", 300);
  EXPECT_EQ(one.value, expected);
  auto list = store_->ListSessions("t1", "");
  ASSERT_TRUE(list.ok());
  ASSERT_EQ(list.value.size(), 2u);
  EXPECT_EQ(list.value[0].uuid, "u2");  // oldest first
  EXPECT_TRUE(list.value[0].body.empty());
  // The listing carries who operated and how deep the tip got.
  EXPECT_EQ(list.value[1].operator_kind, "novice");
  EXPECT_EQ(list.value[1].max_tip_arc_m, 0.8125);
  EXPECT_EQ(store_->ListSessions("t1", "other-case").value.size(), 0u);
  EXPECT_EQ(store_->GetSession("nope").status.code, StoreCode::kNotFound);
}

// Learning curves per lesson are built from the listing: the lesson a
// record names comes back with it (after a reopen, too), '' for a free run.
TEST_P(StoreContract, SessionsReadBackTheLessonTheyName) {
  WriteBatch b;
  SessionRow lesson = Session("u1", "body-a", 100);
  lesson.lesson_id = "navigate-sigmoid";
  SessionRow free_run = Session("u2", "body-b", 200);
  b.sessions = {lesson, free_run};
  ASSERT_TRUE(store_->CommitBatch(b).ok());
  Reopen();
  auto list = store_->ListSessions("t1", "");
  ASSERT_TRUE(list.ok()) << list.status.message;
  ASSERT_EQ(list.value.size(), 2u);
  EXPECT_EQ(list.value[0].lesson_id, "navigate-sigmoid");
  EXPECT_EQ(list.value[1].lesson_id, "");
  // A page after the first row still names its lesson column right.
  ListPage page;
  page.has_after = true;
  page.after_text = "u1";
  page.after_number = 100;
  auto rest = store_->ListSessions("t1", "standard-adult", page);
  ASSERT_TRUE(rest.ok()) << rest.status.message;
  ASSERT_EQ(rest.value.size(), 1u);
  EXPECT_EQ(rest.value[0].uuid, "u2");
  EXPECT_EQ(rest.value[0].lesson_id, "");
  auto one = store_->GetSession("u1");
  ASSERT_TRUE(one.ok()) << one.status.message;
  EXPECT_EQ(one.value.lesson_id, "navigate-sigmoid");
  EXPECT_EQ(one.value.body, "body-a");
  EXPECT_EQ(store_->GetSession("u2").value.lesson_id, "");
}

TEST_P(StoreContract, SessionsKeepLoopAndXrayTimeAndListAnOperatorsRunsOfACase) {
  ASSERT_TRUE(store_->AddTrainee({"s1", "south", "South One", 10}).ok());
  WriteBatch b;
  SessionRow expert_old = Session("u1", "a", 100);
  expert_old.operator_kind = "expert";
  expert_old.loop_s = 2.5;
  expert_old.xray_s = 7.25;
  SessionRow expert_new = Session("u2", "b", 300);
  expert_new.operator_kind = "expert";
  SessionRow other_case = Session("u3", "c", 200);
  other_case.operator_kind = "expert";
  other_case.case_id = "redundant-sigmoid";
  SessionRow novice = Session("u4", "d", 400);  // operator "novice"
  SessionRow unknown = Session("u5", "e", 500);
  unknown.operator_kind = "expert";
  unknown.loop_s = -1;  // a row that never had them: read back as not known
  unknown.xray_s = -1;
  SessionRow south = Session("u6", "f", 600);
  south.trainee_id = "s1";
  south.institution = "south";
  south.operator_kind = "expert";
  b.sessions = {expert_old, expert_new, other_case, novice, unknown, south};
  ASSERT_TRUE(store_->CommitBatch(b).ok());
  Reopen();
  auto one = store_->GetSession("u1");
  ASSERT_TRUE(one.ok()) << one.status.message;
  EXPECT_EQ(one.value.loop_s, 2.5);
  EXPECT_EQ(one.value.xray_s, 7.25);
  auto listed = store_->ListSessions("t1", "");
  ASSERT_TRUE(listed.ok()) << listed.status.message;
  ASSERT_EQ(listed.value.size(), 5u);
  EXPECT_EQ(listed.value[0].loop_s, 2.5);
  EXPECT_EQ(listed.value[0].xray_s, 7.25);
  EXPECT_EQ(listed.value[4].loop_s, -1);
  // The north expert's runs of standard-adult, newest first, bounded.
  auto runs = store_->ListOperatorSessions("north", "standard-adult", "expert", 10);
  ASSERT_TRUE(runs.ok()) << runs.status.message;
  std::vector<std::string> uuids;
  for (const auto& r : runs.value) uuids.push_back(r.uuid);
  EXPECT_EQ(uuids, (std::vector<std::string>{"u5", "u2", "u1"}));
  EXPECT_EQ(runs.value[2].loop_s, 2.5);
  EXPECT_EQ(runs.value[2].body, "");
  auto two = store_->ListOperatorSessions("north", "standard-adult", "expert", 2);
  ASSERT_TRUE(two.ok());
  EXPECT_EQ(two.value.size(), 2u);
  EXPECT_TRUE(store_->ListOperatorSessions("south", "redundant-sigmoid", "expert", 10)
                  .value.empty());
}

TEST_P(StoreContract, TraineeActivityCountsSessionsAndTheLatestEnd) {
  ASSERT_TRUE(store_->AddTrainee({"t2", "north", "Trainee Two", 10}).ok());
  WriteBatch b;
  b.sessions = {Session("u1", "a", 300), Session("u2", "b", 100), Session("u3", "c", 200)};
  ASSERT_TRUE(store_->CommitBatch(b).ok());
  auto activity = store_->GetTraineeActivity({"t2", "t1", "nobody"});
  ASSERT_TRUE(activity.ok()) << activity.status.message;
  ASSERT_EQ(activity.value.size(), 3u);
  EXPECT_EQ(activity.value[0], (TraineeActivity{0, 0}));
  EXPECT_EQ(activity.value[1], (TraineeActivity{3, 1300}));  // Session(): end = start + 1000
  EXPECT_EQ(activity.value[2], (TraineeActivity{0, 0}));
}

TEST_P(StoreContract, SessionForUnknownTraineeFailsWholeBatch) {
  WriteBatch b;
  SessionRow orphan = Session("u9", "x", 1);
  orphan.trainee_id = "ghost";
  b.sessions = {Session("u8", "y", 1), orphan};
  EXPECT_FALSE(store_->CommitBatch(b).ok());
  EXPECT_EQ(store_->CountSessions().value, 0);  // nothing half-written
}

// What a station reports with an upload (sessions_service.cc builds it).
StationRow Report(const std::string& station, int64_t seen, const std::string& version,
                  int64_t session_end, std::optional<uint64_t> safe_states) {
  StationRow r;
  r.institution = "north";
  r.station_id = station;
  r.last_seen_unix_ms = seen;
  r.software_version = version;
  r.version_session_end_unix_ms = session_end;
  if (safe_states) {
    r.has_health = true;
    r.health_session_uuid = "s-" + std::to_string(session_end);
    r.health_session_end_unix_ms = session_end;
    r.health = {"can:can0", 600000, 412.5, 1000.0, 3, *safe_states, 2, 5, 7, 1, 4};
  }
  return r;
}

TEST_P(StoreContract, StationRowsFollowTheirUploadsInTheSameTransaction) {
  auto with = [](SessionRow row, StationRow report) {
    row.station = std::move(report);
    return row;
  };
  WriteBatch first;
  first.sessions = {with(Session("u1", "a", 1000), Report("st-1", 9000, "0.1.0", 2000, 1))};
  ASSERT_TRUE(store_->CommitBatch(first).ok());
  auto rows = store_->ListStations("north");
  ASSERT_TRUE(rows.ok()) << rows.status.message;
  ASSERT_EQ(rows.value.size(), 1u);
  EXPECT_EQ(rows.value[0], Report("st-1", 9000, "0.1.0", 2000, 1));
  EXPECT_TRUE(store_->ListStations("south").value.empty());  // per institution

  // A newer session: version and health follow it; an older one delivered
  // late (an outbox) moves only last seen.
  WriteBatch second;
  second.sessions = {with(Session("u2", "b", 3000), Report("st-1", 9500, "0.2.0", 4000, 0)),
                     with(Session("u0", "c", 100), Report("st-1", 9600, "0.0.9", 1100, 9))};
  ASSERT_TRUE(store_->CommitBatch(second).ok());
  StationRow expected = Report("st-1", 9600, "0.2.0", 4000, 0);
  ASSERT_EQ(store_->ListStations("north").value.size(), 1u);
  EXPECT_EQ(store_->ListStations("north").value[0], expected);

  // Without health: the version moves, the health stays. A conflicting
  // upload (refused) says nothing; a repeated one says the station was seen.
  WriteBatch third;
  third.sessions = {with(Session("u3", "d", 5000), Report("st-1", 9700, "0.3.0", 6000, {})),
                    with(Session("u1", "changed", 1000), Report("st-1", 99999, "9.9.9", 99999, 5)),
                    with(Session("u2", "b", 3000), Report("st-1", 9800, "0.2.0", 4000, 0))};
  auto r3 = store_->CommitBatch(third);
  ASSERT_TRUE(r3.ok());
  EXPECT_EQ(r3.value[1].outcome, SessionPut::kConflict);
  EXPECT_EQ(r3.value[2].outcome, SessionPut::kDuplicate);
  expected.last_seen_unix_ms = 9800;
  expected.software_version = "0.3.0";
  expected.version_session_end_unix_ms = 6000;
  Reopen();
  ASSERT_EQ(store_->ListStations("north").value.size(), 1u);
  EXPECT_EQ(store_->ListStations("north").value[0], expected);
}

TEST_P(StoreContract, AFailedBatchWritesNoStationRow) {
  WriteBatch b;
  SessionRow orphan = Session("u9", "x", 1);
  orphan.trainee_id = "ghost";
  SessionRow reported = Session("u8", "y", 1);
  reported.station = Report("st-1", 10, "0.1.0", 1001, 0);
  b.sessions = {reported, orphan};
  EXPECT_FALSE(store_->CommitBatch(b).ok());
  EXPECT_TRUE(store_->ListStations("north").value.empty());
}

TEST_P(StoreContract, StationsAreListedByIdAndPaged) {
  WriteBatch b;
  int n = 0;
  for (const char* id : {"st-c", "st-a", "st-b"}) {
    SessionRow row = Session(std::string("u-") + id, id, 100 * ++n);
    row.station = Report(id, 10, "0.1.0", 1000, 0);
    b.sessions.push_back(row);
  }
  ASSERT_TRUE(store_->CommitBatch(b).ok());
  ListPage page;
  page.limit = 2;
  auto first = store_->ListStations("north", page);
  ASSERT_TRUE(first.ok());
  ASSERT_EQ(first.value.size(), 2u);
  EXPECT_EQ(first.value[0].station_id, "st-a");
  EXPECT_EQ(first.value[1].station_id, "st-b");
  page.has_after = true;
  page.after_text = "st-b";
  auto rest = store_->ListStations("north", page);
  ASSERT_EQ(rest.value.size(), 1u);
  EXPECT_EQ(rest.value[0].station_id, "st-c");
}

TEST_P(StoreContract, AuditRowsGetIdsAndSessionResults) {
  WriteBatch b;
  b.sessions = {Session("u1", "a", 1), Session("u1", "b", 1)};
  AuditRow a{0, 20, "tok", "label", "station", "north", "session.upload", "u1", ""};
  b.session_audit = {a, a};
  AuditRow read{0, 30, "tok", "label", "station", "north", "case.download", "c@1", "OK"};
  b.audit = {read};
  ASSERT_TRUE(store_->CommitBatch(b).ok());
  Reopen();
  auto rows = store_->ListAudit(0, 100);
  ASSERT_TRUE(rows.ok());
  ASSERT_EQ(rows.value.size(), 3u);
  EXPECT_EQ(rows.value[0].id, 1);
  EXPECT_EQ(rows.value[0].result, "OK");
  EXPECT_EQ(rows.value[1].result, "ALREADY_EXISTS");
  EXPECT_EQ(rows.value[2].action, "case.download");
  EXPECT_EQ(store_->ListAudit(25, 100).value.size(), 1u);
  EXPECT_EQ(store_->ListAudit(0, 2).value.size(), 2u);
  // Ids continue after a reopen.
  WriteBatch more;
  more.audit = {read};
  ASSERT_TRUE(store_->CommitBatch(more).ok());
  EXPECT_EQ(store_->ListAudit(0, 100).value.back().id, 4);
}

// The audit page's listing: newest first, filtered by actor (token id or
// label), action and a time range, paged below the last id seen.
TEST_P(StoreContract, AuditIsListedNewestFirstAndFiltered) {
  WriteBatch b;
  for (int i = 0; i < 10; ++i) {
    const bool even = i % 2 == 0;
    b.audit.push_back({0, 100 + i * 10, even ? "tok-a" : "tok-b", even ? "Dr A" : "Dr B",
                       "supervisor", "north", i < 5 ? "trainee.curve" : "session.read",
                       "t" + std::to_string(i), "OK"});
  }
  ASSERT_TRUE(store_->CommitBatch(b).ok());
  auto all = store_->ListAuditNewest({});
  ASSERT_TRUE(all.ok()) << all.status.message;
  ASSERT_EQ(all.value.size(), 10u);
  EXPECT_EQ(all.value[0].target, "t9");  // newest first
  EXPECT_EQ(all.value[9].target, "t0");
  for (size_t i = 1; i < all.value.size(); ++i) EXPECT_LT(all.value[i].id, all.value[i - 1].id);

  AuditQuery by_label;
  by_label.actor = "Dr A";
  auto a = store_->ListAuditNewest(by_label).value;
  ASSERT_EQ(a.size(), 5u);
  for (const auto& row : a) EXPECT_EQ(row.actor, "tok-a");
  AuditQuery by_token;
  by_token.actor = "tok-b";
  by_token.action = "session.read";
  auto bs = store_->ListAuditNewest(by_token).value;
  ASSERT_EQ(bs.size(), 3u);  // t9, t7, t5
  EXPECT_EQ(bs[0].target, "t9");
  EXPECT_EQ(bs[2].target, "t5");
  AuditQuery range;
  range.from_unix_ms = 120;  // t2 ..
  range.to_unix_ms = 150;    // .. t4, not t5
  auto in_range = store_->ListAuditNewest(range).value;
  ASSERT_EQ(in_range.size(), 3u);
  EXPECT_EQ(in_range[0].target, "t4");
  EXPECT_EQ(in_range[2].target, "t2");

  // Pages of 3 below the last id seen give every row once, newest first.
  std::vector<std::string> walked;
  AuditQuery page;
  page.limit = 3;
  for (int n = 0; n < 10; ++n) {
    auto rows = store_->ListAuditNewest(page);
    ASSERT_TRUE(rows.ok());
    for (const auto& row : rows.value) walked.push_back(row.target);
    if (rows.value.size() < 3) break;
    page.before_id = rows.value.back().id;
  }
  EXPECT_EQ(walked,
            (std::vector<std::string>{"t9", "t8", "t7", "t6", "t5", "t4", "t3", "t2", "t1", "t0"}));
  AuditQuery nobody;
  nobody.actor = "tok-c";
  EXPECT_TRUE(store_->ListAuditNewest(nobody).value.empty());
}

// Every listing pages by its sort key (docs/server.md, "Limits"): walking the
// pages gives every row once, in order, whatever the page size.
TEST_P(StoreContract, ListingsPageByTheirSortKey) {
  WriteBatch b;
  // Starts repeat so the uuid breaks ties (start, uuid).
  for (int i = 0; i < 7; ++i) b.sessions.push_back(Session("u" + std::to_string(i), "x", i / 2));
  for (int i = 0; i < 5; ++i) {
    b.audit.push_back({0, 20, "tok", "label", "admin", "north", "a", std::to_string(i), "OK"});
  }
  ASSERT_TRUE(store_->CommitBatch(b).ok());
  for (int i = 2; i <= 5; ++i) {
    ASSERT_TRUE(store_->AddTrainee({"t" + std::to_string(i), "north", "T", 10}).ok());
  }
  for (const char* id : {"a", "b", "c"}) {
    for (uint32_t v = 1; v <= 2; ++v) {
      ASSERT_TRUE(store_->PutCase(Case(id, v, std::string(id) + std::to_string(v)), "x").ok());
    }
  }
  for (int size = 1; size <= 3; ++size) {
    SCOPED_TRACE("page size " + std::to_string(size));
    std::vector<std::string> uuids;
    ListPage page;
    page.limit = size;
    for (;;) {
      auto rows = store_->ListSessions("t1", "", page);
      ASSERT_TRUE(rows.ok());
      for (const auto& r : rows.value) uuids.push_back(r.uuid);
      if (static_cast<int>(rows.value.size()) < size) break;
      page.has_after = true;
      page.after_number = rows.value.back().start_unix_ms;
      page.after_text = rows.value.back().uuid;
    }
    EXPECT_EQ(uuids, (std::vector<std::string>{"u0", "u1", "u2", "u3", "u4", "u5", "u6"}));

    std::vector<std::string> trainees;
    page = {};
    page.limit = size;
    for (;;) {
      auto rows = store_->ListTrainees("north", page);
      for (const auto& r : rows.value) trainees.push_back(r.trainee_id);
      if (static_cast<int>(rows.value.size()) < size) break;
      page.has_after = true;
      page.after_text = rows.value.back().trainee_id;
    }
    EXPECT_EQ(trainees, (std::vector<std::string>{"t1", "t2", "t3", "t4", "t5"}));

    for (bool all : {false, true}) {
      std::vector<std::string> cases;
      CaseFilter f;
      f.all_versions = all;
      f.page.limit = size;
      for (;;) {
        auto rows = store_->ListCases(f);
        for (const auto& r : rows.value) cases.push_back(r.case_id + std::to_string(r.version));
        if (static_cast<int>(rows.value.size()) < size) break;
        f.page.has_after = true;
        f.page.after_text = rows.value.back().case_id;
        f.page.after_number = rows.value.back().version;
      }
      const std::vector<std::string> every = {"a1", "a2", "b1", "b2", "c1", "c2"};
      const std::vector<std::string> latest = {"a2", "b2", "c2"};
      EXPECT_EQ(cases, all ? every : latest);
    }

    std::vector<int64_t> ids;
    int64_t after = 0;
    for (;;) {
      auto rows = store_->ListAudit(0, size, after);
      for (const auto& r : rows.value) ids.push_back(r.id);
      if (static_cast<int>(rows.value.size()) < size) break;
      after = rows.value.back().id;
    }
    EXPECT_EQ(ids.size(), 5u);
    EXPECT_TRUE(std::is_sorted(ids.begin(), ids.end()));
  }
}

// The web pages' series of a session (docs/web.md): stored once, read back
// byte for byte (binary-safe, large), replaced by a newer computation, kept
// across a reopen, refused for a session that is not stored and over the bound.
TEST_P(StoreContract, SessionSeriesAreStoredReadBackAndBounded) {
  WriteBatch b;
  b.sessions.push_back(Session("s-series", "body", 100));
  ASSERT_TRUE(store_->CommitBatch(b).ok());
  EXPECT_EQ(store_->GetSessionSeries("s-series").status.code, StoreCode::kNotFound);

  std::string json = "{\"frames\": [";
  while (json.size() < 900'000) json += "{\"t_s\": 0.1, \"x\": \"\\u0000\"},";
  json += std::string("\0\xff", 2) + "]}";
  SessionSeriesRow row{"s-series", 1, 1234, json};
  ASSERT_TRUE(store_->PutSessionSeries(row).ok());
  auto got = store_->GetSessionSeries("s-series");
  ASSERT_TRUE(got.ok()) << got.status.message;
  EXPECT_EQ(got.value, row);

  SessionSeriesRow newer{"s-series", 2, 5678, "{\"v\": 2}"};
  ASSERT_TRUE(store_->PutSessionSeries(newer).ok());
  Reopen();
  got = store_->GetSessionSeries("s-series");
  ASSERT_TRUE(got.ok()) << got.status.message;
  EXPECT_EQ(got.value, newer);

  EXPECT_EQ(store_->PutSessionSeries({"no-such-session", 1, 1, "{}"}).code, StoreCode::kNotFound);
  EXPECT_EQ(store_->GetSessionSeries("no-such-session").status.code, StoreCode::kNotFound);
  const StoreStatus big =
      store_->PutSessionSeries({"s-series", 3, 1, std::string(kMaxSessionSeriesBytes + 1, 'x')});
  EXPECT_EQ(big.code, StoreCode::kInvalidArgument);
  EXPECT_NE(big.message.find("bytes"), std::string::npos) << big.message;
  EXPECT_EQ(store_->PutSessionSeries({"s-series", 3, 1, ""}).code, StoreCode::kInvalidArgument);
  EXPECT_EQ(store_->GetSessionSeries("s-series").value, newer);  // the refusals changed nothing
}

TEST_P(StoreContract, SessionNotesAreKeptInOrderAndBounded) {
  WriteBatch b;
  b.sessions.push_back(Session("s-notes", "body", 100));
  b.sessions.push_back(Session("s-other", "body2", 200));
  ASSERT_TRUE(store_->CommitBatch(b).ok());
  auto none = store_->ListSessionNotes("s-notes", 10);
  ASSERT_TRUE(none.ok()) << none.status.message;
  EXPECT_TRUE(none.value.empty());

  const SessionNoteRow later{"n-b", "s-notes", "tok-1", "Dr. Ng", 2000,
                             "Loop at the splenic flexure.\nRetry with torque."};
  const SessionNoteRow earlier{"n-a", "s-notes", "tok-2", "Dr. \xc3\x98ster", 1000, "Good start"};
  ASSERT_TRUE(store_->AddSessionNote(later).ok());
  ASSERT_TRUE(store_->AddSessionNote(earlier).ok());
  ASSERT_TRUE(store_->AddSessionNote({"n-c", "s-other", "tok-1", "Dr. Ng", 1500, "other"}).ok());
  Reopen();
  auto notes = store_->ListSessionNotes("s-notes", 10);
  ASSERT_TRUE(notes.ok()) << notes.status.message;
  EXPECT_EQ(notes.value, (std::vector<SessionNoteRow>{earlier, later}));  // oldest first
  EXPECT_EQ(store_->ListSessionNotes("s-notes", 1).value, std::vector<SessionNoteRow>{earlier});

  EXPECT_EQ(store_->AddSessionNote({"n-a", "s-notes", "t", "l", 3000, "again"}).code,
            StoreCode::kAlreadyExists);
  EXPECT_EQ(store_->AddSessionNote({"n-x", "no-such-session", "t", "l", 1, "x"}).code,
            StoreCode::kNotFound);
  const StoreStatus big = store_->AddSessionNote(
      {"n-big", "s-notes", "t", "l", 1, std::string(kMaxSessionNoteBytes + 1, 'x')});
  EXPECT_EQ(big.code, StoreCode::kInvalidArgument);
  EXPECT_NE(big.message.find("note text"), std::string::npos) << big.message;
  EXPECT_EQ(store_->AddSessionNote({"n-e", "s-notes", "t", "l", 1, ""}).code,
            StoreCode::kInvalidArgument);
  EXPECT_EQ(store_->AddSessionNote({"n-z", "s-notes", "t", "l", 1, std::string("a\0b", 3)}).code,
            StoreCode::kInvalidArgument);
  EXPECT_TRUE(store_->AddSessionNote(
                        {"n-max", "s-notes", "t", "l", 9000, std::string(kMaxSessionNoteBytes, 'y')})
                  .ok());
  EXPECT_EQ(store_->ListSessionNotes("s-notes", 10).value.size(), 3u);  // refusals wrote nothing
}

TEST_P(StoreContract, ASessionIsSignedOffOnceAndListedForItsTrainee) {
  ASSERT_TRUE(store_->AddTrainee({"t2", "north", "Trainee Two", 10}).ok());
  WriteBatch b;
  b.sessions.push_back(Session("s-sign", "body", 100));
  b.sessions.push_back(Session("s-open", "body2", 200));
  SessionRow theirs = Session("s-t2", "body3", 300);
  theirs.trainee_id = "t2";
  b.sessions.push_back(theirs);
  ASSERT_TRUE(store_->CommitBatch(b).ok());
  EXPECT_EQ(store_->GetSessionSignOff("s-sign").status.code, StoreCode::kNotFound);

  const SessionSignOffRow first{"s-sign", "tok-1", "Dr. Ng", 5000};
  auto put = store_->SignOffSession(first);
  ASSERT_TRUE(put.ok()) << put.status.message;
  EXPECT_TRUE(put.value);
  put = store_->SignOffSession({"s-sign", "tok-2", "Dr. Other", 6000});
  ASSERT_TRUE(put.ok()) << put.status.message;
  EXPECT_FALSE(put.value);  // the first sign-off is kept
  ASSERT_TRUE(store_->SignOffSession({"s-t2", "tok-1", "Dr. Ng", 7000}).ok());
  EXPECT_EQ(store_->SignOffSession({"no-such-session", "t", "l", 1}).status.code,
            StoreCode::kNotFound);
  Reopen();
  auto got = store_->GetSessionSignOff("s-sign");
  ASSERT_TRUE(got.ok()) << got.status.message;
  EXPECT_EQ(got.value, first);
  EXPECT_EQ(store_->GetSessionSignOff("s-open").status.code, StoreCode::kNotFound);
  auto listed = store_->ListTraineeSignOffs("t1");
  ASSERT_TRUE(listed.ok()) << listed.status.message;
  EXPECT_EQ(listed.value, std::vector<SessionSignOffRow>{first});
  listed = store_->ListTraineeSignOffs("t2");
  ASSERT_EQ(listed.value.size(), 1u);
  EXPECT_EQ(listed.value[0].session_uuid, "s-t2");
  EXPECT_TRUE(store_->ListTraineeSignOffs("nobody").value.empty());
}

INSTANTIATE_TEST_SUITE_P(
    Backends, StoreContract,
    ::testing::Values(Backend{"sqlite",
                              [](const std::filesystem::path& dir) -> std::unique_ptr<Store> {
                                return OpenStore("sqlite:" + (dir / "ves.db").string());
                              }}),
    [](const ::testing::TestParamInfo<Backend>& info) { return info.param.name; });

// SQLite specifics: the migration runs once and the settings are the durable ones.
TEST(SqliteStore, MigratesOnceAndRecordsVersion) {
  const auto path = std::filesystem::temp_directory_path() /
                    ("ves_migrate_" + std::to_string(::getpid()) + ".db");
  std::filesystem::remove(path);
  {
    SqliteStore first(path.string());
    EXPECT_EQ(first.schema_version(), SqlMigrations().back().version);
  }
  SqliteStore second(path.string());  // a second open must not re-run CREATE TABLE
  EXPECT_EQ(second.schema_version(), SqlMigrations().back().version);
  SqliteDb db(path.string());
  std::string error;
  auto* s = db.Prepare("PRAGMA journal_mode", &error);
  ASSERT_NE(s, nullptr) << error;
  int rc = 0;
  ASSERT_TRUE(s->Step(&rc));
  EXPECT_EQ(s->Text(0), "wal");
  s = db.Prepare("PRAGMA synchronous", &error);
  ASSERT_TRUE(s->Step(&rc));
  EXPECT_EQ(s->Int(0), 2);  // FULL
  s = db.Prepare("PRAGMA foreign_keys", &error);
  ASSERT_TRUE(s->Step(&rc));
  EXPECT_EQ(s->Int(0), 1);
  std::filesystem::remove(path);
}

// A database an older server (schema 4) left: opening it applies migration 5
// (stations) and keeps what was stored; uploads then report their station.
TEST(SqliteStore, MigrationFiveAddsStationsToAnOlderDatabase) {
  const auto path = std::filesystem::temp_directory_path() /
                    ("ves_migrate5_" + std::to_string(::getpid()) + ".db");
  std::filesystem::remove(path);
  {
    SqliteDb db(path.string());
    std::string error;
    ASSERT_TRUE(
        db.Exec("CREATE TABLE schema_migrations (version INTEGER PRIMARY KEY, "
                "description TEXT NOT NULL, applied_unix_ms BIGINT NOT NULL)",
                &error))
        << error;
    for (const Migration& m : SqlMigrations()) {
      if (m.version > 4) break;
      ASSERT_TRUE(db.Exec(m.sql, &error)) << error;
      ASSERT_TRUE(db.Exec(
          "INSERT INTO schema_migrations VALUES (" + std::to_string(m.version) + ", 'old', 1)",
          &error))
          << error;
    }
    ASSERT_TRUE(
        db.Exec("INSERT INTO institutions (name, created_unix_ms) VALUES ('north', 1)", &error))
        << error;
    ASSERT_TRUE(db.Exec("SELECT * FROM stations", &error) == false);  // not there yet
  }
  SqliteStore store(path.string());
  EXPECT_EQ(store.schema_version(), SqlMigrations().back().version);  // 5 and every later one
  ASSERT_TRUE(store.HasInstitution("north").value);
  ASSERT_TRUE(store.AddTrainee({"t1", "north", "T", 1}).ok());
  SessionRow row;
  row.uuid = "u1";
  row.trainee_id = "t1";
  row.institution = "north";
  row.case_id = "c";
  row.case_version = 1;
  row.station_id = "st-1";
  row.body_sha256_hex = "h";
  row.body = "b";
  StationRow report;
  report.institution = "north";
  report.station_id = "st-1";
  report.last_seen_unix_ms = 7;
  report.software_version = "0.1.0";
  row.station = report;
  WriteBatch b;
  b.sessions = {row};
  ASSERT_TRUE(store.CommitBatch(b).ok());
  ASSERT_EQ(store.ListStations("north").value.size(), 1u);
  EXPECT_EQ(store.ListStations("north").value[0], report);
  std::filesystem::remove(path);
}

// A database of schema 6 with a session stored: migration 7 reads that
// session's loop and X-ray time back as not known (-1), not as 0 s, and
// keeps the figures of sessions stored after it.
TEST(SqliteStore, MigrationSevenLeavesOlderSessionsLoopAndXrayTimeUnknown) {
  const auto path = std::filesystem::temp_directory_path() /
                    ("ves_migrate7_" + std::to_string(::getpid()) + ".db");
  std::filesystem::remove(path);
  {
    SqliteDb db(path.string());
    std::string error;
    ASSERT_TRUE(
        db.Exec("CREATE TABLE schema_migrations (version INTEGER PRIMARY KEY, "
                "description TEXT NOT NULL, applied_unix_ms BIGINT NOT NULL)",
                &error))
        << error;
    for (const Migration& m : SqlMigrations()) {
      if (m.version > 6) break;
      ASSERT_TRUE(db.Exec(m.sql, &error)) << error;
      ASSERT_TRUE(db.Exec(
          "INSERT INTO schema_migrations VALUES (" + std::to_string(m.version) + ", 'old', 1)",
          &error))
          << error;
    }
    for (const char* sql :
         {"INSERT INTO institutions (name, created_unix_ms) VALUES ('north', 1)",
          "INSERT INTO trainees (trainee_id, institution, display_name, created_unix_ms) "
          "VALUES ('t1', 'north', 'T', 1)",
          "INSERT INTO sessions (uuid, trainee_id, institution, case_id, case_version, "
          "station_id, start_unix_ms, end_unix_ms, outcome, completed, time_to_cecum_s, pain_s, "
          "score, body_sha256_hex, stored_unix_ms, body, operator_kind, max_tip_arc_m) VALUES "
          "('old', 't1', 'north', 'c', 1, 'st', 10, 20, 1, 1, 5, 1, 50, 'h', 30, x'00', "
          "'expert', 0.5)"}) {
      ASSERT_TRUE(db.Exec(sql, &error)) << error;
    }
  }
  SqliteStore store(path.string());
  auto old = store.GetSession("old");
  ASSERT_TRUE(old.ok()) << old.status.message;
  EXPECT_EQ(old.value.loop_s, -1);
  EXPECT_EQ(old.value.xray_s, -1);
  EXPECT_EQ(old.value.score, 50);
  SessionRow row;
  row.uuid = "new";
  row.trainee_id = "t1";
  row.institution = "north";
  row.case_id = "c";
  row.case_version = 1;
  row.operator_kind = "expert";
  row.start_unix_ms = 40;
  row.loop_s = 3.5;
  row.xray_s = 0;
  row.body_sha256_hex = "h2";
  row.body = "b";
  WriteBatch b;
  b.sessions = {row};
  ASSERT_TRUE(store.CommitBatch(b).ok());
  auto runs = store.ListOperatorSessions("north", "c", "expert", 10);
  ASSERT_TRUE(runs.ok()) << runs.status.message;
  ASSERT_EQ(runs.value.size(), 2u);
  EXPECT_EQ(runs.value[0].uuid, "new");
  EXPECT_EQ(runs.value[0].loop_s, 3.5);
  EXPECT_EQ(runs.value[0].xray_s, 0);
  EXPECT_EQ(runs.value[1].loop_s, -1);
  std::filesystem::remove(path);
}

TEST(OpenStore, UnknownSchemeIsRefused) {
  EXPECT_THROW(OpenStore("mysql://x"), std::invalid_argument);
}

}  // namespace
}  // namespace ves::patient_db
