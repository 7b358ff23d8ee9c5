// The lesson part of the storage contract (docs/lessons.md), on SQLite and,
// when deploy/with-postgres.sh provides a cluster, on PostgreSQL.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include "patient_db/store.h"
#include "tests/patient_db/pg_test_util.h"

namespace ves::patient_db {
namespace {

struct LessonBackend {
  std::string name;
  std::function<std::unique_ptr<Store>(const std::filesystem::path& dir)> open;
};

void PrintTo(const LessonBackend& backend, std::ostream* os) { *os << backend.name; }

class LessonStore : public ::testing::TestWithParam<LessonBackend> {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("ves_lesson_store_" + GetParam().name + "_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    store_ = GetParam().open(dir_);
    ASSERT_TRUE(store_->AddInstitution("north", 1).ok());
    ASSERT_TRUE(store_->AddInstitution("south", 1).ok());
    ASSERT_TRUE(store_->AddTrainee({"t1", "north", "One", 10}).ok());
    ASSERT_TRUE(store_->AddTrainee({"t2", "north", "Two", 10}).ok());
    ASSERT_TRUE(store_->AddTrainee({"s1", "south", "South", 10}).ok());
  }
  void TearDown() override {
    store_.reset();
    std::filesystem::remove_all(dir_);
  }
  void Reopen() {
    store_.reset();
    store_ = GetParam().open(dir_);
  }

  static CurriculumRow Curriculum(const std::string& id, const std::string& body,
                                  std::vector<std::string> lessons) {
    CurriculumRow c;
    c.curriculum_id = id;
    c.institution = "north";
    c.title = "Title of " + id;
    c.lesson_ids = std::move(lessons);
    c.created_by = "tok";
    c.created_unix_ms = 100;
    c.body = body;
    c.body_sha256_hex = "sha-" + body;
    return c;
  }

  // A stored session of `trainee` (t1); lesson_id non-empty queues it for judging.
  void StoreSession(const std::string& uuid, const std::string& lesson_id, int64_t start,
                    const std::string& trainee = "t1") {
    SessionRow r;
    r.uuid = uuid;
    r.trainee_id = trainee;
    r.institution = "north";
    r.case_id = "c";
    r.case_version = 1;
    r.station_id = "st";
    r.start_unix_ms = start;
    r.end_unix_ms = start + 1;
    r.body = "body-" + uuid;
    r.body_sha256_hex = "h-" + uuid;
    r.stored_unix_ms = start;
    r.lesson_id = lesson_id;
    WriteBatch batch;
    batch.sessions.push_back(r);
    auto result = store_->CommitBatch(batch);
    ASSERT_TRUE(result.ok()) << result.status.message;
  }

