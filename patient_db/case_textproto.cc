#include "patient_db/case_textproto.h"

#include <google/protobuf/io/tokenizer.h>
#include <google/protobuf/text_format.h>

#include <charconv>
#include <cmath>
#include <vector>

#include "patient_db/case_problem.h"

namespace ves::patient_db {
namespace {

class ProblemCollector : public google::protobuf::io::ErrorCollector {
 public:
  explicit ProblemCollector(const std::string& file) : file_(file) {}
  void AddError(int line, int column, const std::string& message) override {
    // The parser counts from 0; editors from 1.
    problems_.push_back({file_, "textproto", line + 1, "column " + std::to_string(column + 1),
                         message});
  }
  void AddWarning(int, int, const std::string&) override {}
  std::vector<CaseProblem>& problems() { return problems_; }

 private:
  std::string file_;
  std::vector<CaseProblem> problems_;
};

// Shortest text that reads back to the same double; "inf"/"nan" as the text
// format spells them.
std::string ShortestDouble(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

}  // namespace

ves::v1::ColonCase ParseCaseTextproto(std::string_view text, const std::string& file_label) {
  ves::v1::ColonCase colon_case;
  ProblemCollector collector(file_label);
  google::protobuf::TextFormat::Parser parser;
  parser.RecordErrorsTo(&collector);
  const bool ok = parser.ParseFromString(std::string(text), &colon_case);
  if (!ok || !collector.problems().empty()) {
    if (collector.problems().empty()) {
      collector.problems().push_back(
          {file_label, "textproto", -1, "", "not a ves.v1.ColonCase in text format"});
    }
    throw CaseError(std::move(collector.problems()));
  }
  return colon_case;
}

std::string FormatCaseTextproto(const ves::v1::ColonCase& colon_case) {
  // Header fields by the protobuf printer; the long repeated geometry one
  // element per line so a case stays readable and diffable.
  ves::v1::ColonCase header = colon_case;
  header.clear_centerline();
  header.clear_radius_profile();
  header.clear_regions();
  ves::v1::ColonCase regions_only;
  *regions_only.mutable_regions() = colon_case.regions();
  std::string header_text, regions_text;
  google::protobuf::TextFormat::Printer printer;
  printer.PrintToString(header, &header_text);
  printer.PrintToString(regions_only, &regions_text);

  std::string text =
      "# proto-file: ves/v1/case.proto\n# proto-message: ves.v1.ColonCase\n"
      "# Units: metres; frame: docs/case-format.md.\n\n" +
      header_text + "\n";
  for (const auto& p : colon_case.centerline()) {
    text += "centerline { x_m: " + ShortestDouble(p.x_m()) + " y_m: " + ShortestDouble(p.y_m()) +
            " z_m: " + ShortestDouble(p.z_m()) + " }\n";
  }
  text += "\n";
  for (const auto& r : colon_case.radius_profile()) {
    text += "radius_profile { arc_m: " + ShortestDouble(r.arc_m()) +
            " radius_m: " + ShortestDouble(r.radius_m()) + " }\n";
  }
  text += "\n" + regions_text;
  return text;
}

}  // namespace ves::patient_db
