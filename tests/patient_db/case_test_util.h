#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "patient_db/case_format.h"

// Helpers shared by the case format tests.
namespace ves::patient_db::testing {

// A small valid case: 10 points straight up z every 2 cm (0.18 m), radius 2 cm,
// rectum [0, 0.09] and sigmoid [0.09, 0.18] with the default tissue.
ves::v1::ColonCase MakeValidCase();

// A fresh empty directory, removed with its content on destruction.
class ScratchDir {
 public:
  ScratchDir();
  ~ScratchDir();
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

void WriteText(const std::filesystem::path& path, const std::string& text);

// Writes `colon_case` unvalidated as textproto into `dir`, loads it with
// LoadCaseFile and returns the problems of the CaseError it must throw (an
// empty list plus a test failure when it loads).
std::vector<CaseProblem> ProblemsOfBrokenFile(const ScratchDir& dir,
                                              const ves::v1::ColonCase& colon_case);

// True when some problem has this field and index (index -2: any index).
bool HasProblem(const std::vector<CaseProblem>& problems, const std::string& field,
                int index = -2);

}  // namespace ves::patient_db::testing
