#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace ves::patient_db {

// One thing wrong with a case file. Every problem names where it is (file,
// field path such as "regions[2].tissue.static_friction" reduced to its field
// name plus index) and the offending value, so an author can fix it without a
// debugger.
struct CaseProblem {
  std::string file;     // label of the file (path as given), never empty
  std::string field;    // e.g. "centerline", "regions.tissue.static_friction", "bundle.sha256"
  int index = -1;       // element of a repeated field (or line of a text file); -1: none
  std::string value;    // the offending value as text; may be empty
  std::string message;  // what is wrong and what is allowed

  // "<file>: <field>[<index>] = <value>: <message>" (index/value left out when absent).
  std::string ToString() const;

  bool operator==(const CaseProblem&) const = default;
};

// Thrown by every reader and writer of case files: carries all problems found,
// never a half-loaded case.
class CaseError : public std::runtime_error {
 public:
  explicit CaseError(std::vector<CaseProblem> problems);
  CaseError(std::string file, std::string field, int index, std::string value,
            std::string message);

  const std::vector<CaseProblem>& problems() const { return problems_; }

 private:
  std::vector<CaseProblem> problems_;
};

// Joins problems' ToString() with newlines.
std::string JoinProblems(const std::vector<CaseProblem>& problems);

}  // namespace ves::patient_db
