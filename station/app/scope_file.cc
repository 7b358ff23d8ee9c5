#include "station/app/scope_file.h"

#include <google/protobuf/text_format.h>

#include <fstream>
#include <iterator>
#include <stdexcept>

namespace ves::station {

ves::v1::EndoscopeSpec ReadScopeFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument("cannot read scope file '" + path + "'");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ves::v1::EndoscopeSpec spec;
  if (!google::protobuf::TextFormat::ParseFromString(text, &spec)) {
    throw std::invalid_argument("scope file '" + path + "' is not an EndoscopeSpec textproto");
  }
  return spec;
}

}  // namespace ves::station
