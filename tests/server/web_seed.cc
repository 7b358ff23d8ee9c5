// Test fixture for tests/server/web_browser_test.py (not installed):
//   web_seed setup DB_URL
//     tokens, institution "north", trainees t1, t2 and one named like
//     markup, group g1, the sample case, supervisor account "dr.north"
//     (password in "account_password"); prints {"admin": ..., ...} as JSON.
//   web_seed upload GRPC_ADDRESS STATION_TOKEN TRAINEE OPERATOR SECONDS
//     a scripted operator's session on the sample case, uploaded as a station
//     does; prints {"uuid": ..., "final_tip_arc_m": ...} (the recording run's
//     own last tip depth, independent of the server's replay).
//   web_seed upload ... SECONDS STATION_ID faulty
//     the same from STATION_ID with a fixture StationHealth whose every
//     figure is out of range (the stations page's flags).
//   web_seed store DB_URL TRAINEE OPERATOR SECONDS
//     the same session written straight into the store (run before the
//     server starts), as a server before session series stored it: no
//     series; prints {"uuid": ..., "final_tip_arc_m": ...}.
//   web_seed lesson GRPC_ADDRESS SUPERVISOR_TOKEN STATION_TOKEN TRAINEE
//     creates curriculum "web-lessons" with one 3 s lesson on the sample case
//     ("web-first-seconds": no damage, under 30 s of pain), uploads the
//     scripted expert's session of it and waits (up to 60 s) for the
//     server's verdict; prints {"uuid", "lesson_id", "passed", "score"}.
//   web_seed assign GRPC_ADDRESS SUPERVISOR_TOKEN CURRICULUM GROUP
//     assigns the curriculum to the group (Lessons.AssignCurriculum).
#include <chrono>
#include <iostream>
#include <nlohmann/json.hpp>
#include <thread>

#include "patient_db/case_bundle.h"
#include "server/accounts.h"
#include "server/auth.h"
#include "server/client.h"
#include "station/training/case_run.h"
#include "tests/integration/test_server.h"
#include "ves/v1/services.grpc.pb.h"

namespace ts = ves::server::testing;
using ves::patient_db::StoreRole;

