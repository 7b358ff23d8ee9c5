// ves-station subcommands that need no server, as processes:
//  - `haptic-check` stopped (SIGSTOP) for 30 ms five times while it runs the
//    spring mode on the wall clock: a stall of the station's own process is
//    not silence of the device, so the run ends with no hard fault and still
//    draws the spring line of the paper's Fig. 6;
//  - `sim --operator` and `replay` of its session file print the same
//    summary line, byte for byte;
//  - help texts print their defaults as written, not as binary fractions.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/station/app/child_process.h"

namespace ves::station::testing {
namespace {

namespace fs = std::filesystem;
using std::chrono::milliseconds;

const std::string kStationBin = VES_BINARY_DIR "/station/app/ves-station";

// The number after "KEY=" in `text` (NaN when absent).
double NumberAfter(const std::string& text, const std::string& key) {
  const size_t at = text.find(key + "=");
  if (at == std::string::npos) return std::nan("");
  return std::atof(text.c_str() + at + key.size() + 1);
}

// The summary line of one axis ("mode=spring axis=thrust ...").
std::string AxisLine(const std::string& out, const std::string& axis) {
  const size_t at = out.find("axis=" + axis);
  if (at == std::string::npos) return "";
  return out.substr(at, out.find('\n', at) - at);
}

TEST(HapticCheck, StoppingTheProcessFiveTimesFor30MsIsNoFaultAndKeepsTheSpringLine) {
  const fs::path dir = MakeTempDir("haptic-check");
  ChildProcess check({kStationBin, "haptic-check", "--device", "sim", "--mode", "spring",
                      "--profile", "sine:20:0.25", "--seconds", "4", "--csv",
                      (dir / "run.csv").string()},
                     dir / "check");
  std::this_thread::sleep_for(milliseconds(800));  // past bring-up and arming
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(check.Running());
    ASSERT_EQ(::kill(check.pid(), SIGSTOP), 0);
    std::this_thread::sleep_for(milliseconds(30));
    ASSERT_EQ(::kill(check.pid(), SIGCONT), 0);
    std::this_thread::sleep_for(milliseconds(400));
  }
  const ProcessResult result = check.Wait(std::chrono::seconds(60));
  ASSERT_EQ(result.exit_code, 0) << result.out << result.err;
  EXPECT_EQ(NumberAfter(result.err, "hard_faults"), 0.0) << result.err;
  EXPECT_GE(NumberAfter(result.err, "station_stalls"), 5.0) << result.err;
  const std::string thrust = AxisLine(result.out, "thrust");
  const std::string roll = AxisLine(result.out, "roll");
  EXPECT_NEAR(NumberAfter(thrust, "slope_N_per_m"), 100.0, 5.0) << result.out;
  EXPECT_GE(NumberAfter(thrust, "r2"), 0.99) << result.out;
  EXPECT_NEAR(NumberAfter(roll, "slope_Nm_per_rad"), 0.05, 0.0025) << result.out;
  EXPECT_GE(NumberAfter(roll, "r2"), 0.99) << result.out;
  fs::remove_all(dir);
}

TEST(SimAndReplay, ReplayPrintsTheSimsSummaryByteForByte) {
  const fs::path dir = MakeTempDir("sim-replay");
  const fs::path session = dir / "novice.session";
  const ProcessResult sim = RunProgram(
      {kStationBin, "sim", "--case", VES_SOURCE_DIR "/patient_db/cases/standard-adult.textproto",
       "--operator", "novice", "--seconds", "3", "--session-out", session.string()},
      dir / "sim");
  // A session that ran to its end is a success, whatever its outcome.
  ASSERT_EQ(sim.exit_code, 0) << sim.out << sim.err;
  ASSERT_EQ(sim.out.rfind("outcome=", 0), 0u) << sim.out;
  // Three seconds do not reach the cecum: what did not happen is "-".
  EXPECT_NE(sim.out.find(" time_to_cecum_s=- inserted_at_cecum_m=- deepest_tip_arc_m="),
            std::string::npos)
      << sim.out;
  EXPECT_NE(sim.out.find(" deepest_region="), std::string::npos) << sim.out;
  EXPECT_NE(sim.out.find("/100\n"), std::string::npos) << sim.out;
  const ProcessResult replay = RunProgram({kStationBin, "replay", session.string()}, dir / "replay");
  ASSERT_EQ(replay.exit_code, 0) << replay.err;
  EXPECT_EQ(replay.out, sim.out);
  fs::remove_all(dir);
}

// The debrief of a real session (docs/scoring.md, "Debrief"): `replay
// --debrief` prints the summary line, then one line per weighed part whose
// points sum to the score.
TEST(SimAndReplay, TheDebriefsPartsSumToTheReplayedScore) {
  const fs::path dir = MakeTempDir("debrief");
  const fs::path session = dir / "novice.session";
  const ProcessResult sim = RunProgram(
      {kStationBin, "sim", "--case", VES_SOURCE_DIR "/patient_db/cases/standard-adult.textproto",
       "--operator", "novice", "--seconds", "20", "--session-out", session.string()},
      dir / "sim");
  ASSERT_EQ(sim.exit_code, 0) << sim.out << sim.err;
  const ProcessResult replay =
      RunProgram({kStationBin, "replay", session.string(), "--debrief"}, dir / "replay");
  ASSERT_EQ(replay.exit_code, 0) << replay.err;
  ASSERT_EQ(replay.out.rfind(sim.out, 0), 0u) << "the summary line first:\n" << replay.out;
  const double score = NumberAfter(sim.out, "score");
  double sum = 0.0;
  int parts = 0;
  std::istringstream lines(replay.out.substr(sim.out.size()));
  // 20 s of the novice is far short of the cecum: the first line says so,
  // how far the tip got and where (the summary line's deepest tip and region).
  std::string headline;
  std::getline(lines, headline);
  const double deepest_m = NumberAfter(sim.out, "deepest_tip_arc_m");
  const size_t region_at = sim.out.find("deepest_region=") + 15;
  const std::string region = sim.out.substr(region_at, sim.out.find(' ', region_at) - region_at);
  char expected[96];
  std::snprintf(expected, sizeof(expected), "  Cecum not reached: the tip got %.2f m of the ",
                deepest_m);
  EXPECT_EQ(headline.rfind(expected, 0), 0u) << replay.out;
  EXPECT_NE(headline.find(", as far as the " + region + "; every part below is scaled by that "),
            std::string::npos)
      << headline;
  for (std::string line; std::getline(lines, line);) {
    ASSERT_EQ(line.rfind("  ", 0), 0u) << line;
    const std::string name = line.substr(2, line.find(' ', 2) - 2);
    sum += std::atof(line.c_str() + 2 + name.size() + 1);
    ++parts;
  }
  // cecum, pain, loops, force, x-ray, red-out on a medium case (time is out
  // of play short of the cecum); each printed to 0.1.
  EXPECT_GE(parts, 6) << replay.out;
  EXPECT_NEAR(sum, score, 0.05 * parts + 0.05) << replay.out;
  fs::remove_all(dir);
}

TEST(Snapshot, TheCarmAngleAndZoomGiveAnotherImageAndBadValuesAreRefused) {
  const fs::path dir = MakeTempDir("snapshot");
  const std::vector<std::string> base = {
      kStationBin, "snapshot", "--case", VES_SOURCE_DIR "/patient_db/cases/standard-adult.textproto",
      "--insert-mm", "200", "--width", "160", "--height", "120", "--segments", "60"};
  auto with = [&](std::vector<std::string> extra, const fs::path& out) {
    std::vector<std::string> args = base;
    args.insert(args.end(), extra.begin(), extra.end());
    args.insert(args.end(), {"--out", out.string()});
    return RunProgram(args, out.string() + "-log");
  };
  const ProcessResult plain = with({}, dir / "plain");
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_FALSE(fs::exists(dir / "plain" / "fluoroscopy_c-arm.png"));
  const ProcessResult turned = with({"--c-arm-deg", "35", "--zoom", "2"}, dir / "turned");
  ASSERT_EQ(turned.exit_code, 0) << turned.err;
  ASSERT_TRUE(fs::exists(dir / "turned" / "fluoroscopy_c-arm.png"));
  // Zoom 2 around the tip: the AP image is another one.
  EXPECT_NE(ReadFile(dir / "plain" / "fluoroscopy_ap.png"),
            ReadFile(dir / "turned" / "fluoroscopy_ap.png"));
  const ProcessResult far = with({"--zoom", "20"}, dir / "far");
  EXPECT_EQ(far.exit_code, 2);
  EXPECT_NE(far.err.find("--zoom"), std::string::npos) << far.err;
  const ProcessResult tilt = with({"--tilt-deg", "10"}, dir / "tilt");
  EXPECT_EQ(tilt.exit_code, 2);
  EXPECT_NE(tilt.err.find("--c-arm-deg"), std::string::npos) << tilt.err;
  fs::remove_all(dir);
}

// snapshot --session: the views from where a recorded session left the
// scope (docs/views.md), e.g. at the cecum's pole after an expert's run.
// Here a short novice run: the tip it reports is the replay's last row's.
TEST(Snapshot, ASessionsLastStepPutsTheTipWhereItEnded) {
  const fs::path dir = MakeTempDir("snapshot-session");
  const fs::path session = dir / "novice.session";
  const ProcessResult sim = RunProgram(
      {kStationBin, "sim", "--case", VES_SOURCE_DIR "/patient_db/cases/standard-adult.textproto",
       "--operator", "novice", "--seconds", "8", "--segments", "60", "--session-out",
       session.string()},
      dir / "sim");
  ASSERT_EQ(sim.exit_code, 0) << sim.out << sim.err;
  const ProcessResult replay = RunProgram(
      {kStationBin, "replay", session.string(), "--csv", (dir / "replay.csv").string()},
      dir / "replay");
  ASSERT_EQ(replay.exit_code, 0) << replay.err;
  const std::string csv = ReadFile(dir / "replay.csv");
  const size_t last_row = csv.rfind('\n', csv.size() - 2) + 1;
  // t_s, inserted_m, tip_arc_m, ...
  const size_t tip_at = csv.find(',', csv.find(',', last_row) + 1) + 1;
  const double last_tip_m = std::atof(csv.c_str() + tip_at);
  ASSERT_GT(last_tip_m, 0.05) << "the novice did not go in";

  const fs::path out = dir / "views";
  const ProcessResult snapshot =
      RunProgram({kStationBin, "snapshot", "--session", session.string(), "--width", "160",
                  "--height", "120", "--out", out.string()},
                 dir / "snapshot");
  ASSERT_EQ(snapshot.exit_code, 0) << snapshot.out << snapshot.err;
  EXPECT_NEAR(NumberAfter(snapshot.out, "tip_arc_m"), last_tip_m, 1e-4) << snapshot.out;
  // The replayed outcome, as the run's own summary line has it.
  const std::string outcome = sim.out.substr(0, sim.out.find(' '));
  ASSERT_EQ(outcome.rfind("outcome=", 0), 0u) << sim.out;
  EXPECT_NE(snapshot.out.find(" " + outcome + " "), std::string::npos) << snapshot.out;
  for (const char* image : {"endoscope_wireframe.png", "endoscope_polygon.png",
                            "endoscope_texture.png", "fluoroscopy_ap.png"}) {
    const cv::Mat png = cv::imread((out / image).string());
    EXPECT_EQ(png.cols, 160) << image;
    EXPECT_EQ(png.rows, 120) << image;
  }
  // --advance-mm: then pushed on by position (from where a session stopped
  // at the cecum's entrance to its pole): the tip goes deeper.
  const ProcessResult advanced =
      RunProgram({kStationBin, "snapshot", "--session", session.string(), "--advance-mm", "30",
                  "--width", "160", "--height", "120", "--out", (dir / "advanced").string()},
                 dir / "advanced");
  ASSERT_EQ(advanced.exit_code, 0) << advanced.out << advanced.err;
  EXPECT_GT(NumberAfter(advanced.out, "inserted_m"), NumberAfter(snapshot.out, "inserted_m") + 0.025)
      << advanced.out;
  EXPECT_GT(NumberAfter(advanced.out, "tip_arc_m"), last_tip_m + 0.005) << advanced.out;
  const ProcessResult no_session = RunProgram(
      {kStationBin, "snapshot", "--case", "standard-adult", "--insert-mm", "100", "--advance-mm",
       "30", "--out", (dir / "no-session").string()},
      dir / "no-session");
  EXPECT_EQ(no_session.exit_code, 2);
  EXPECT_NE(no_session.err.find("--advance-mm needs --session"), std::string::npos)
      << no_session.err;
  // The record sets the case and the insertion: asking for them too is refused.
  const ProcessResult both =
      RunProgram({kStationBin, "snapshot", "--session", session.string(), "--insert-mm", "100",
                  "--out", (dir / "both").string()},
                 dir / "both");
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_NE(both.err.find("--insert-mm cannot be used with --session"), std::string::npos)
      << both.err;
  // A file that is no session is refused, naming it.
  std::ofstream(dir / "bad.session") << "not a session";
  const ProcessResult bad =
      RunProgram({kStationBin, "snapshot", "--session", (dir / "bad.session").string(), "--out",
                  (dir / "bad").string()},
                 dir / "bad");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("bad.session"), std::string::npos) << bad.err;
  fs::remove_all(dir);
}

