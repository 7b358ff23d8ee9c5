// The sessions CSV export (docs/web.md, "Export"): columns, quoting, cells.
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <ctime>
#include <map>

#include "server/web_api.h"
#include "server/web_reply.h"
#include "ves/v1/session.pb.h"

namespace ves::server {
namespace {

// RFC 4180: quoted when it holds a comma, quote or line end. A text cell a
// spreadsheet would run as a formula gets a leading ' (ids are printable
// text from uploads; a trainee id may well start with '=').
std::string CsvText(const std::string& text) {
  std::string cell = text;
  if (!cell.empty() && std::string_view("=+-@").find(cell[0]) != std::string_view::npos) {
    cell.insert(cell.begin(), '\'');
  }
  if (cell.find_first_of(",\"\r\n") == std::string::npos) return cell;
  std::string quoted = "\"";
  for (char c : cell) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  return quoted + "\"";
}

std::string CsvNumber(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// ISO 8601 in UTC to the millisecond: 2026-12-07T14:53:22.123Z.
std::string IsoUtc(int64_t unix_ms) {
  const std::time_t secs = static_cast<std::time_t>(unix_ms / 1000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[96];  // room for any int the compiler cannot rule out
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", tm.tm_year + 1900,
                tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec,
                static_cast<int>(unix_ms % 1000));
  return buf;
}

// "cecum_reached", "timed_out", ...: the station's names for an outcome.
std::string OutcomeText(int outcome) {
  std::string name = v1::Outcome_IsValid(outcome)
                         ? v1::Outcome_Name(static_cast<v1::Outcome>(outcome))
                         : "OUTCOME_UNSPECIFIED";
  name = name.substr(name.rfind("OUTCOME_", 0) == 0 ? 8 : 0);
  std::transform(name.begin(), name.end(), name.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return name;
}

}  // namespace

const std::vector<std::string>& SessionsCsvColumns() {
  static const std::vector<std::string> columns = {
      "session_uuid",   "trainee_id",    "case_id",    "case_version", "lesson_id",
      "lesson_verdict", "lesson_checks", "station_id", "operator",     "start_utc",
      "end_utc",        "duration_s",    "outcome",    "completed",    "time_to_cecum_s",
      "pain_s",         "max_tip_arc_m", "score",      "loop_s",       "xray_s"};
  return columns;
}

std::string SessionsCsv(const std::vector<patient_db::SessionRow>& sessions,
                        const std::vector<patient_db::LessonVerdictRow>& verdicts) {
  std::map<std::string, const patient_db::LessonVerdictRow*> verdict_of;
  for (const auto& v : verdicts) verdict_of[v.session_uuid] = &v;
  std::string out;
  const auto line = [&out](const std::vector<std::string>& cells) {
    for (size_t i = 0; i < cells.size(); ++i) {
      if (i > 0) out += ',';
      out += cells[i];
    }
    out += "\r\n";
  };
  line(SessionsCsvColumns());
  for (const auto& s : sessions) {
    std::string verdict, checks;
    if (!s.lesson_id.empty()) {
      auto it = verdict_of.find(s.uuid);
      if (it == verdict_of.end()) {
        verdict = "pending";  // the judge has not replayed it yet
      } else {
        verdict = it->second->rejected ? "rejected" : it->second->passed ? "passed" : "failed";
        for (const std::string& check : SplitText(it->second->detail, '\n')) {
          if (check.empty()) continue;
          checks += (checks.empty() ? "" : "; ") + check;
        }
      }
    }
    line({CsvText(s.uuid), CsvText(s.trainee_id), CsvText(s.case_id),
          std::to_string(s.case_version), CsvText(s.lesson_id), verdict, CsvText(checks),
          CsvText(s.station_id), CsvText(s.operator_kind), IsoUtc(s.start_unix_ms),
          IsoUtc(s.end_unix_ms), CsvNumber((s.end_unix_ms - s.start_unix_ms) / 1000.0, 3),
          OutcomeText(s.outcome), s.completed ? "true" : "false",
          s.completed ? CsvNumber(s.time_to_cecum_s, 3) : "", CsvNumber(s.pain_s, 3),
          CsvNumber(s.max_tip_arc_m, 4), CsvNumber(s.score, 2),
          s.loop_s >= 0 ? CsvNumber(s.loop_s, 3) : "", s.xray_s >= 0 ? CsvNumber(s.xray_s, 3) : ""});
  }
  return out;
}

}  // namespace ves::server
