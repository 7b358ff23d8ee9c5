#pragma once

#include <cstddef>
#include <string_view>

// The pages, scripts and styles of the web front end, built into the binary
// from server/web/ and Debian's Chart.js (server/CMakeLists.txt).
namespace ves::server {

struct WebAsset {
  const char* path;  // "/index.html"
  const char* content_type;
  const char* data;
  size_t size;
};

// nullptr when there is no such asset.
const WebAsset* FindWebAsset(std::string_view path);

}  // namespace ves::server
