// Replies' pages and tokens and the proto role:
// the small helpers the handlers of every service share (server/services.h).
#include <algorithm>
#include <charconv>

#include "patient_db/limits.h"
#include "server/services.h"

namespace ves::server {

using grpc::Status;
using grpc::StatusCode;
using patient_db::StoreRole;

ves::v1::Role ToProtoRole(StoreRole role) { return static_cast<ves::v1::Role>(role); }

int PageSizeOf(uint32_t requested, int default_size) {
  if (requested == 0) return default_size;
  return static_cast<int>(std::min<uint32_t>(requested, patient_db::kMaxPageSize));
}

std::string MakePageToken(const std::string& listing, int64_t number, const std::string& text) {
  return listing + ":" + std::to_string(number) + ":" + text;
}

Status ReadPageToken(const std::string& token, const std::string& listing,
                     patient_db::ListPage* page) {
  if (token.empty()) return Status::OK;
  const auto bad = [&] {
    return Status(StatusCode::INVALID_ARGUMENT,
                  "page_token = '" + patient_db::PrintableExcerpt(token, 40) +
                      "': not a next_page_token of this listing");
  };
  if (token.compare(0, listing.size() + 1, listing + ":") != 0) return bad();
  const size_t number_end = token.find(':', listing.size() + 1);
  if (number_end == std::string::npos) return bad();
  const std::string number = token.substr(listing.size() + 1, number_end - listing.size() - 1);
  int64_t value = 0;
  const auto [end, ec] = std::from_chars(number.data(), number.data() + number.size(), value);
  if (number.empty() || ec != std::errc() || end != number.data() + number.size()) return bad();
  page->has_after = true;
  page->after_number = value;
  page->after_text = token.substr(number_end + 1);
  return Status::OK;
}
}  // namespace ves::server
