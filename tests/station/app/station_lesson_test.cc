// `ves-station run --lesson next` with real processes (docs/lessons.md): the
// shipped curriculum created and assigned with ves-admin, scripted trainees
// at headless stations, verdicts from the server's replay, a case that fails
// verification refused before the run, and an offline lesson whose verdict
// arrives on reconnect.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>

#include "patient_db/case_format.h"
#include "tests/station/app/station_fixture.h"

namespace ves::station::testing {
namespace {

namespace fs = std::filesystem;

constexpr char kFirstLesson[] = "x-ray-free-1-gentle-minute";
const std::string kCurriculumFile = VES_SOURCE_DIR "/patient_db/curricula/x-ray-free.textproto";
const std::string kCasesDir = VES_SOURCE_DIR "/patient_db/cases/";

class StationLesson : public StationFixture {
 protected:
  void SetUp() override {
    StationFixture::SetUp();
    if (HasFatalFailure()) return;
    for (const char* c : {"paper-sigmoid", "standard-adult", "mobile-descending", "redundant-sigmoid"}) {
      const ProcessResult up = AsAdmin({"case", "upload", kCasesDir + c + ".textproto"});
      ASSERT_EQ(up.exit_code, 0) << up.err;
    }
    const ProcessResult created = AsSupervisor({"curriculum", "create", kCurriculumFile});
    ASSERT_EQ(created.exit_code, 0) << created.err;
    ASSERT_EQ(AsSupervisor({"group", "set", "--trainee", kTrainee, "--group", "residents"})
                  .exit_code,
              0);
    const ProcessResult assigned =
        AsSupervisor({"assign", "--curriculum", "x-ray-free", "--group", "residents"});
    ASSERT_EQ(assigned.exit_code, 0) << assigned.err;
  }

  ProcessResult AsAdmin(std::vector<std::string> args) {
    args.insert(args.end(), {"--server", address_, "--token", admin_token_});
    return Admin(args);
  }
  ProcessResult AsSupervisor(std::vector<std::string> args) {
    args.insert(args.end(), {"--server", address_, "--token", supervisor_token_});
    return Admin(args);
  }

