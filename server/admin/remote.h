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
// "YYYY-MM-DD HH:MM" in UTC: the date column of the tables ves-admin prints.
std::string FormatUtcMinute(int64_t unix_ms);
// Calls a paginated List method (docs/server.md, "Limits") page after page
// until the last: `call(context, request, reply)` sends one, `each(reply)`
// sees every reply. Returns the first failure, else OK.
template <typename Response, typename Request, typename Call, typename Each>
grpc::Status ForEachPage(const ves::server::ClientOptions& client, Request request, Call call,
                         Each each) {
  for (;;) {
    grpc::ClientContext context;
    ves::server::PrepareContext(&context, client);
    Response reply;
    const grpc::Status status = call(&context, request, &reply);
    if (!status.ok()) return status;
    const bool more = each(reply);
    if (!more || reply.next_page_token().empty()) return status;
    request.set_page_token(reply.next_page_token());
  }
}

// A string from the server made safe for the terminal: control characters
// (an ANSI escape in a display name) escaped as \xNN, cut at 256 bytes.
std::string Shown(const std::string& text);
// Prints "ves-admin NAME: CODE: message" and returns kExitFailed.
int ReportRpcError(const std::string& name, int code, const std::string& message);

}  // namespace ves::admin
