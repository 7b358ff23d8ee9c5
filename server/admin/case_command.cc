// `ves-admin case <action>`: offline work on colon case files (docs/case-format.md).
// Actions are a table below; the server work adds upload/list/download here.
#include <boost/program_options.hpp>

#include <charconv>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "patient_db/case_format.h"
#include "server/admin/commands.h"

namespace ves::admin {
namespace {

namespace po = boost::program_options;
namespace pdb = ves::patient_db;

constexpr int kOk = 0;
constexpr int kFailed = 1;
constexpr int kInvalid = 2;

struct CaseAction {
  const char* name;
  const char* summary;
  int (*run)(const CommandArgs& args);
};

// Options shared by actions that read CSV or markups files.
void AddImportOptions(po::options_description& options) {
  options.add_options()
      ("radius-mm", po::value<double>(), "constant lumen radius for imports (mm)")
      ("region", po::value<std::string>(), "region of a whole imported centerline "
                                           "(rectum, sigmoid, ..., cecum)")
      ("id", po::value<std::string>(), "case id of an import (default: from the file name)")
      ("title", po::value<std::string>(), "title of an import");
}

// Throws po::error on a bad region name.
pdb::ImportOptions ReadImportOptions(const po::variables_map& vm) {
  pdb::ImportOptions import;
  if (vm.count("radius-mm")) import.radius_mm = vm["radius-mm"].as<double>();
  if (vm.count("region")) {
    const auto name = vm["region"].as<std::string>();
    import.region = pdb::ParseRegionName(name);
    if (!import.region) throw po::error("unknown region '" + name + "'");
  }
  if (vm.count("id")) import.id = vm["id"].as<std::string>();
  if (vm.count("title")) import.title = vm["title"].as<std::string>();
  return import;
}

// Parses `args`; returns nullopt after printing help (exit 0) or an error (exit 2)
// into `status`.
std::optional<po::variables_map> ParseArgs(const CommandArgs& args,
                                           const po::options_description& visible,
                                           const po::positional_options_description& positional,
                                           const std::string& usage, int* status) {
  po::options_description all;
  all.add(visible);
  all.add_options()("help,h", "show this help");
  po::variables_map vm;
  try {
    po::store(po::command_line_parser(args).options(all).positional(positional).run(), vm);
    if (vm.count("help")) {
      std::cout << usage << "\n\n" << visible << "  -h [ --help ]         show this help\n";
      *status = kOk;
      return std::nullopt;
    }
    po::notify(vm);
  } catch (const po::error& e) {
    std::cerr << "ves-admin case: " << e.what() << " (see --help)\n";
    *status = kInvalid;
    return std::nullopt;
  }
  return vm;
}

// What an import changed on its own (a reversed centreline), on stderr;
// clears `warnings`.
void PrintWarnings(std::vector<pdb::CaseProblem>& warnings) {
  for (const auto& warning : warnings) std::cerr << "warning: " << warning.ToString() << "\n";
  warnings.clear();
}

std::string Identify(const ves::v1::ColonCase& colon_case) {
  return colon_case.id() + " v" + std::to_string(colon_case.version()) +
         " sha256=" + pdb::CasePayloadSha256Hex(colon_case);
}

// Writes the case to `out` (.textproto or .vescase) and says so; a case the
// writer refuses prints its problems and fails.
int WriteCaseAndSay(const ves::v1::ColonCase& colon_case, const std::string& out) {
  try {
    pdb::WriteCaseFile(colon_case, out);
  } catch (const pdb::CaseError& e) {
    for (const auto& problem : e.problems()) std::cerr << problem.ToString() << "\n";
    return kFailed;
  }
  std::cout << "wrote " << out << " " << Identify(colon_case) << "\n";
  return kOk;
}

int RunValidate(const CommandArgs& args) {
  po::options_description options("options");
  options.add_options()("file", po::value<std::vector<std::string>>()->required(), "case files");
  AddImportOptions(options);
  po::positional_options_description positional;
  positional.add("file", -1);
  int status = kOk;
  const auto vm = ParseArgs(args, options, positional,
                            "usage: ves-admin case validate FILE... [import options]\n"
                            "Checks .textproto, .vescase, .csv and .mrk.json case files; "
                            "prints one line per problem, or\n"
                            "\"OK <file> <id> v<version> sha256=<hex>\". Exit 0 only when "
                            "every file is valid, 2 otherwise.",
                            &status);
  if (!vm) return status;
  pdb::ImportOptions import;
  try {
    import = ReadImportOptions(*vm);
  } catch (const po::error& e) {
    std::cerr << "ves-admin case validate: " << e.what() << "\n";
    return kInvalid;
  }
  const auto files = (*vm)["file"].as<std::vector<std::string>>();
  int invalid = 0;
  std::vector<pdb::CaseProblem> warnings;
  import.warnings = &warnings;
  for (const auto& file : files) {
    try {
      const auto colon_case = pdb::LoadCaseFile(file, import);
      PrintWarnings(warnings);
      std::cout << "OK " << file << " " << Identify(colon_case) << "\n";
    } catch (const pdb::CaseError& e) {
      ++invalid;
      PrintWarnings(warnings);
      for (const auto& problem : e.problems()) std::cout << problem.ToString() << "\n";
    }
  }
  if (invalid > 0) {
    std::cerr << "ves-admin case validate: " << invalid << " of " << files.size()
              << " file(s) invalid\n";
    return kInvalid;
  }
  return kOk;
}

int RunConvert(const CommandArgs& args) {
  po::options_description options("options");
  options.add_options()
      ("in", po::value<std::string>()->required(), "input (.textproto .vescase .csv .mrk.json)")
      ("out", po::value<std::string>()->required(), "output (.textproto or .vescase)");
  AddImportOptions(options);
  po::positional_options_description positional;
  positional.add("in", 1).add("out", 1);
  int status = kOk;
  const auto vm = ParseArgs(args, options, positional,
                            "usage: ves-admin case convert IN OUT [--radius-mm R] "
                            "[--region NAME] [--id ID] [--title TEXT]\n"
                            "Reads any supported case file, validates it and writes OUT "
                            "as textproto or bundle by its extension.",
                            &status);
  if (!vm) return status;
  ves::v1::ColonCase colon_case;
  std::vector<pdb::CaseProblem> warnings;
  try {
    auto import = ReadImportOptions(*vm);
    import.warnings = &warnings;
    colon_case = pdb::LoadCaseFile((*vm)["in"].as<std::string>(), import);
    PrintWarnings(warnings);
  } catch (const po::error& e) {
    std::cerr << "ves-admin case convert: " << e.what() << "\n";
    return kInvalid;
  } catch (const pdb::CaseError& e) {
    PrintWarnings(warnings);
    for (const auto& problem : e.problems()) std::cerr << problem.ToString() << "\n";
    return kInvalid;
  }
  const std::string out = (*vm)["out"].as<std::string>();
  if (!pdb::CaseFileKindOf(out) || pdb::CaseFileKindOf(out) == pdb::CaseFileKind::kCsv ||
      pdb::CaseFileKindOf(out) == pdb::CaseFileKind::kSlicerMarkups) {
    std::cerr << "ves-admin case convert: output '" << out
              << "' must end in .textproto or .vescase\n";
    return kInvalid;
  }
  return WriteCaseAndSay(colon_case, out);
}

int RunInfo(const CommandArgs& args) {
  po::options_description options("options");
  options.add_options()("file", po::value<std::string>()->required(), "case file");
  AddImportOptions(options);
  po::positional_options_description positional;
  positional.add("file", 1);
  int status = kOk;
  const auto vm = ParseArgs(args, options, positional,
                            "usage: ves-admin case info FILE\n"
                            "Prints a valid case's identity, length and regions.",
                            &status);
  if (!vm) return status;
  ves::v1::ColonCase c;
  try {
    c = pdb::LoadCaseFile((*vm)["file"].as<std::string>(), ReadImportOptions(*vm));
  } catch (const po::error& e) {
    std::cerr << "ves-admin case info: " << e.what() << "\n";
    return kInvalid;
  } catch (const pdb::CaseError& e) {
    for (const auto& problem : e.problems()) std::cerr << problem.ToString() << "\n";
    return kInvalid;
  }
  std::cout << Identify(c) << "\n"
            << "title: " << c.title() << "\n"
            << "difficulty: " << ves::v1::Difficulty_Name(c.difficulty()) << "\n"
            << "control points: " << c.centerline_size() << "\n";
  char line[160];
  std::snprintf(line, sizeof(line), "length: %.3f m\n", pdb::CalcCenterlineLength_m(c));
  std::cout << line;
  for (const auto& span : c.regions()) {
    std::snprintf(line, sizeof(line), "  %-16s %.3f m  [%.3f, %.3f]  K_c %g N/m^2  D_c %g N s/m^2\n",
                  pdb::RegionName(span.region()).c_str(), span.end_arc_m() - span.start_arc_m(),
                  span.start_arc_m(), span.end_arc_m(),
                  span.tissue().suspension_stiffness_n_per_m2(),
                  span.tissue().suspension_damping_n_s_per_m2());
    std::cout << line;
  }
  return kOk;
}

int RunGenerate(const CommandArgs& args) {
  po::options_description options("options");
  options.add_options()
      ("seed", po::value<std::string>()->required(), "seed, 0 to 2^64-1: the same seed gives "
                                                     "the same colon")
      ("out", po::value<std::string>(), "output (.textproto or .vescase); default: textproto "
                                        "on standard output")
      ("sigmoid", po::value<std::string>(), "redundant or common (default: drawn)")
      ("descending", po::value<std::string>(), "mobile or fixed (default: drawn)")
      ("id", po::value<std::string>(), "case id (default: generated-<seed>)");
  po::positional_options_description positional;
  int status = kOk;
  const auto vm = ParseArgs(args, options, positional,
                            "usage: ves-admin case generate --seed N [--out FILE] "
                            "[--sigmoid redundant|common] [--descending mobile|fixed] [--id ID]\n"
                            "Generates a plausible colon: region lengths, radii and mesentery "
                            "heights drawn from\npublished distributions "
                            "(docs/case-generator.md); valid for import.",
                            &status);
  if (!vm) return status;
  pdb::ColonGeneratorOptions generator;
  const auto choice = [&](const char* name, const char* yes, const char* no,
                          std::optional<bool>& out) {
    if (!vm->count(name)) return true;
    const auto value = (*vm)[name].as<std::string>();
    if (value != yes && value != no) {
      std::cerr << "ves-admin case generate: --" << name << " must be " << yes << " or " << no
                << ", not '" << value << "'\n";
      return false;
    }
    out = value == yes;
    return true;
  };
  if (!choice("sigmoid", "redundant", "common", generator.redundant_sigmoid) ||
      !choice("descending", "mobile", "fixed", generator.mobile_descending)) {
    return kInvalid;
  }
  if (vm->count("id")) generator.id = (*vm)["id"].as<std::string>();
  // Digits only: a lexical cast would wrap "-1" round to 2^64-1.
  const auto seed_text = (*vm)["seed"].as<std::string>();
  std::uint64_t seed = 0;
  const auto [end, error] =
      std::from_chars(seed_text.data(), seed_text.data() + seed_text.size(), seed);
  if (seed_text.empty() || error != std::errc() || end != seed_text.data() + seed_text.size()) {
    std::cerr << "ves-admin case generate: --seed '" << seed_text
              << "' is not a whole number in 0..18446744073709551615\n";
    return kInvalid;
  }
  const std::string out = vm->count("out") ? (*vm)["out"].as<std::string>() : "";
  if (!out.empty() && pdb::CaseFileKindOf(out) != pdb::CaseFileKind::kTextproto &&
      pdb::CaseFileKindOf(out) != pdb::CaseFileKind::kBundle) {
    std::cerr << "ves-admin case generate: output '" << out
              << "' must end in .textproto or .vescase\n";
    return kInvalid;
  }
  ves::v1::ColonCase colon_case;
  try {
    colon_case = pdb::GenerateColonCase(seed, generator);
  } catch (const pdb::CaseError& e) {
    for (const auto& problem : e.problems()) std::cerr << problem.ToString() << "\n";
    return kInvalid;
  }
  if (out.empty()) {
    std::cout << pdb::FormatCaseTextproto(colon_case);
    return kOk;
  }
  return WriteCaseAndSay(colon_case, out);
}

// Actions of `ves-admin case`; the server work appends upload, list, download.
const std::vector<CaseAction>& CaseActions() {
  static const std::vector<CaseAction> kActions = {
      {"validate", "check case files; exit 0 only when all are valid", RunValidate},
      {"convert", "convert IN OUT between textproto, bundle, CSV/markups import", RunConvert},
      {"info", "print a case's identity, length and regions", RunInfo},
      {"generate", "generate a plausible colon from a seed (--seed N [--out FILE])", RunGenerate},
      {"upload", "upload FILE to the server (admin)", RunCaseUpload},
      {"list", "list the server's cases", RunCaseList},
      {"download", "download ID -o FILE.vescase from the server", RunCaseDownload},
  };
  return kActions;
}

void PrintCaseUsage(std::ostream& out) {
  out << "usage: ves-admin case <action> [options]   (ves-admin case <action> --help)\n\n"
         "actions:\n";
  for (const auto& action : CaseActions()) {
    out << "  " << action.name << std::string(12 - std::string(action.name).size(), ' ')
        << action.summary << "\n";
  }
}

}  // namespace

int RunCaseCommand(const CommandArgs& args) {
  if (args.empty()) {
    PrintCaseUsage(std::cerr);
    return kInvalid;
  }
  if (args[0] == "--help" || args[0] == "-h" || args[0] == "help") {
    PrintCaseUsage(std::cout);
    return kOk;
  }
  for (const auto& action : CaseActions()) {
    if (args[0] == action.name) return action.run(CommandArgs(args.begin() + 1, args.end()));
  }
  std::cerr << "ves-admin case: unknown action '" << args[0] << "' (see ves-admin case --help)\n";
  return kInvalid;
}

}  // namespace ves::admin
