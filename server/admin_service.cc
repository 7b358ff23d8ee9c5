// The Admin service: tokens, the audit log and the stations' reports.
#include "patient_db/limits.h"
#include "server/pipeline.h"
#include "server/services.h"

namespace ves::server {

using grpc::Status;
using grpc::StatusCode;
using patient_db::StoreRole;

namespace {

void ToStationHealth(const patient_db::StationHealthRow& h, ves::v1::StationHealth* out) {
  out->set_device(h.device);
  out->set_loop_cycles(h.loop_cycles);
  out->set_loop_cycle_p99_us(h.loop_cycle_p99_us);
  out->set_loop_budget_us(h.loop_budget_us);
  out->set_loop_overruns(h.loop_overruns);
  out->set_hard_faults(h.hard_faults);
  out->set_transient_faults(h.transient_faults);
  out->set_can_bus_errors(h.can_bus_errors);
  out->set_can_lost_frames(h.can_lost_frames);
  out->set_can_send_failures(h.can_send_failures);
  out->set_can_malformed_frames(h.can_malformed_frames);
}

}  // namespace

Status CreateTokenCall(const ServiceDeps& deps, const Principal& who,
                       const ves::v1::CreateTokenRequest& request,
                       ves::v1::CreateTokenResponse* response) {
  const std::string institution =
      request.institution().empty() ? who.institution : request.institution();
  static const CallSpec spec{"token.create", {StoreRole::kAdmin}, "create tokens"};
  const std::string target =
      std::string(patient_db::RoleName(static_cast<StoreRole>(
          request.role() >= 1 && request.role() <= 4 ? request.role() : 4))) +
      "@" + institution;
  return RunCall(deps, who, spec, target, [&]() -> Status {
    const int role = request.role();
    if (role < 1 || role > 4) {
      return Status(StatusCode::INVALID_ARGUMENT,
                    "role = " + std::to_string(role) + ": must be admin, supervisor, station "
                    "or trainee");
    }
    if (!patient_db::IsPrintableId(institution)) {
      return Status(StatusCode::INVALID_ARGUMENT,
                    "institution = '" + institution + "': not a valid name");
    }
    patient_db::TokenRow row;
    row.role = static_cast<StoreRole>(role);
    row.institution = institution;
    row.label = request.label();
    row.created_unix_ms = NowUnixMs();
    if (row.role == StoreRole::kTrainee) {
      auto trainee = deps.store->GetTrainee(request.trainee_id());
      if (!trainee.ok()) {
        return Status(StatusCode::FAILED_PRECONDITION,
                      "trainee_id = '" + request.trainee_id() + "': " + trainee.status.message);
      }
      if (trainee.value.institution != institution) {
        return Status(StatusCode::INVALID_ARGUMENT,
                      "trainee '" + request.trainee_id() + "' belongs to institution '" +
                          trainee.value.institution + "', not '" + institution + "'");
      }
      row.trainee_id = request.trainee_id();
    }
    auto st = deps.store->AddInstitution(institution, row.created_unix_ms);
    const std::string token = NewToken();
    row.token_sha256_hex = Sha256Hex(token);
    if (st.ok()) st = deps.store->AddToken(row);
    if (!st.ok()) return ToGrpcStatus(st);
    response->set_token(token);
    response->set_token_id(TokenIdOf(row.token_sha256_hex));
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* AdminService::CreateToken(grpc::CallbackServerContext* ctx,
                                                    const ves::v1::CreateTokenRequest* request,
                                                    ves::v1::CreateTokenResponse* response) {
  return ServeUnary(ctx, deps_, request, response, &CreateTokenCall);
}

Status ListAuditCall(const ServiceDeps& deps, const Principal& who,
                     const ves::v1::ListAuditRequest& request,
                     ves::v1::ListAuditResponse* response) {
  static const CallSpec spec{"audit.list",
                             {StoreRole::kAdmin},
                             "read the audit log",
                             /*audit_every_call=*/false};
  return RunCall(deps, who, spec, "", [&]() -> Status {
    const int size = PageSizeOf(request.limit(), patient_db::kMaxPageSize);
    patient_db::ListPage page;
    const Status token = ReadPageToken(request.page_token(), "audit", &page);
    if (!token.ok()) return token;
    auto rows = deps.store->ListAudit(request.since_unix_ms(), size + 1,
                                      page.has_after ? page.after_number : 0);
    if (!rows.ok()) return ToGrpcStatus(rows.status);
    if (static_cast<int>(rows.value.size()) > size) {
      rows.value.resize(size);
      response->set_next_page_token(MakePageToken("audit", rows.value.back().id, ""));
    }
    for (const auto& r : rows.value) {
      auto* e = response->add_entries();
      e->set_id(r.id);
      e->set_at_unix_ms(r.at_unix_ms);
      e->set_actor(r.actor);
      e->set_actor_label(r.actor_label);
      StoreRole role = StoreRole::kTrainee;
      e->set_role(patient_db::ParseRoleName(r.role, &role) ? ToProtoRole(role)
                                                           : ves::v1::ROLE_UNSPECIFIED);
      e->set_institution(r.institution);
      e->set_action(r.action);
      e->set_target(r.target);
      e->set_result(r.result);
    }
    return Status::OK;
  });
}

Status ListStationsCall(const ServiceDeps& deps, const Principal& who,
                        const ves::v1::ListStationsRequest& request,
                        ves::v1::ListStationsResponse* response) {
  const std::string institution =
      request.institution().empty() ? who.institution : request.institution();
  static const CallSpec spec{
      "station.list", {StoreRole::kAdmin, StoreRole::kSupervisor}, "list stations"};
  return RunCall(deps, who, spec, institution, [&]() -> Status {
    AuthStatus a = RequireInstitution(who, institution, "list the stations");
    if (!a.ok()) return ToGrpcStatus(a);
    patient_db::ListPage page;
    const Status token = ReadPageToken(request.page_token(), "stations", &page);
    if (!token.ok()) return token;
    const int size = PageSizeOf(request.page_size());
    page.limit = size + 1;  // one more tells whether a next page exists
    auto rows = deps.store->ListStations(institution, page);
    if (!rows.ok()) return ToGrpcStatus(rows.status);
    for (int i = 0; i < static_cast<int>(rows.value.size()) && i < size; ++i) {
      const patient_db::StationRow& r = rows.value[i];
      auto* out = response->add_stations();
      out->set_station_id(r.station_id);
      out->set_institution(r.institution);
      out->set_last_seen_unix_ms(r.last_seen_unix_ms);
      out->set_software_version(r.software_version);
      if (r.has_health) {
        ToStationHealth(r.health, out->mutable_health());
        out->set_health_session_uuid(r.health_session_uuid);
        out->set_health_session_end_unix_ms(r.health_session_end_unix_ms);
      }
      if (i + 1 == size && i + 1 < static_cast<int>(rows.value.size())) {
        response->set_next_page_token(MakePageToken("stations", 0, r.station_id));
      }
    }
    return Status::OK;
  });
}

grpc::ServerUnaryReactor* AdminService::ListStations(grpc::CallbackServerContext* ctx,
                                                     const ves::v1::ListStationsRequest* request,
                                                     ves::v1::ListStationsResponse* response) {
  return ServeUnary(ctx, deps_, request, response, &ListStationsCall);
}

grpc::ServerUnaryReactor* AdminService::ListAudit(grpc::CallbackServerContext* ctx,
                                                  const ves::v1::ListAuditRequest* request,
                                                  ves::v1::ListAuditResponse* response) {
  return ServeUnary(ctx, deps_, request, response, &ListAuditCall);
}

}  // namespace ves::server