  // A headless lesson run; `seconds` empty: the lesson's own limit.
  std::vector<std::string> LessonArgs(const std::string& trainee, const std::string& operator_kind,
                                      const fs::path& data, const std::string& out,
                                      bool with_server, const std::string& seconds = "") {
    std::vector<std::string> args = {"run", "--trainee", trainee, "--lesson", "next",
                                     "--headless", "--operator", operator_kind,
                                     "--out", (dir_ / out).string(), "--data-dir", data.string(),
                                     "--frame-every-s", "1000"};
    if (!seconds.empty()) args.insert(args.end(), {"--seconds", seconds});
    if (with_server) args.insert(args.end(), {"--server", address_, "--token", station_token_});
    return args;
  }
};

// The lesson row of `ves-admin progress --trainee` for the first lesson.
std::string FirstLessonRow(const std::string& progress_out) {
  std::istringstream lines(progress_out);
  for (std::string line; std::getline(lines, line);) {
    if (line.find(kFirstLesson) != std::string::npos) return line;
  }
  return "";
}

TEST_F(StationLesson, ExpertPassesTheFirstLessonNoviceDoesNotAndProgressShowsIt) {
  ASSERT_EQ(AsAdmin({"trainee", "add", "--id", "trainee-8"}).exit_code, 0);
  ASSERT_EQ(AsSupervisor({"group", "set", "--trainee", "trainee-8", "--group", "residents"})
                .exit_code,
            0);

  const ProcessResult expert =
      Station(LessonArgs(kTrainee, "expert", dir_ / "station-a", "out-expert", true));
  ASSERT_TRUE(expert.exit_code == 0) << expert.out << expert.err;
  // Before the start: the lesson, its aids and criteria.
  EXPECT_NE(expert.out.find("lesson 1/6 of curriculum 'x-ray-free'"), std::string::npos)
      << expert.out;
  EXPECT_NE(expert.out.find("- pain_s <= 10 s"), std::string::npos) << expert.out;
  EXPECT_NE(expert.out.find("station verdict: lesson x-ray-free-1-gentle-minute: PASSED"),
            std::string::npos)
      << expert.out;
  EXPECT_NE(expert.out.find("server verdict (replayed): lesson x-ray-free-1-gentle-minute"),
            std::string::npos)
      << expert.out;
  EXPECT_NE(expert.out.find(": PASSED score="), std::string::npos) << expert.out;

  const ProcessResult novice =
      Station(LessonArgs("trainee-8", "novice", dir_ / "station-b", "out-novice", true));
  ASSERT_TRUE(novice.exit_code == 0) << novice.out << novice.err;
  EXPECT_NE(novice.out.find(": FAILED score="), std::string::npos) << novice.out;

  const ProcessResult p7 = AsSupervisor({"progress", "--trainee", kTrainee});
  ASSERT_EQ(p7.exit_code, 0) << p7.err;
  EXPECT_NE(FirstLessonRow(p7.out).find(" yes "), std::string::npos) << p7.out;
  EXPECT_NE(p7.out.find("next lesson: x-ray-free-2-cecum-with-aids"), std::string::npos)
      << p7.out;
  const ProcessResult p8 = AsSupervisor({"progress", "--trainee", "trainee-8"});
  EXPECT_NE(FirstLessonRow(p8.out).find(" no "), std::string::npos) << p8.out;
  const ProcessResult group = AsSupervisor({"progress", "--group", "residents"});
  ASSERT_EQ(group.exit_code, 0) << group.err;
  EXPECT_TRUE(std::regex_search(group.out, std::regex("trainee-7 +yes "))) << group.out;
  EXPECT_TRUE(std::regex_search(group.out, std::regex("trainee-8 +no/1 "))) << group.out;
}

TEST_F(StationLesson, ALessonWhoseCaseFailsVerificationIsRefusedBeforeTheRun) {
  // Another case's bundle sits in the cache under the lesson's case hash.
  const fs::path data = dir_ / "station";
  const auto paper = patient_db::LoadCaseFile(kCasesDir + "paper-sigmoid.textproto");
  const auto other = patient_db::LoadCaseFile(kCasesDir + "redundant-sigmoid.textproto");
  fs::create_directories(data / "cases");
  {
    std::ofstream out(data / "cases" / (patient_db::CasePayloadSha256Hex(paper) + ".vescase"),
                      std::ios::binary);
    out << patient_db::EncodeCaseBundle(other);
  }
  const ProcessResult run = Station(LessonArgs(kTrainee, "expert", data, "out", true));
  EXPECT_EQ(run.exit_code, 2) << run.out << run.err;
  EXPECT_NE(run.err.find("fails verification"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("refusing to start the lesson"), std::string::npos) << run.err;
  EXPECT_EQ(CommittedUuid(run.out), "") << run.out;  // nothing ran, nothing recorded
  EXPECT_FALSE(fs::exists(dir_ / "out" / "summary.txt"));
  EXPECT_EQ(PendingUploads(Station({"status", "--data-dir", data.string()}).out), 0);
}

TEST_F(StationLesson, AnOfflineLessonRunsFromTheCacheAndItsVerdictArrivesOnReconnect) {
  const fs::path data = dir_ / "station";
  // Online once (a 1 s practice cut): the lesson and its case are cached.
  const ProcessResult online = Station(LessonArgs(kTrainee, "novice", data, "out-1", true, "1"));
  ASSERT_TRUE(online.exit_code == 0) << online.out << online.err;

  const int port = port_;
  StopServer();
  // A 5 s practice cut: it cannot pass (a lesson needs its whole minute).
  const ProcessResult offline =
      Station(LessonArgs(kTrainee, "novice", data, "out-2", false, "5"));
  ASSERT_TRUE(offline.exit_code == 0) << offline.out << offline.err;
  EXPECT_NE(offline.out.find("offline lesson cache"), std::string::npos) << offline.out;
  EXPECT_NE(offline.out.find("station verdict: lesson x-ray-free-1-gentle-minute: FAILED"),
            std::string::npos)
      << offline.out;
  const std::string uuid = CommittedUuid(offline.out);
  ASSERT_FALSE(uuid.empty()) << offline.out;
  const ProcessResult waiting = Station({"status", "--data-dir", data.string()});
  EXPECT_NE(waiting.out.find("lesson verdicts awaited: 1\n  " + uuid +
                             "  lesson=x-ray-free-1-gentle-minute"),
            std::string::npos)
      << waiting.out;

  StartServer(port);
  const ProcessResult sync = Station(
      {"sync", "--server", address_, "--token", station_token_, "--data-dir", data.string()});
  EXPECT_EQ(sync.exit_code, 0) << sync.out << sync.err;
  EXPECT_NE(sync.out.find("server verdict (replayed): lesson x-ray-free-1-gentle-minute session " +
                          uuid + ": FAILED"),
            std::string::npos)
      << sync.out;
  const ProcessResult synced = Station({"status", "--data-dir", data.string()});
  EXPECT_NE(synced.out.find("lesson verdicts awaited: 0\n"), std::string::npos) << synced.out;
  EXPECT_NE(synced.out.find("  " + uuid + "  trainee=" + kTrainee +
                            "  lesson=x-ray-free-1-gentle-minute  FAILED  score="),
            std::string::npos)
      << synced.out;
  const ProcessResult progress = AsSupervisor({"progress", "--trainee", kTrainee});
  EXPECT_TRUE(std::regex_search(FirstLessonRow(progress.out), std::regex(" 2 +0/1 ")))
      << progress.out;  // both attempts judged, neither passed
}

TEST_F(StationLesson, AidsThatAreOffAreForcedOffAndTheServerAgrees) {
  // A 5 s lesson with neither aid, for a trainee of its own; the scripted
  // novice switches fluoroscopy on at once and would keep it on.
  const fs::path file = dir_ / "no-aids.textproto";
  {
    std::ofstream out(file);
    out << "curriculum_id: \"no-aids\" lessons { lesson_id: \"no-aids-1\" "
           "case_ref { case_id: \"paper-sigmoid\" } time_limit_s: 5 "
           "aids { fluoroscopy_allowed: false wireframe_allowed: false } }\n";
  }
  ASSERT_EQ(AsAdmin({"trainee", "add", "--id", "trainee-9"}).exit_code, 0);
  const ProcessResult created = AsSupervisor({"curriculum", "create", file.string()});
  ASSERT_EQ(created.exit_code, 0) << created.err;
  ASSERT_EQ(AsSupervisor({"assign", "--curriculum", "no-aids", "--trainee", "trainee-9"})
                .exit_code,
            0);
  const ProcessResult run =
      Station(LessonArgs("trainee-9", "novice", dir_ / "station", "out", true));
  ASSERT_TRUE(run.exit_code == 0) << run.out << run.err;
  EXPECT_NE(run.out.find("aids: fluoroscopy OFF, wireframe view OFF"), std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("xray_s=0.0 "), std::string::npos) << run.out;  // forced off
  EXPECT_FALSE(fs::exists(dir_ / "out" / "fluoroscopy.png"));            // not rendered
  EXPECT_NE(run.out.find("fluoroscopy not allowed: xray_s 0 = 0: ok"), std::string::npos)
      << run.out;  // the server's replay of what the model got agrees
}

}  // namespace
}  // namespace ves::station::testing
