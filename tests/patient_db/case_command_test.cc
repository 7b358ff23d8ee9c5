// `ves-admin case` as a process: exit status and output (the built binary).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

#include "patient_db/case_format.h"
#include "tests/patient_db/case_test_util.h"

namespace ves::patient_db {
namespace {

using testing::MakeValidCase;
using testing::ScratchDir;
using testing::WriteText;

const std::string kCasesDir = VES_SOURCE_DIR "/patient_db/cases/";

struct Run {
  int status = -1;
  std::string out;  // stdout and stderr together
};

Run RunAdmin(const std::string& args) {
  Run run;
  const std::string command = std::string(VES_ADMIN_PATH) + " " + args + " 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return run;
  std::array<char, 4096> buffer{};
  size_t n = 0;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0) run.out.append(buffer.data(), n);
  const int raw = ::pclose(pipe);
  run.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  return run;
}

TEST(CaseCommand, ValidateShippedCasesExitsZeroWithOkLines) {
  const auto run = RunAdmin("case validate " + kCasesDir + "standard-adult.textproto " + kCasesDir +
                            "paper-sigmoid.textproto");
  EXPECT_EQ(run.status, 0) << run.out;
  const auto c = LoadCaseFile(kCasesDir + "standard-adult.textproto");
  EXPECT_NE(run.out.find("OK " + kCasesDir + "standard-adult.textproto standard-adult v1 sha256=" +
                         CasePayloadSha256Hex(c)),
            std::string::npos)
      << run.out;
}

TEST(CaseCommand, ValidateWithOneInvalidFileExitsTwoAndNamesTheProblem) {
  ScratchDir dir;
  auto c = MakeValidCase();
  c.mutable_radius_profile(0)->set_radius_m(0.07);
  WriteText(dir / "bad.textproto", FormatCaseTextproto(c));
  const auto run =
      RunAdmin("case validate " + kCasesDir + "fixed-tube.textproto " + (dir / "bad.textproto").string());
  EXPECT_EQ(run.status, 2) << run.out;
  EXPECT_NE(run.out.find("OK " + kCasesDir + "fixed-tube.textproto"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find((dir / "bad.textproto").string() + ": radius_profile.radius_m[0] = 0.07"),
            std::string::npos)
      << run.out;
}

TEST(CaseCommand, ConvertWritesABundleThatValidates) {
  ScratchDir dir;
  const std::string out = (dir / "sa.vescase").string();
  const auto run = RunAdmin("case convert " + kCasesDir + "standard-adult.textproto " + out);
  EXPECT_EQ(run.status, 0) << run.out;
  EXPECT_EQ(RunAdmin("case validate " + out).status, 0);
  EXPECT_EQ(DecodeCaseBundle(ReadFileBytes(out), out).id(), "standard-adult");
}

TEST(CaseCommand, ConvertCsvNeedsARegionWhenTheTableHasNone) {
  ScratchDir dir;
  WriteText(dir / "line.csv", "x_mm,y_mm,z_mm,radius_mm\n0,0,0,20\n0,0,30,20\n0,0,60,20\n0,0,90,20\n");
  const std::string in = (dir / "line.csv").string();
  const std::string out = (dir / "line.textproto").string();
  EXPECT_EQ(RunAdmin("case convert " + in + " " + out).status, 2);
  EXPECT_EQ(RunAdmin("case convert " + in + " " + out + " --region sigmoid").status, 0);
  EXPECT_EQ(LoadCaseFile(out).regions(0).region(), ves::v1::REGION_SIGMOID);
}

TEST(CaseCommand, GenerateWritesTheSeedsColonOrPrintsIt) {
  ScratchDir dir;
  const std::string out = (dir / "g.textproto").string();
  const auto run = RunAdmin("case generate --seed 3 --out " + out);
  EXPECT_EQ(run.status, 0) << run.out;
  EXPECT_EQ(RunAdmin("case validate " + out).status, 0);
  const std::string expected = FormatCaseTextproto(GenerateColonCase(3));
  EXPECT_EQ(ReadFileBytes(out), expected);
  const auto printed = RunAdmin("case generate --seed 3");
  EXPECT_EQ(printed.status, 0);
  EXPECT_EQ(printed.out, expected);
  const std::string bundle = (dir / "g.vescase").string();
  EXPECT_EQ(RunAdmin("case generate --seed 3 --sigmoid redundant --out " + bundle).status, 0);
  const auto c = DecodeCaseBundle(ReadFileBytes(bundle), bundle);
  EXPECT_GE(c.regions(1).end_arc_m() - c.regions(1).start_arc_m(), 0.50);
}

TEST(CaseCommand, GenerateRefusesBadArgumentsNamingThem) {
  for (const char* args : {"--seed -1", "--seed 1x", "--seed 18446744073709551616", ""}) {
    const auto run = RunAdmin(std::string("case generate ") + args);
    EXPECT_EQ(run.status, 2) << args << ": " << run.out;
    EXPECT_NE(run.out.find("seed"), std::string::npos) << args << ": " << run.out;
  }
  const auto sigmoid = RunAdmin("case generate --seed 1 --sigmoid long");
  EXPECT_EQ(sigmoid.status, 2);
  EXPECT_NE(sigmoid.out.find("--sigmoid must be redundant or common"), std::string::npos)
      << sigmoid.out;
  EXPECT_EQ(RunAdmin("case generate --seed 1 --out g.csv").status, 2);
  const auto id = RunAdmin("case generate --seed 1 --id 'Bad Id'");
  EXPECT_EQ(id.status, 2);
  EXPECT_NE(id.out.find("id"), std::string::npos) << id.out;
}

TEST(CaseCommand, ConvertSaysWhenItReversesACentrelineAndRefusesOneRegionOverAColon) {
  ScratchDir dir;
  // Written cecum first: the sigmoid rows before the rectum's.
  WriteText(dir / "back.csv",
            "x_mm,y_mm,z_mm,radius_mm,region\n25,10,150,16,sigmoid\n15,0,120,16,sigmoid\n"
            "5,-10,90,18,sigmoid\n0,-15,60,22,rectum\n0,-10,30,20,rectum\n0,0,0,13,rectum\n");
  const std::string in = (dir / "back.csv").string();
  const std::string out = (dir / "back.textproto").string();
  const auto run = RunAdmin("case convert " + in + " " + out);
  EXPECT_EQ(run.status, 0) << run.out;
  EXPECT_NE(run.out.find("warning: " + in +
                         ": csv: runs cecum first (its regions run from "
                         "sigmoid to rectum): reversed, so the anus is line 7"),
            std::string::npos)
      << run.out;
  EXPECT_EQ(LoadCaseFile(out).regions(0).region(), ves::v1::REGION_RECTUM);
  // A whole colon (the shipped one's points) as one sigmoid: refused, why said.
  const auto colon = LoadCaseFile(kCasesDir + "standard-adult.textproto");
  std::string csv = "x_mm,y_mm,z_mm,radius_mm\n";
  for (const auto& p : colon.centerline()) {
    csv += std::to_string(p.x_m() * 1000) + "," + std::to_string(p.y_m() * 1000) + "," +
           std::to_string(p.z_m() * 1000) + ",20\n";
  }
  WriteText(dir / "colon.csv", csv);
  const auto whole =
      RunAdmin("case convert " + (dir / "colon.csv").string() + " " + out + " --region sigmoid");
  EXPECT_EQ(whole.status, 2) << whole.out;
  EXPECT_NE(whole.out.find("--region = sigmoid: the centreline is 1586 mm long, longer than any "
                           "sigmoid (at most 900 mm)"),
            std::string::npos)
      << whole.out;
}

TEST(CaseCommand, BadArgumentsExitTwo) {
  EXPECT_EQ(RunAdmin("case").status, 2);
  EXPECT_EQ(RunAdmin("case frobnicate").status, 2);
  EXPECT_EQ(RunAdmin("case validate").status, 2);
  EXPECT_EQ(RunAdmin("case convert only-one.textproto").status, 2);
  EXPECT_EQ(RunAdmin("case convert " + kCasesDir + "fixed-tube.textproto out.csv").status, 2);
  EXPECT_EQ(RunAdmin("case validate x.csv --region nowhere").status, 2);
  EXPECT_EQ(RunAdmin("case validate --help").status, 0);
  EXPECT_EQ(RunAdmin("case --help").status, 0);
}

}  // namespace
}  // namespace ves::patient_db