  std::filesystem::path dir_;
  std::unique_ptr<Store> store_;
};

TEST_P(LessonStore, CurriculumRoundTripsAndIsImmutable) {
  const CurriculumRow c = Curriculum("basics", "B1", {"l1", "l2"});
  auto put = store_->PutCurriculum(c);
  ASSERT_TRUE(put.ok()) << put.status.message;
  EXPECT_FALSE(put.value);  // newly stored
  auto again = store_->PutCurriculum(c);
  ASSERT_TRUE(again.ok());
  EXPECT_TRUE(again.value);  // the same content: already stored
  auto other = store_->PutCurriculum(Curriculum("basics", "B2", {"l1", "l2"}));
  EXPECT_EQ(other.status.code, StoreCode::kAlreadyExists);
  Reopen();
  auto got = store_->GetCurriculum("basics");
  ASSERT_TRUE(got.ok()) << got.status.message;
  EXPECT_EQ(got.value, c);
  EXPECT_EQ(store_->GetCurriculum("nope").status.code, StoreCode::kNotFound);
  auto found = store_->FindLessonCurriculum("l2");
  ASSERT_TRUE(found.ok());
  EXPECT_EQ(found.value, "basics");
}

TEST_P(LessonStore, ALessonIdBelongsToOneCurriculumOnly) {
  ASSERT_TRUE(store_->PutCurriculum(Curriculum("a", "A", {"l1"})).ok());
  auto clash = store_->PutCurriculum(Curriculum("b", "B", {"l9", "l1"}));
  EXPECT_EQ(clash.status.code, StoreCode::kAlreadyExists);
  EXPECT_NE(clash.status.message.find("l1"), std::string::npos) << clash.status.message;
  // Nothing of the refused curriculum was kept.
  EXPECT_EQ(store_->GetCurriculum("b").status.code, StoreCode::kNotFound);
  EXPECT_EQ(store_->FindLessonCurriculum("l9").status.code, StoreCode::kNotFound);
  auto list = store_->ListCurricula("north");
  ASSERT_TRUE(list.ok());
  ASSERT_EQ(list.value.size(), 1u);
  EXPECT_TRUE(store_->ListCurricula("south").value.empty());
}

TEST_P(LessonStore, AssignmentsReachTraineesDirectlyAndThroughTheirGroup) {
  ASSERT_TRUE(store_->PutCurriculum(Curriculum("a", "A", {"l1"})).ok());
  ASSERT_TRUE(store_->PutCurriculum(Curriculum("b", "B", {"l2"})).ok());
  ASSERT_TRUE(store_->SetTraineeGroup("t1", "residents").ok());
  ASSERT_TRUE(store_->SetTraineeGroup("t2", "residents").ok());
  ASSERT_TRUE(store_->AddAssignment({"a", true, "residents", "north", "tok", 200}).ok());
  ASSERT_TRUE(store_->AddAssignment({"b", false, "t1", "north", "tok", 300}).ok());
  ASSERT_TRUE(store_->AddAssignment({"b", false, "t1", "north", "tok", 400}).ok());  // again
  // A group of the same name in another institution is another group.
  ASSERT_TRUE(store_->SetTraineeGroup("s1", "residents").ok());
  // Curricula come in pages by id (docs/server.md, "Limits").
  ListPage page;
  page.limit = 1;
  auto first = store_->ListCurricula("north", page);
  ASSERT_EQ(first.value.size(), 1u);
  EXPECT_EQ(first.value[0].curriculum_id, "a");
  page.has_after = true;
  page.after_text = "a";
  auto second = store_->ListCurricula("north", page);
  ASSERT_EQ(second.value.size(), 1u);
  EXPECT_EQ(second.value[0].curriculum_id, "b");
  page.after_text = "b";
  EXPECT_TRUE(store_->ListCurricula("north", page).value.empty());

  auto t1 = store_->ListAssignments("t1");
  ASSERT_TRUE(t1.ok()) << t1.status.message;
  ASSERT_EQ(t1.value.size(), 2u);
  EXPECT_EQ(t1.value[0].curriculum_id, "a");
  EXPECT_TRUE(t1.value[0].to_group);
  EXPECT_EQ(t1.value[1].curriculum_id, "b");
  EXPECT_EQ(t1.value[1].assigned_unix_ms, 300);  // the first assignment is kept
  EXPECT_EQ(store_->ListAssignments("t2").value.size(), 1u);
  EXPECT_TRUE(store_->ListAssignments("s1").value.empty());

  auto members = store_->ListGroupTrainees("north", "residents");
  ASSERT_TRUE(members.ok());
  EXPECT_EQ(members.value, (std::vector<std::string>{"t1", "t2"}));
  ASSERT_TRUE(store_->SetTraineeGroup("t2", "").ok());
  EXPECT_EQ(store_->GetTraineeGroup("t2").value, "");
  EXPECT_EQ(store_->GetTraineeGroup("t1").value, "residents");
  EXPECT_EQ(store_->ListGroupTrainees("north", "residents").value.size(), 1u);
  EXPECT_FALSE(store_->SetTraineeGroup("ghost", "x").ok());
  EXPECT_FALSE(store_->AddAssignment({"ghost", false, "t1", "north", "tok", 1}).ok());
}

TEST_P(LessonStore, LessonSessionsWaitForOneVerdictEach) {
  StoreSession("u1", "l1", 1000);
  StoreSession("u2", "", 2000);  // not a lesson: never queued
  StoreSession("u3", "l1", 3000);
  auto unjudged = store_->ListUnjudgedLessonSessions("", 100);
  ASSERT_TRUE(unjudged.ok()) << unjudged.status.message;
  EXPECT_EQ(unjudged.value, (std::vector<std::string>{"u1", "u3"}));

  LessonVerdictRow v{"u3", "t1", "a", "l1", true, 55.5, 3000, 4000, "pain_s ok"};
  auto put = store_->PutLessonVerdict(v);
  ASSERT_TRUE(put.ok()) << put.status.message;
  EXPECT_TRUE(put.value);
  LessonVerdictRow later = v;
  later.passed = false;
  EXPECT_FALSE(store_->PutLessonVerdict(later).value);  // the first verdict stays
  Reopen();
  auto got = store_->GetLessonVerdict("u3");
  ASSERT_TRUE(got.ok());
  EXPECT_EQ(got.value, v);
  EXPECT_EQ(store_->ListUnjudgedLessonSessions("t1", 100).value,
            (std::vector<std::string>{"u1"}));
  EXPECT_TRUE(store_->ListUnjudgedLessonSessions("t2", 100).value.empty());
  ASSERT_TRUE(store_->PutLessonVerdict({"u1", "t1", "a", "l1", false, 5, 1000, 5000, "x"}).ok());
  auto all = store_->ListLessonVerdicts("t1");
  ASSERT_TRUE(all.ok());
  ASSERT_EQ(all.value.size(), 2u);
  EXPECT_EQ(all.value[0].session_uuid, "u1");  // oldest session first
  EXPECT_EQ(store_->GetLessonVerdict("u2").status.code, StoreCode::kNotFound);
  EXPECT_FALSE(store_->PutLessonVerdict({"ghost", "t1", "a", "l1", true, 1, 1, 1, ""}).ok());
}

// The trainee list reads a page's groups, assignments and verdicts in one
// read each: for every listed id, in order, the same as the per-trainee reads.
TEST_P(LessonStore, BatchedReadsGiveWhatEachTraineesReadGives) {
  ASSERT_TRUE(store_->AddTrainee({"t3", "north", "Three", 10}).ok());
  ASSERT_TRUE(store_->PutCurriculum(Curriculum("a", "A", {"l1"})).ok());
  ASSERT_TRUE(store_->PutCurriculum(Curriculum("b", "B", {"l2"})).ok());
  ASSERT_TRUE(store_->SetTraineeGroup("t1", "residents").ok());
  ASSERT_TRUE(store_->SetTraineeGroup("t2", "fellows").ok());
  ASSERT_TRUE(store_->SetTraineeGroup("s1", "residents").ok());  // another institution's group
  ASSERT_TRUE(store_->AddAssignment({"b", true, "residents", "north", "tok", 500}).ok());
  ASSERT_TRUE(store_->AddAssignment({"a", false, "t1", "north", "tok", 200}).ok());
  ASSERT_TRUE(store_->AddAssignment({"a", true, "fellows", "north", "tok", 300}).ok());
  ASSERT_TRUE(store_->AddAssignment({"b", false, "t2", "north", "tok", 300}).ok());
  StoreSession("u3", "l1", 3000);
  StoreSession("u1", "l1", 1000);
  StoreSession("u2", "l2", 2000, "t2");
  StoreSession("u4", "l2", 2000, "t1");
  ASSERT_TRUE(store_->PutLessonVerdict({"u3", "t1", "a", "l1", true, 80, 3000, 3100, "ok"}).ok());
  ASSERT_TRUE(store_->PutLessonVerdict({"u1", "t1", "a", "l1", false, 20, 1000, 1100, "x"}).ok());
  ASSERT_TRUE(store_->PutLessonVerdict({"u4", "t1", "b", "l2", true, 60, 2000, 2100, "ok"}).ok());
  ASSERT_TRUE(store_->PutLessonVerdict({"u2", "t2", "b", "l2", true, 70, 2000, 2200, "ok"}).ok());

  // Unordered, with a trainee of no group, one of another institution, an
  // unknown id and one listed twice.
  const std::vector<std::string> ids = {"t2", "ghost", "t1", "t3", "s1", "t1"};
  auto groups = store_->GetTraineeGroups(ids);
  ASSERT_TRUE(groups.ok()) << groups.status.message;
  auto assignments = store_->ListAssignmentsOf(ids);
  ASSERT_TRUE(assignments.ok()) << assignments.status.message;
  auto verdicts = store_->ListLessonVerdictsOf(ids);
  ASSERT_TRUE(verdicts.ok()) << verdicts.status.message;
  ASSERT_EQ(groups.value.size(), ids.size());
  ASSERT_EQ(assignments.value.size(), ids.size());
  ASSERT_EQ(verdicts.value.size(), ids.size());
  for (size_t i = 0; i < ids.size(); ++i) {
    SCOPED_TRACE(ids[i]);
    EXPECT_EQ(groups.value[i], store_->GetTraineeGroup(ids[i]).value);
    EXPECT_EQ(assignments.value[i], store_->ListAssignments(ids[i]).value);
    EXPECT_EQ(verdicts.value[i], store_->ListLessonVerdicts(ids[i]).value);
  }
  // What the per-trainee reads give, so that the comparison above is not of empties.
  EXPECT_EQ(groups.value,
            (std::vector<std::string>{"fellows", "", "residents", "", "residents", "residents"}));
  ASSERT_EQ(assignments.value[2].size(), 2u);  // t1: its own "a" (200), its group's "b" (500)
  EXPECT_EQ(assignments.value[2][0].curriculum_id, "a");
  EXPECT_EQ(assignments.value[2][1].curriculum_id, "b");
  EXPECT_EQ(assignments.value[0].size(), 2u);  // t2: "a" by group, "b" directly, both at 300
  EXPECT_TRUE(assignments.value[4].empty());   // s1's "residents" is south's group
  ASSERT_EQ(verdicts.value[2].size(), 3u);     // t1, oldest session first
  EXPECT_EQ(verdicts.value[2][0].session_uuid, "u1");
  EXPECT_EQ(verdicts.value[2][2].session_uuid, "u3");
  EXPECT_EQ(verdicts.value[0].size(), 1u);
  EXPECT_TRUE(verdicts.value[1].empty());
  EXPECT_TRUE(store_->ListLessonVerdictsOf({}).value.empty());
}

// The group's cohort page reads its members' sessions in a range in one
// read: for every listed id, in order, what ListSessions gives from `from`
// on, cut at `to`, at most limit + 1.
TEST_P(LessonStore, BatchedSessionReadGivesWhatEachTraineesListingGives) {
  StoreSession("u5", "", 5000);
  StoreSession("u3", "l1", 3000);
  StoreSession("u1", "", 1000);
  StoreSession("u2b", "l2", 2000);  // two at the same start: uuid order
  StoreSession("u2a", "", 2000);
  StoreSession("v2", "l1", 2000, "t2");
  StoreSession("v9", "", 9000, "t2");
  StoreSession("w1", "", 1000, "s1");
  auto each = [&](const std::string& id, int64_t from, int64_t to, int limit) {
    ListPage page;
    page.has_after = from > 0;
    page.after_number = from;
    page.limit = limit + 1;
    std::vector<SessionRow> rows = store_->ListSessions(id, "", page).value;
    std::erase_if(rows, [&](const SessionRow& r) { return to != 0 && r.start_unix_ms >= to; });
    return rows;
  };
  const std::vector<std::string> ids = {"t2", "ghost", "t1", "s1", "t1"};
  struct Range {
    int64_t from, to;
    int limit;
  };
  for (const Range& r : {Range{0, 0, 100}, Range{2000, 5000, 100}, Range{1500, 0, 2},
                         Range{9001, 0, 100}}) {
    SCOPED_TRACE(std::to_string(r.from) + ".." + std::to_string(r.to));
    auto batched = store_->ListSessionsOf(ids, r.from, r.to, r.limit);
    ASSERT_TRUE(batched.ok()) << batched.status.message;
    ASSERT_EQ(batched.value.size(), ids.size());
    for (size_t i = 0; i < ids.size(); ++i) {
      SCOPED_TRACE(ids[i]);
      EXPECT_EQ(batched.value[i], each(ids[i], r.from, r.to, r.limit));
    }
  }
  // What the per-trainee reads give, so that the comparison above is not of empties.
  auto uuids = [](const std::vector<SessionRow>& rows) {
    std::vector<std::string> out;
    for (const auto& r : rows) out.push_back(r.uuid);
    return out;
  };
  auto all = store_->ListSessionsOf(ids, 0, 0, 100).value;
  EXPECT_EQ(uuids(all[2]), (std::vector<std::string>{"u1", "u2a", "u2b", "u3", "u5"}));
  EXPECT_EQ(all[2][2].lesson_id, "l2");
  EXPECT_EQ(uuids(all[0]), (std::vector<std::string>{"v2", "v9"}));
  EXPECT_TRUE(all[1].empty());
  auto range = store_->ListSessionsOf(ids, 2000, 5000, 100).value;
  EXPECT_EQ(uuids(range[2]), (std::vector<std::string>{"u2a", "u2b", "u3"}));
  auto capped = store_->ListSessionsOf(ids, 1500, 0, 2).value;
  EXPECT_EQ(uuids(capped[2]), (std::vector<std::string>{"u2a", "u2b", "u3"}));  // limit + 1
  EXPECT_TRUE(store_->ListSessionsOf({}, 0, 0, 100).value.empty());
}

INSTANTIATE_TEST_SUITE_P(
    Backends, LessonStore,
    ::testing::Values(LessonBackend{"sqlite",
                                    [](const std::filesystem::path& dir) -> std::unique_ptr<Store> {
                                      return OpenStore("sqlite:" + (dir / "ves.db").string());
                                    }},
                      LessonBackend{"postgres", &pg_testing::OpenPostgresTestStore}),
    [](const ::testing::TestParamInfo<LessonBackend>& info) { return info.param.name; });

}  // namespace
}  // namespace ves::patient_db
