// Test fixture for tests/server/web_browser_test.py (not installed):
//   web_seed setup DB_URL
//     tokens, institution "north", trainees t1, t2 and one named like
//     markup, group g1, the sample case; prints {"admin": ..., ...} as JSON.
//   web_seed upload GRPC_ADDRESS STATION_TOKEN TRAINEE OPERATOR SECONDS
//     a scripted operator's session on the sample case, uploaded as a station
//     does; prints {"uuid": ..., "final_tip_arc_m": ...} (the recording run's
//     own last tip depth, independent of the server's replay).
//   web_seed upload ... SECONDS STATION_ID faulty
//     the same from STATION_ID with a fixture StationHealth whose every
//     figure is out of range (the stations page's flags).
#include <iostream>
#include <nlohmann/json.hpp>

#include "patient_db/case_bundle.h"
#include "server/client.h"
#include "station/training/case_run.h"
#include "tests/integration/test_server.h"
#include "ves/v1/services.grpc.pb.h"

namespace ts = ves::server::testing;
using ves::patient_db::StoreRole;

namespace {

std::string Token(ves::patient_db::Store& store, StoreRole role, const std::string& trainee = "") {
  const std::string token = ves::server::NewToken();
  ves::patient_db::TokenRow row{ves::server::Sha256HexOf(token),
                                role,
                                "north",
                                trainee,
                                std::string(ves::patient_db::RoleName(role)) + " (web test)",
                                1};
  if (!store.AddToken(row).ok()) throw std::runtime_error("cannot add a token");
  return token;
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
        h->set_safe_state_entries(1);
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
      ves::v1::UploadSessionRequest req;
      *req.mutable_record() = record;
      ves::v1::UploadSessionResponse resp;
      grpc::ClientContext ctx;
      ves::server::PrepareContext(&ctx, client);
      const grpc::Status s = ves::v1::Sessions::NewStub(ves::server::MakeClientChannel(client))
                                 ->UploadSession(&ctx, req, &resp);
      if (!s.ok()) {
        std::cerr << "web_seed: upload refused: " << s.error_message() << "\n";
        return 1;
      }
      std::cout << nlohmann::json{{"uuid", record.uuid()},
                                  {"final_tip_arc_m", final_tip_arc_m},
                                  {"score", record.score()}}
                       .dump()
                << "\n";
      return 0;
    }
    std::cerr << "usage: web_seed setup DB_URL | web_seed upload ADDRESS TOKEN TRAINEE "
                 "OPERATOR SECONDS [STATION_ID faulty]\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "web_seed: " << e.what() << "\n";
    return 1;
  }
}
