#pragma once

#include "server/services.h"
#include "ves/v1/live.grpc.pb.h"

namespace ves::server {

// Live.StreamSession: a station streams a running session's frames into the
// LiveHub (docs/web.md, "Live proctoring").
class LiveService final : public ves::v1::Live::CallbackService {
 public:
  explicit LiveService(ServiceDeps deps) : deps_(deps) {}
  grpc::ServerReadReactor<ves::v1::LiveFrame>* StreamSession(
      grpc::CallbackServerContext* ctx, ves::v1::LiveStreamSummary* response) override;

 private:
  ServiceDeps deps_;
};

}  // namespace ves::server
