#include "tests/patient_db/case_test_util.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <fstream>

namespace ves::patient_db::testing {

ves::v1::ColonCase MakeValidCase() {
  ves::v1::ColonCase c;
  c.set_id("unit-case");
  c.set_title("Unit test case");
  c.set_version(1);
  c.set_difficulty(ves::v1::DIFFICULTY_EASY);
  c.mutable_provenance()->set_source("synthetic");
  c.mutable_provenance()->set_year(2024);
  for (int i = 0; i < 10; ++i) {
    auto* p = c.add_centerline();
    p->set_z_m(0.02 * i);
  }
  auto* r = c.add_radius_profile();
  r->set_arc_m(0.0);
  r->set_radius_m(0.02);
  auto* rectum = c.add_regions();
  rectum->set_region(ves::v1::REGION_RECTUM);
  rectum->set_start_arc_m(0.0);
  rectum->set_end_arc_m(0.09);
  *rectum->mutable_tissue() = DefaultTissue(ves::v1::REGION_RECTUM);
  auto* sigmoid = c.add_regions();
  sigmoid->set_region(ves::v1::REGION_SIGMOID);
  sigmoid->set_start_arc_m(0.09);
  sigmoid->set_end_arc_m(0.18);
  *sigmoid->mutable_tissue() = DefaultTissue(ves::v1::REGION_SIGMOID);
  return c;
}

ScratchDir::ScratchDir() {
  static std::atomic<int> counter{0};
  path_ = std::filesystem::temp_directory_path() /
          ("ves-case-test-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
  std::filesystem::remove_all(path_);
  std::filesystem::create_directories(path_);
}

ScratchDir::~ScratchDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

void WriteText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  ASSERT_TRUE(out.good()) << "cannot write " << path;
}

std::vector<CaseProblem> ProblemsOfBrokenFile(const ScratchDir& dir,
                                              const ves::v1::ColonCase& colon_case) {
  const auto path = dir / "broken.textproto";
  WriteText(path, FormatCaseTextproto(colon_case));
  try {
    LoadCaseFile(path);
  } catch (const CaseError& e) {
    for (const auto& problem : e.problems()) EXPECT_EQ(problem.file, path.string());
    return e.problems();
  }
  ADD_FAILURE() << "LoadCaseFile accepted a broken case";
  return {};
}

bool HasProblem(const std::vector<CaseProblem>& problems, const std::string& field, int index) {
  for (const auto& problem : problems) {
    if (problem.field == field && (index == -2 || problem.index == index)) return true;
  }
  return false;
}

}  // namespace ves::patient_db::testing