namespace {

std::string Token(ves::patient_db::Store& store, StoreRole role, const std::string& trainee = "") {
  const std::string token = ves::server::NewToken();
  ves::patient_db::TokenRow row{ves::server::Sha256Hex(token),
                                role,
                                "north",
                                trainee,
                                std::string(ves::patient_db::RoleName(role)) + " (web test)",
                                1};
  if (!store.AddToken(row).ok()) throw std::runtime_error("cannot add a token");
  return token;
}

// The station's upload of `record` with `client`; "" or why it was refused.
std::string Upload(const ves::server::ClientOptions& client, const ves::v1::SessionRecord& record) {
  ves::v1::UploadSessionRequest req;
  *req.mutable_record() = record;
  ves::v1::UploadSessionResponse resp;
  grpc::ClientContext ctx;
  ves::server::PrepareContext(&ctx, client);
  const grpc::Status s = ves::v1::Sessions::NewStub(ves::server::MakeClientChannel(client))
                             ->UploadSession(&ctx, req, &resp);
  return s.ok() ? "" : s.error_message();
}

int SeedPassedLesson(const std::string& address, const std::string& supervisor_token,
                     const std::string& station_token, const std::string& trainee) {
  ves::server::ClientOptions supervisor{};
  supervisor.address = address;
  supervisor.token = supervisor_token;
  ves::server::ClientOptions station = supervisor;
  station.token = station_token;
  const auto colon_case = ts::SampleCase();
  ves::v1::CreateCurriculumRequest create;
  ves::v1::Curriculum* c = create.mutable_curriculum();
  c->set_curriculum_id("web-lessons");
  c->set_title("Web lessons");
  ves::v1::Lesson* lesson = c->add_lessons();
  lesson->set_lesson_id("web-first-seconds");
  lesson->set_title("The first seconds");
  lesson->mutable_case_ref()->set_case_id(colon_case.id());
  lesson->mutable_aids()->set_fluoroscopy_allowed(true);
  lesson->mutable_aids()->set_wireframe_allowed(true);
  lesson->set_time_limit_s(3);
  lesson->mutable_pass()->set_max_damage_events(0);
  lesson->mutable_pass()->set_max_pain_s(30);
  lesson->set_required_passes(1);
  auto lessons = ves::v1::Lessons::NewStub(ves::server::MakeClientChannel(supervisor));
  ves::v1::CreateCurriculumResponse created;
  {
    grpc::ClientContext ctx;
    ves::server::PrepareContext(&ctx, supervisor);
    const grpc::Status s = lessons->CreateCurriculum(&ctx, create, &created);
    if (!s.ok()) {
      std::cerr << "web_seed: curriculum refused: " << s.error_message() << "\n";
      return 1;
    }
  }
  const ves::v1::Lesson& stored = created.curriculum().lessons(0);
  ves::v1::SessionRecord record;
  ves::training::RunScriptedCase(colon_case, stored.scope(), {}, "expert", stored.time_limit_s(),
                                 ves::server::NowUnixMs() - 60'000, &record);
  record.set_trainee_id(trainee);
  record.set_station_id("web-test-station");
  record.set_case_id(colon_case.id());
  record.set_case_version(colon_case.version());
  record.set_case_sha256_hex(ves::patient_db::CasePayloadSha256Hex(colon_case));
  record.set_lesson_id(stored.lesson_id());
  const std::string refused = Upload(station, record);
  if (!refused.empty()) {
    std::cerr << "web_seed: upload refused: " << refused << "\n";
    return 1;
  }
  // The judge replays it in the background.
  auto verdicts = ves::v1::Lessons::NewStub(ves::server::MakeClientChannel(station));
  for (int i = 0; i < 600; ++i) {
    grpc::ClientContext ctx;
    ves::server::PrepareContext(&ctx, station);
    ves::v1::GetLessonVerdictRequest q;
    q.set_session_uuid(record.uuid());
    ves::v1::GetLessonVerdictResponse r;
    const grpc::Status s = verdicts->GetLessonVerdict(&ctx, q, &r);
    if (!s.ok()) {
      std::cerr << "web_seed: verdict refused: " << s.error_message() << "\n";
      return 1;
    }
    if (r.judged()) {
      std::cout << nlohmann::json{{"uuid", record.uuid()},
                                  {"lesson_id", stored.lesson_id()},
                                  {"passed", r.verdict().passed()},
                                  {"score", record.score()}}
                       .dump()
                << "\n";
      return 0;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  std::cerr << "web_seed: no verdict for " << record.uuid() << " within 60 s\n";
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::string mode = argc > 1 ? argv[1] : "";
    if (mode == "setup" && argc == 3) {
      auto store = ves::patient_db::OpenStore(argv[2]);
      store->AddInstitution("north", 1);
      for (const char* id : {"t1", "t2", "<img src=x onerror=alert(1)>"}) {
        store->AddTrainee({id, "north", std::string("Trainee ") + id, 1});
      }
      store->SetTraineeGroup("t1", "g1");
      store->SetTraineeGroup("t2", "g1");
      ts::PutSampleCase(*store, "north");
      nlohmann::json out = {{"admin", Token(*store, StoreRole::kAdmin)},
                            {"supervisor", Token(*store, StoreRole::kSupervisor)},
                            {"station", Token(*store, StoreRole::kStation)}};
      const std::string password = "web test password " + ves::server::NewToken().substr(0, 8);
      if (!store
               ->AddAccount({"dr.north", StoreRole::kSupervisor, "north",
                             ves::server::HashPassword(password), "", 1, 0, 0})
               .ok()) {
        throw std::runtime_error("cannot add an account");
      }
      out["account"] = "dr.north";
      out["account_password"] = password;
      std::cout << out.dump() << "\n";
      return 0;
    }
    if (mode == "upload" && (argc == 7 || argc == 9)) {
      const auto colon_case = ts::SampleCase();
      ves::v1::SessionRecord record;
      double final_tip_arc_m = 0;
      ves::training::RunScriptedCase(
          colon_case, ves::v1::EndoscopeSpec(), {}, argv[5], std::stod(argv[6]),
          ves::server::NowUnixMs() - 60'000, &record,
          [&](const ves::training::InputSample&, const ves::training::SessionRunner& runner) {
            final_tip_arc_m = runner.observation().tip_arc_m;
          });
      record.set_trainee_id(argv[4]);
      record.set_station_id(argc == 9 ? argv[7] : "web-test-station");
      if (argc == 9 && std::string(argv[8]) == "faulty") {
        // A fixture, not a measurement: the health a station with a slow
        // loop, a bus-off and CAN errors would report, for the flags.
        auto* h = record.mutable_station_health();
        h->set_device("can:can0");
        h->set_loop_cycles(2000);
        h->set_loop_cycle_p99_us(1500);
        h->set_loop_budget_us(1000);
        h->set_loop_overruns(12);
        h->set_hard_faults(1);
        h->set_can_bus_errors(2);
      } else if (argc == 9) {
        std::cerr << "web_seed: HEALTH '" << argv[8] << "' must be faulty\n";
        return 2;
      }
      record.set_case_id(colon_case.id());
      record.set_case_version(colon_case.version());
      record.set_case_sha256_hex(ves::patient_db::CasePayloadSha256Hex(colon_case));
      ves::server::ClientOptions client;
      client.address = argv[2];
      client.token = argv[3];
      const std::string refused = Upload(client, record);
      if (!refused.empty()) {
        std::cerr << "web_seed: upload refused: " << refused << "\n";
        return 1;
      }
      std::cout << nlohmann::json{{"uuid", record.uuid()},
                                  {"final_tip_arc_m", final_tip_arc_m},
                                  {"score", record.score()}}
                       .dump()
                << "\n";
      return 0;
    }
    if (mode == "store" && argc == 6) {
      const auto colon_case = ts::SampleCase();
      ves::v1::SessionRecord record;
      double final_tip_arc_m = 0;
      ves::training::RunScriptedCase(
          colon_case, ves::v1::EndoscopeSpec(), {}, argv[4], std::stod(argv[5]),
          ves::server::NowUnixMs() - 120'000, &record,
          [&](const ves::training::InputSample&, const ves::training::SessionRunner& runner) {
            final_tip_arc_m = runner.observation().tip_arc_m;
          });
      record.set_trainee_id(argv[3]);
      record.set_station_id("web-test-station");
      record.set_case_id(colon_case.id());
      record.set_case_version(colon_case.version());
      record.set_case_sha256_hex(ves::patient_db::CasePayloadSha256Hex(colon_case));
      ves::patient_db::SessionRow row;
      row.uuid = record.uuid();
      row.trainee_id = record.trainee_id();
      row.institution = "north";
      row.case_id = record.case_id();
      row.case_version = record.case_version();
      row.station_id = record.station_id();
      row.start_unix_ms = record.start_unix_ms();
      row.end_unix_ms = record.end_unix_ms();
      row.completed = record.metrics().completed();
      row.score = record.score();
      row.body = record.SerializeAsString();
      row.body_sha256_hex = ves::server::Sha256Hex(row.body);
      row.stored_unix_ms = ves::server::NowUnixMs();
      ves::patient_db::WriteBatch batch;
      batch.sessions.push_back(std::move(row));
      if (!ves::patient_db::OpenStore(argv[2])->CommitBatch(batch).ok()) {
        std::cerr << "web_seed: cannot store the session\n";
        return 1;
      }
      std::cout
          << nlohmann::json{{"uuid", record.uuid()}, {"final_tip_arc_m", final_tip_arc_m}}.dump()
          << "\n";
      return 0;
    }
    if (mode == "lesson" && argc == 6) return SeedPassedLesson(argv[2], argv[3], argv[4], argv[5]);
    if (mode == "assign" && argc == 6) {
      ves::server::ClientOptions supervisor{};
      supervisor.address = argv[2];
      supervisor.token = argv[3];
      ves::v1::AssignCurriculumRequest req;
      req.set_curriculum_id(argv[4]);
      req.set_group(argv[5]);
      ves::v1::AssignCurriculumResponse resp;
      grpc::ClientContext ctx;
      ves::server::PrepareContext(&ctx, supervisor);
      const grpc::Status s = ves::v1::Lessons::NewStub(ves::server::MakeClientChannel(supervisor))
                                 ->AssignCurriculum(&ctx, req, &resp);
      if (!s.ok()) {
        std::cerr << "web_seed: assignment refused: " << s.error_message() << "\n";
        return 1;
      }
      return 0;
    }
    std::cerr << "usage: web_seed setup DB_URL | web_seed upload ADDRESS TOKEN TRAINEE "
                 "OPERATOR SECONDS [STATION_ID faulty] | web_seed store DB_URL TRAINEE OPERATOR "
                 "SECONDS | web_seed lesson ADDRESS SUPERVISOR_TOKEN STATION_TOKEN TRAINEE | "
                 "web_seed assign ADDRESS SUPERVISOR_TOKEN CURRICULUM GROUP\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "web_seed: " << e.what() << "\n";
    return 1;
  }
}
