#pragma once

#include <boost/program_options.hpp>
#include <cstdint>
#include <string>

#include "server/admin/commands.h"
#include "server/client.h"

// Shared by the ves-admin subcommands that talk to a running ves-server:
// --server, --token (or $VES_TOKEN), TLS files, deadline; parsing with one
// clear error line and exit status 2.
namespace ves::admin {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailed = 1;
inline constexpr int kExitUsage = 2;

void AddRemoteOptions(boost::program_options::options_description* options,
                      ves::server::ClientOptions* client, int* deadline_s);
// Parses `args`; returns -1 to go on, else the exit status (help or error).
// Fills the client's deadline and $VES_TOKEN fallback.
int ParseRemote(const std::string& name, const std::string& usage, const CommandArgs& args,
                const boost::program_options::options_description& options,
                const boost::program_options::positional_options_description* positional,
                boost::program_options::variables_map* vm, ves::server::ClientOptions* client,
                int deadline_s);
// The command line of a subcommand that talks to a running ves-server: the
// shared options (AddRemoteOptions) and the subcommand's own.
class RemoteCommandLine {
 public:
  RemoteCommandLine() { AddRemoteOptions(&options_, &client_, &deadline_s_); }
  RemoteCommandLine(const RemoteCommandLine&) = delete;
  RemoteCommandLine& operator=(const RemoteCommandLine&) = delete;

  // The subcommand's own options, as options_description::add_options.
  boost::program_options::options_description_easy_init Add() { return options_.add_options(); }
  // A positional argument, as positional_options_description::add.
  RemoteCommandLine& Positional(const char* name, int max_count) {
    positional_.add(name, max_count);
    return *this;
  }
  // As ParseRemote: -1 to go on, else the exit status (help or an error).
  int Parse(const std::string& name, const std::string& usage, const CommandArgs& args) {
    return ParseRemote(name, usage, args, options_,
                       positional_.max_total_count() > 0 ? &positional_ : nullptr, &vm_, &client_,
                       deadline_s_);
  }
  const ves::server::ClientOptions& client() const { return client_; }
  // Whether the (switch) option was given.
  bool Has(const std::string& option) const { return vm_.count(option) > 0; }

 private:
  ves::server::ClientOptions client_;
  int deadline_s_ = 30;
  boost::program_options::options_description options_{"options"};
  boost::program_options::positional_options_description positional_;
  boost::program_options::variables_map vm_;
};

// "YYYY-MM-DD HH:MM" in UTC: the date column of the tables ves-admin prints.
std::string FormatUtcMinute(int64_t unix_ms);
// A string from the server made safe for the terminal: control characters
// (an ANSI escape in a display name) escaped as \xNN, cut at 256 bytes.
std::string Shown(const std::string& text);
// Prints "ves-admin NAME: CODE: message" and returns kExitFailed.
int ReportRpcError(const std::string& name, int code, const std::string& message);

// Sends `request` to the unary method `method` of `stub` and fills `reply`.
// Returns the exit status: kExitOk, or the failure, reported as `name`.
template <typename Stub, typename Request, typename Response>
int CallOnce(const std::string& name, const ves::server::ClientOptions& client, Stub& stub,
             grpc::Status (Stub::*method)(grpc::ClientContext*, const Request&, Response*),
             const Request& request, Response* reply) {
  grpc::ClientContext context;
  ves::server::PrepareContext(&context, client);
  const grpc::Status status = (stub.*method)(&context, request, reply);
  if (!status.ok()) return ReportRpcError(name, status.error_code(), status.error_message());
  return kExitOk;
}

// Calls the paginated List method `method` of `stub` (docs/server.md,
// "Limits") page after page until the last: `each(reply)` sees every reply
// and returns false to stop early. Returns the exit status: kExitOk, or the
// first failure, reported as `name` (ReportRpcError).
template <typename Stub, typename Request, typename Response, typename Each>
int ListAllPages(const std::string& name, const ves::server::ClientOptions& client, Stub& stub,
                 grpc::Status (Stub::*method)(grpc::ClientContext*, const Request&, Response*),
                 Request request, Each each) {
  for (;;) {
    grpc::ClientContext context;
    ves::server::PrepareContext(&context, client);
    Response reply;
    const grpc::Status status = (stub.*method)(&context, request, &reply);
    if (!status.ok()) return ReportRpcError(name, status.error_code(), status.error_message());
    if (!each(reply) || reply.next_page_token().empty()) return kExitOk;
    request.set_page_token(reply.next_page_token());
  }
}

}  // namespace ves::admin
