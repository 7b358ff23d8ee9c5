// Every gRPC method the server registers answers through the request pipeline
// (server/pipeline.h): the methods are enumerated from the service
// descriptors of proto/ves/v1 (services.proto, live.proto), so a new method
// is covered without touching this test. Each is called over real gRPC with
// a generic stub (unary and streaming alike):
//   - with a bad token: UNAUTHENTICATED, and no audit row (AdmitRequest is not
//     audited: there is nobody to name yet; docs/server.md, "Audit log");
//   - with a field over its bound: INVALID_ARGUMENT naming the field; a unary
//     or server-streaming request is bounded before authentication, so no
//     audit row, while a client stream's message is bounded as it arrives,
//     after the call was admitted: that ending is the call's one audit row;
//   - with a message over the transport's cap (--max-message-mb):
//     RESOURCE_EXHAUSTED from gRPC itself, before any handler: no audit row,
//     except for a client stream, admitted before its message came;
//   - with a trainee's token: a role refusal (PERMISSION_DENIED) is audited.
#include <google/protobuf/descriptor.h>
#include <google/protobuf/dynamic_message.h>
#include <google/protobuf/message.h>
#include <grpcpp/generic/generic_stub.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "patient_db/limits.h"
#include "server/client.h"
#include "tests/integration/test_server.h"
#include "ves/v1/live.pb.h"
#include "ves/v1/services.pb.h"

namespace ves::server::testing {
namespace {

using google::protobuf::Descriptor;
using google::protobuf::FieldDescriptor;
using google::protobuf::Message;
using google::protobuf::MethodDescriptor;
using grpc::StatusCode;
using patient_db::StoreRole;

constexpr const char* kProtoFiles[] = {"ves/v1/services.proto", "ves/v1/live.proto"};

std::vector<const MethodDescriptor*> RegisteredMethods() {
  std::vector<const MethodDescriptor*> methods;
  const auto* pool = google::protobuf::DescriptorPool::generated_pool();
  for (const char* name : kProtoFiles) {
    const auto* file = pool->FindFileByName(name);
    EXPECT_NE(file, nullptr) << name;
    if (file == nullptr) continue;
    for (int s = 0; s < file->service_count(); ++s) {
      for (int m = 0; m < file->service(s)->method_count(); ++m) {
        methods.push_back(file->service(s)->method(m));
      }
    }
  }
  return methods;
}

std::string PathOf(const MethodDescriptor& m) {
  return "/" + m.service()->full_name() + "/" + m.name();
}

std::unique_ptr<Message> NewRequest(const MethodDescriptor& m) {
  const Message* prototype =
      google::protobuf::MessageFactory::generated_factory()->GetPrototype(m.input_type());
  return std::unique_ptr<Message>(prototype->New());
}

// Fills the first string or bytes field of `message` (depth first through
// singular message fields) with `bytes` bytes of 'a' when `bytes` > 0, or
// with one byte more than its bound when `bytes` is 0; returns the field's
// path below the message ("header.file_label"), empty when it has none.
std::string Oversize(Message* message, size_t bytes) {
  const Descriptor* d = message->GetDescriptor();
  const auto* r = message->GetReflection();
  for (int i = 0; i < d->field_count(); ++i) {
    const FieldDescriptor* f = d->field(i);
    if (f->cpp_type() != FieldDescriptor::CPPTYPE_STRING || f->is_repeated()) continue;
    const size_t n = bytes > 0 ? bytes : patient_db::LimitOf(*f).max_bytes + 1;
    r->SetString(message, f, std::string(n, 'a'));
    return f->name();
  }
  for (int i = 0; i < d->field_count(); ++i) {
    const FieldDescriptor* f = d->field(i);
    if (f->cpp_type() != FieldDescriptor::CPPTYPE_MESSAGE || f->is_repeated()) continue;
    const std::string below = Oversize(r->MutableMessage(message, f), bytes);
    if (!below.empty()) return f->name() + "." + below;
    r->ClearField(message, f);
  }
  return {};
}

// One call of any kind (unary or streaming) with `messages` as its requests;
// the replies are read and dropped. The call's status.
grpc::Status CallRaw(const std::shared_ptr<grpc::Channel>& channel, const std::string& path,
                     const std::string& token, const std::vector<std::string>& messages) {
  grpc::GenericStub stub(channel);
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  if (!token.empty()) ctx.AddMetadata("authorization", "Bearer " + token);
  grpc::CompletionQueue cq;
  auto call = stub.PrepareCall(&ctx, path, &cq);
  const auto wait = [&](intptr_t expected) {
    void* tag = nullptr;
    bool ok = false;
    EXPECT_TRUE(cq.Next(&tag, &ok));
    EXPECT_EQ(reinterpret_cast<intptr_t>(tag), expected);
    return ok;
  };
  call->StartCall(reinterpret_cast<void*>(1));
  bool open = wait(1);
  for (const std::string& bytes : messages) {
    if (!open) break;
    grpc::Slice slice(bytes);
    grpc::ByteBuffer buffer(&slice, 1);
    call->Write(buffer, reinterpret_cast<void*>(2));
    open = wait(2);
  }
  if (open) {
    call->WritesDone(reinterpret_cast<void*>(3));
    wait(3);
  }
  for (;;) {
    grpc::ByteBuffer reply;
    call->Read(&reply, reinterpret_cast<void*>(4));
    if (!wait(4)) break;
  }
  grpc::Status status;
  call->Finish(&status, reinterpret_cast<void*>(5));
  wait(5);
  cq.Shutdown();
  void* tag = nullptr;
  bool ok = false;
  while (cq.Next(&tag, &ok)) {
  }
  return status;
}

class GrpcRoutesPipeline : public ::testing::Test {
 protected:
  GrpcRoutesPipeline() {
    admin_ = server_.MakeToken(StoreRole::kAdmin, "north");
    server_.AddTrainee("t1", "north");
    trainee_ = server_.MakeToken(StoreRole::kTrainee, "north", "t1");
    channel_ = MakeClientChannel(server_.Client(admin_));
  }

