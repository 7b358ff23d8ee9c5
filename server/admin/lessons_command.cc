// ves-admin curriculum|assign|progress|group: curricula with proficiency
// gates against a running server (docs/lessons.md).
#include <google/protobuf/io/tokenizer.h>
#include <google/protobuf/text_format.h>

#include <cstdio>
#include <algorithm>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>

#include "server/admin/remote.h"
#include "ves/v1/services.grpc.pb.h"

namespace ves::admin {
namespace {

namespace po = boost::program_options;
using ves::server::ClientOptions;

// A lesson never attempted has no date.
std::string FormatDate(int64_t unix_ms) { return unix_ms == 0 ? "-" : FormatUtcMinute(unix_ms); }

std::unique_ptr<ves::v1::Lessons::Stub> LessonsStub(const ClientOptions& client) {
  return ves::v1::Lessons::NewStub(ves::server::MakeClientChannel(client));
}

// Collects text-format parse errors as "FILE:LINE:COL: message".
class ParseErrors final : public google::protobuf::io::ErrorCollector {
 public:
  explicit ParseErrors(std::string file) : file_(std::move(file)) {}
  void AddError(int line, int column, const std::string& message) override {
    if (first_.empty()) {
      first_ = file_ + ":" + std::to_string(line + 1) + ":" + std::to_string(column + 1) + ": " +
               message;
    }
  }
  const std::string& first() const { return first_; }