// import-case --preview: the colon at rest on AP fluoroscopy with its
// regions named (yellow, the only colour on the grey X-ray); a file written
// cecum first previews the same as the same colon written anus first.
TEST(ImportCase, APreviewShowsTheColonWithItsRegionsNamed) {
  const fs::path dir = MakeTempDir("preview");
  const std::string rows[] = {"0,0,0,13,rectum",     "0,-10,30,20,rectum",  "0,-15,60,22,rectum",
                              "5,-10,90,18,sigmoid", "15,0,120,16,sigmoid", "25,10,150,16,sigmoid"};
  std::string forward = "x_mm,y_mm,z_mm,radius_mm,region\n";
  std::string backward = forward;
  for (int i = 0; i < 6; ++i) {
    forward += rows[i] + "\n";
    backward += rows[5 - i] + "\n";
  }
  {
    std::ofstream(dir / "forward.csv") << forward;
    std::ofstream(dir / "backward.csv") << backward;
  }
  const fs::path previews = dir / "previews";
  const ProcessResult imported = RunProgram(
      {kStationBin, "import-case", VES_SOURCE_DIR "/patient_db/cases/standard-adult.textproto",
       (dir / "forward.csv").string(), (dir / "backward.csv").string(), "--preview",
       previews.string(), "--data-dir", (dir / "data").string()},
      (dir / "log").string());
  ASSERT_EQ(imported.exit_code, 0) << imported.out << imported.err;
  EXPECT_NE(imported.out.find("preview " + (previews / "standard-adult.png").string()),
            std::string::npos)
      << imported.out << imported.err;
  EXPECT_NE(imported.err.find("runs cecum first"), std::string::npos) << imported.err;
  const cv::Mat colon = cv::imread((previews / "standard-adult.png").string());
  ASSERT_FALSE(colon.empty()) << imported.err;
  EXPECT_EQ(colon.cols, 640);
  EXPECT_EQ(colon.rows, 720);
  int yellow = 0;
  for (int y = 0; y < colon.rows; ++y) {
    for (int x = 0; x < colon.cols; ++x) {
      const cv::Vec3b bgr = colon.at<cv::Vec3b>(y, x);
      yellow += bgr[0] < 80 && bgr[1] > 150 && bgr[2] > 180;
    }
  }
  EXPECT_GT(yellow, 500);  // nine names and dots: rectum ... cecum and the anus
  EXPECT_EQ(ReadFile(previews / "forward.png"), ReadFile(previews / "backward.png"));
  fs::remove_all(dir);
}

TEST(Help, DefaultsAreRoundedAsWritten) {
  const fs::path dir = MakeTempDir("help");
  for (const char* command : {"run", "sim", "replay", "snapshot", "haptic-check", "import-case",
                              "export-case", "status", "sync"}) {
    const ProcessResult help = RunProgram({kStationBin, command, "--help"}, dir / command);
    ASSERT_EQ(help.exit_code, 0) << command << help.err;
    // "(=0.050000000000000003)" is 0.05 printed with all its binary digits.
    for (size_t at = help.out.find("(="); at != std::string::npos; at = help.out.find("(=", at + 1)) {
      const std::string value = help.out.substr(at + 2, help.out.find(')', at) - at - 2);
      EXPECT_LT(value.size(), 12u) << command << ": default " << value;
    }
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ves::station::testing