  // The audit rows written since the last call of this (an audited marker
  // call, waited for, closes each span: the group commit writes in order).
  std::vector<patient_db::AuditRow> AuditSinceLast() {
    const std::string marker = "marker-" + std::to_string(++markers_);
    ves::v1::ListTraineesRequest list;
    list.set_institution(marker);
    std::string bytes;
    list.SerializeToString(&bytes);
    EXPECT_TRUE(CallRaw(channel_, "/ves.v1.Trainees/ListTrainees", admin_, {bytes}).ok());
    std::vector<patient_db::AuditRow> rows;
    for (int attempt = 0; attempt < 500; ++attempt) {
      rows = server_.store().ListAudit(0, 100000).value;
      if (!rows.empty() && rows.back().target == marker) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    EXPECT_TRUE(!rows.empty() && rows.back().target == marker) << "marker row not written";
    std::vector<patient_db::AuditRow> span(rows.begin() + seen_, rows.end() - 1);
    seen_ = rows.size();
    return span;
  }

  TestServer server_;
  std::string admin_;
  std::string trainee_;
  std::shared_ptr<grpc::Channel> channel_;
  int markers_ = 0;
  size_t seen_ = 0;
};

std::string Describe(const std::vector<patient_db::AuditRow>& rows) {
  std::string out;
  for (const auto& r : rows) out += "\n  " + r.action + " " + r.target + " " + r.result;
  return out;
}

TEST_F(GrpcRoutesPipeline, EveryMethodIsBoundedAuthenticatedAndAudited) {
  const auto methods = RegisteredMethods();
  ASSERT_GE(methods.size(), 20u) << "the services' descriptors were not linked in";
  AuditSinceLast();
  for (const MethodDescriptor* method : methods) {
    SCOPED_TRACE(PathOf(*method));
    const std::string path = PathOf(*method);
    const bool client_stream = method->client_streaming();
    std::string empty;
    NewRequest(*method)->SerializeToString(&empty);

    // A bad token: the pipeline's answer, and nobody to name in an audit row.
    const grpc::Status bad_token = CallRaw(channel_, path, std::string(64, '0'), {empty});
    EXPECT_EQ(bad_token.error_code(), StatusCode::UNAUTHENTICATED) << bad_token.error_message();
    EXPECT_TRUE(AuditSinceLast().empty());

    // A field over its bound, with a valid token.
    auto oversized = NewRequest(*method);
    const std::string field = Oversize(oversized.get(), 0);
    ASSERT_FALSE(field.empty()) << "no string field to oversize in "
                                << method->input_type()->name();
    std::string bytes;
    oversized->SerializeToString(&bytes);
    const grpc::Status bounded = CallRaw(channel_, path, admin_, {bytes});
    EXPECT_EQ(bounded.error_code(), StatusCode::INVALID_ARGUMENT) << bounded.error_message();
    EXPECT_NE(bounded.error_message().find("." + field), std::string::npos)
        << "names " << field << ": " << bounded.error_message();
    EXPECT_NE(bounded.error_message().find("more than"), std::string::npos)
        << bounded.error_message();
    const auto bounded_rows = AuditSinceLast();
    if (client_stream) {
      // Admitted at the stream's start: its ending is its one audit row.
      ASSERT_EQ(bounded_rows.size(), 1u) << Describe(bounded_rows);
      EXPECT_EQ(bounded_rows[0].result.rfind("INVALID_ARGUMENT: ", 0), 0u)
          << Describe(bounded_rows);
      EXPECT_EQ(bounded_rows[0].role, "admin");
    } else {
      EXPECT_TRUE(bounded_rows.empty()) << Describe(bounded_rows);
    }

    // Over the transport's cap (16 MiB by default): refused by gRPC itself.
    auto huge = NewRequest(*method);
    ASSERT_FALSE(Oversize(huge.get(), 17u << 20).empty());
    std::string huge_bytes;
    huge->SerializeToString(&huge_bytes);
    const grpc::Status capped = CallRaw(channel_, path, admin_, {huge_bytes});
    EXPECT_EQ(capped.error_code(), StatusCode::RESOURCE_EXHAUSTED) << capped.error_message();
    if (client_stream) {
      // The stream was admitted before its message came: the reactor ends
      // it when gRPC cancels the call, and that ending is audited (it may
      // reach the writer after the client heard the status).
      auto rows = AuditSinceLast();
      for (int attempt = 0; attempt < 100 && rows.empty(); ++attempt) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        const auto more = AuditSinceLast();
        rows.insert(rows.end(), more.begin(), more.end());
      }
      ASSERT_EQ(rows.size(), 1u) << Describe(rows);
      EXPECT_EQ(rows[0].role, "admin");
    } else {
      const auto rows = AuditSinceLast();
      EXPECT_TRUE(rows.empty()) << Describe(rows);
    }

    // A role refusal is audited (methods a trainee may call answer otherwise).
    const grpc::Status as_trainee = CallRaw(channel_, path, trainee_, {empty});
    EXPECT_NE(as_trainee.error_code(), StatusCode::UNIMPLEMENTED) << "not registered";
    const auto trainee_rows = AuditSinceLast();
    if (as_trainee.error_code() == StatusCode::PERMISSION_DENIED) {
      ASSERT_EQ(trainee_rows.size(), 1u) << Describe(trainee_rows);
      EXPECT_EQ(trainee_rows[0].role, "trainee");
      EXPECT_EQ(trainee_rows[0].result.rfind("PERMISSION_DENIED: ", 0), 0u)
          << Describe(trainee_rows);
    }
  }
}

}  // namespace
}  // namespace ves::server::testing
