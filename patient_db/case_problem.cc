#include "patient_db/case_problem.h"

#include <utility>

#include "patient_db/limits.h"

namespace ves::patient_db {

std::string CaseProblem::ToString() const {
  std::string text = file + ": " + field;
  if (index >= 0) text += "[" + std::to_string(index) + "]";
  // Values come from files and requests: shown cut and with control bytes escaped.
  if (!value.empty()) text += " = " + PrintableExcerpt(value, 200);
  text += ": " + message;
  return text;
}

std::string JoinProblems(const std::vector<CaseProblem>& problems) {
  std::string text;
  for (const auto& problem : problems) {
    if (!text.empty()) text += "\n";
    text += problem.ToString();
  }
  return text;
}

CaseError::CaseError(std::vector<CaseProblem> problems)
    : std::runtime_error(problems.empty() ? std::string("invalid case") : JoinProblems(problems)),
      problems_(std::move(problems)) {}

CaseError::CaseError(std::string file, std::string field, int index, std::string value,
                     std::string message)
    : CaseError(std::vector<CaseProblem>{CaseProblem{std::move(file), std::move(field), index,
                                                     std::move(value), std::move(message)}}) {}

}  // namespace ves::patient_db