 private:
  std::string file_;
  std::string first_;
};

int CurriculumCreate(const std::string& file, const ClientOptions& client,
                     const std::string& institution) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  if (!in) {
    std::cerr << "ves-admin curriculum create: cannot read '" << file << "'\n";
    return kExitUsage;
  }
  ves::v1::CreateCurriculumRequest q;
  google::protobuf::TextFormat::Parser parser;
  ParseErrors errors(file);
  parser.RecordErrorsTo(&errors);
  if (!parser.ParseFromString(text.str(), q.mutable_curriculum())) {
    std::cerr << "ves-admin curriculum create: " << errors.first() << "\n";
    return kExitUsage;
  }
  if (!institution.empty()) q.mutable_curriculum()->set_institution(institution);
  ves::v1::CreateCurriculumResponse r;
  if (const int called = CallOnce("curriculum create", client, *LessonsStub(client),
                                  &ves::v1::Lessons::Stub::CreateCurriculum, q, &r);
      called != kExitOk) {
    return called;
  }
  const auto& c = r.curriculum();
  std::cout << (r.already_stored() ? "already stored: " : "created: ") << c.curriculum_id()
            << " (" << c.institution() << "), " << c.lessons_size() << " lesson(s)\n";
  for (const auto& l : c.lessons()) {
    std::cout << "  " << l.lesson_id() << ": " << l.case_ref().case_id() << " v"
              << l.case_ref().version() << " sha256=" << l.case_ref().payload_sha256_hex().substr(0, 16)
              << "… passes " << l.required_passes() << "\n";
  }
  return kExitOk;
}

int CurriculumList(const ClientOptions& client, const std::string& institution) {
  ves::v1::ListCurriculaRequest q;
  q.set_institution(institution);
  auto stub = LessonsStub(client);
  return ListAllPages(
      "curriculum list", client, *stub, &ves::v1::Lessons::Stub::ListCurricula, q,
      [](const ves::v1::ListCurriculaResponse& r) {
        for (const auto& c : r.curricula()) {
          std::printf("%-24s %-16s %2d lesson(s)  %s\n", Shown(c.curriculum_id()).c_str(),
                      Shown(c.institution()).c_str(), c.lessons_size(), Shown(c.title()).c_str());
        }
        return true;
      });
}

// The progress of one trainee: one line per lesson.
void PrintTraineeProgress(const ves::v1::TraineeProgress& t) {
  std::printf("%-16s %-32s %8s %8s %6s %6s  %-16s\n", "curriculum", "lesson", "attempts",
              "passes", "best", "passed", "date (UTC)");
  for (const auto& l : t.lessons()) {
    const std::string passes =
        std::to_string(l.passes()) + "/" + std::to_string(l.required_passes());
    std::printf("%-16s %-32s %8u %8s %6.1f %6s  %-16s\n", Shown(l.curriculum_id()).c_str(),
                Shown(l.lesson_id()).c_str(), l.attempts(), passes.c_str(), l.best_score(),
                l.completed() ? "yes" : "no",
                FormatDate(l.completed() ? l.completed_unix_ms() : l.last_attempt_unix_ms())
                    .c_str());
  }
  std::printf("next lesson: %s; verdicts pending: %u\n",
              t.next_lesson_id().empty() ? "none" : Shown(t.next_lesson_id()).c_str(),
              t.pending_verdicts());
}

// A group: one row per trainee, one numbered column per lesson ("yes", or
// "no/N" with N judged attempts), the numbers explained below the table.
void PrintGroupProgress(const ves::v1::GetProgressResponse& r) {
  std::vector<std::string> lessons;
  for (const auto& t : r.trainees()) {
    for (const auto& l : t.lessons()) {
      if (std::find(lessons.begin(), lessons.end(), l.lesson_id()) == lessons.end()) {
        lessons.push_back(l.lesson_id());
      }
    }
  }
  std::printf("%-20s", "trainee");
  for (size_t i = 0; i < lessons.size(); ++i) {
    std::printf(" %-7s", ("#" + std::to_string(i + 1)).c_str());
  }
  std::printf(" %-8s %s\n", "next", "pending");
  for (const auto& t : r.trainees()) {
    std::map<std::string, const ves::v1::LessonProgress*> by_id;
    for (const auto& l : t.lessons()) by_id[l.lesson_id()] = &l;
    std::printf("%-20s", Shown(t.trainee_id()).c_str());
    for (const auto& id : lessons) {
      auto it = by_id.find(id);
      std::string cell = "-";
      if (it != by_id.end()) {
        cell = it->second->completed() ? "yes"
                                       : "no/" + std::to_string(it->second->attempts());
      }
      std::printf(" %-7s", cell.c_str());
    }
    std::string next = "-";
    for (size_t i = 0; i < lessons.size(); ++i) {
      if (lessons[i] == t.next_lesson_id()) next = "#" + std::to_string(i + 1);
    }
    std::printf(" %-8s %u\n", next.c_str(), t.pending_verdicts());
  }
  for (size_t i = 0; i < lessons.size(); ++i) {
    std::printf("#%zu = %s\n", i + 1, Shown(lessons[i]).c_str());
  }
}

}  // namespace

int RunCurriculumCommand(const CommandArgs& args) {
  if (!args.empty() && (args[0] == "assign" || args[0] == "progress")) {
    const CommandArgs rest(args.begin() + 1, args.end());
    return args[0] == "assign" ? RunAssignCommand(rest) : RunProgressCommand(rest);
  }
  std::string action, file, institution;
  RemoteCommandLine line;
  line.Add()("action", po::value(&action)->required(), "create or list")(
      "file", po::value(&file), "create: the curriculum (textproto of ves.v1.Curriculum)")(
      "institution", po::value(&institution), "owner (default: the caller's; admins only)");
  line.Positional("action", 1).Positional("file", 1);
  if (const int rc = line.Parse("curriculum", "curriculum create FILE.textproto | list", args);
      rc >= 0)
    return rc;
  const ClientOptions& client = line.client();
  if (action == "create") {
    if (file.empty()) {
      std::cerr << "ves-admin curriculum create: give the curriculum FILE.textproto\n";
      return kExitUsage;
    }
    return CurriculumCreate(file, client, institution);
  }
  if (action == "list") return CurriculumList(client, institution);
  std::cerr << "ves-admin curriculum: unknown action '" << action
            << "' (create, list, assign or progress)\n";
  return kExitUsage;
}

