#include "patient_db/case_format.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <system_error>

namespace ves::patient_db {
namespace {

bool EndsWith(const std::string& text, const std::string& suffix) {
  return text.size() >= suffix.size() &&
         text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace

std::optional<CaseFileKind> CaseFileKindOf(const std::filesystem::path& path) {
  const std::string name = path.filename().string();
  if (EndsWith(name, ".mrk.json")) return CaseFileKind::kSlicerMarkups;
  if (EndsWith(name, ".textproto")) return CaseFileKind::kTextproto;
  if (EndsWith(name, ".vescase")) return CaseFileKind::kBundle;
  if (EndsWith(name, ".csv")) return CaseFileKind::kCsv;
  return std::nullopt;
}

std::filesystem::path MarkupsLandmarksPath(const std::filesystem::path& markups_path) {
  std::string name = markups_path.filename().string();
  if (EndsWith(name, ".mrk.json")) name.resize(name.size() - 9);
  return markups_path.parent_path() / (name + ".regions.mrk.json");
}

std::filesystem::path MarkupsRadiusSidecarPath(const std::filesystem::path& markups_path) {
  std::string name = markups_path.filename().string();
  if (EndsWith(name, ".mrk.json")) name.resize(name.size() - 9);
  return markups_path.parent_path() / (name + ".radius.csv");
}

std::string ReadFileBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw CaseError(path.string(), "(file)", -1, "", std::string("cannot open: ") +
                                                         std::strerror(errno));
  }
  std::ostringstream bytes;
  bytes << in.rdbuf();
  if (in.bad()) throw CaseError(path.string(), "(file)", -1, "", "read failed");
  return bytes.str();
}

ves::v1::ColonCase LoadCaseFile(const std::filesystem::path& path, const ImportOptions& import) {
  const std::string label = path.string();
  const auto kind = CaseFileKindOf(path);
  if (!kind) {
    throw CaseError(label, "(file)", -1, path.extension().string(),
                    "unsupported extension (.textproto, .vescase, .csv, .mrk.json)");
  }
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw CaseError(label, "(file)", -1, "", "is a directory");
  }
  const std::string bytes = ReadFileBytes(path);
  switch (*kind) {
    case CaseFileKind::kTextproto: {
      auto colon_case = ParseCaseTextproto(bytes, label);
      CheckCase(colon_case, label);
      return colon_case;
    }
    case CaseFileKind::kBundle:
      return DecodeCaseBundle(bytes, label);
    case CaseFileKind::kCsv:
      return ImportCenterlineCsv(bytes, label, import);
    case CaseFileKind::kSlicerMarkups: {
      const auto sidecar_path = MarkupsRadiusSidecarPath(path);
      std::optional<std::string> sidecar;
      if (std::filesystem::exists(sidecar_path, ec)) sidecar = ReadFileBytes(sidecar_path);
      const auto landmarks_path = MarkupsLandmarksPath(path);
      std::optional<std::string> landmarks;
      if (std::filesystem::exists(landmarks_path, ec)) landmarks = ReadFileBytes(landmarks_path);
      return ImportSlicerMarkups(bytes, sidecar, label, import, landmarks);
    }
  }
  throw CaseError(label, "(file)", -1, "", "unreachable");
}

void WriteCaseFile(const ves::v1::ColonCase& colon_case, const std::filesystem::path& path) {
  const std::string label = path.string();
  const auto kind = CaseFileKindOf(path);
  std::string bytes;
  if (kind == CaseFileKind::kTextproto) {
    CheckCase(colon_case, label);
    bytes = FormatCaseTextproto(colon_case);
  } else if (kind == CaseFileKind::kBundle) {
    CheckCase(colon_case, label);
    bytes = EncodeCaseBundle(colon_case);
  } else {
    throw CaseError(label, "(file)", -1, path.extension().string(),
                    "can only write .textproto or .vescase");
  }
  std::filesystem::path temp = path;
  temp += ".tmp";
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.flush();
    if (!out) {
      throw CaseError(label, "(file)", -1, "", std::string("cannot write: ") +
                                                   std::strerror(errno));
    }
  }
  std::error_code ec;
  std::filesystem::rename(temp, path, ec);
  if (ec) {
    std::filesystem::remove(temp, ec);
    throw CaseError(label, "(file)", -1, "", "cannot rename into place: " + ec.message());
  }
}

}  // namespace ves::patient_db