int RunAssignCommand(const CommandArgs& args) {
  std::string curriculum, trainee, group;
  RemoteCommandLine line;
  line.Add()("curriculum", po::value(&curriculum)->required(), "curriculum id")(
      "trainee", po::value(&trainee), "one trainee")("group", po::value(&group), "a group");
  if (const int rc = line.Parse("assign", "assign --curriculum C --trainee T|--group G", args);
      rc >= 0)
    return rc;
  const ClientOptions& client = line.client();
  if (trainee.empty() == group.empty()) {
    std::cerr << "ves-admin assign: give exactly one of --trainee T and --group G\n";
    return kExitUsage;
  }
  ves::v1::AssignCurriculumRequest q;
  q.set_curriculum_id(curriculum);
  if (group.empty()) {
    q.set_trainee_id(trainee);
  } else {
    q.set_group(group);
  }
  ves::v1::AssignCurriculumResponse r;
  if (const int called = CallOnce("assign", client, *LessonsStub(client),
                                  &ves::v1::Lessons::Stub::AssignCurriculum, q, &r);
      called != kExitOk) {
    return called;
  }
  std::cout << "assigned " << curriculum << " to "
            << (group.empty() ? "trainee " + trainee : "group " + group) << " ("
            << r.trainee_ids_size() << " trainee(s) now)\n";
  return kExitOk;
}

int RunProgressCommand(const CommandArgs& args) {
  std::string trainee, group, institution;
  RemoteCommandLine line;
  line.Add()("trainee", po::value(&trainee), "one trainee")(
      "group", po::value(&group), "a group (table)")("institution", po::value(&institution),
                                                     "with --group: the group's institution");
  if (const int rc = line.Parse("progress", "progress --trainee T | --group G", args); rc >= 0)
    return rc;
  const ClientOptions& client = line.client();
  if (trainee.empty() == group.empty()) {
    std::cerr << "ves-admin progress: give exactly one of --trainee T and --group G\n";
    return kExitUsage;
  }
  ves::v1::GetProgressRequest q;
  if (group.empty()) {
    q.set_trainee_id(trainee);
  } else {
    q.set_group(group);
    q.set_institution(institution);
  }
  ves::v1::GetProgressResponse r;
  if (const int called = CallOnce("progress", client, *LessonsStub(client),
                                  &ves::v1::Lessons::Stub::GetProgress, q, &r);
      called != kExitOk) {
    return called;
  }
  if (group.empty()) {
    for (const auto& t : r.trainees()) PrintTraineeProgress(t);
  } else {
    PrintGroupProgress(r);
  }
  return kExitOk;
}

int RunGroupCommand(const CommandArgs& args) {
  std::string action, trainee, group;
  RemoteCommandLine line;
  line.Add()("action", po::value(&action)->required(), "set")(
      "trainee", po::value(&trainee)->required(), "trainee id")(
      "group", po::value(&group)->default_value(""), "group name (empty: none)");
  line.Positional("action", 1);
  if (const int rc = line.Parse("group", "group set --trainee T --group G", args); rc >= 0)
    return rc;
  const ClientOptions& client = line.client();
  if (action != "set") {
    std::cerr << "ves-admin group: unknown action '" << action << "' (only: set)\n";
    return kExitUsage;
  }
  ves::v1::SetTraineeGroupRequest q;
  q.set_trainee_id(trainee);
  q.set_group(group);
  ves::v1::SetTraineeGroupResponse r;
  if (const int called = CallOnce("group", client, *LessonsStub(client),
                                  &ves::v1::Lessons::Stub::SetTraineeGroup, q, &r);
      called != kExitOk) {
    return called;
  }
  std::cout << "trainee " << trainee << ": group " << (group.empty() ? "(none)" : group) << "\n";
  return kExitOk;
}

}  // namespace ves::admin
