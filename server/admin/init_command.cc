// `ves-admin init --db sqlite:PATH --institution NAME`: creates (and migrates)
// the database and prints the first admin token, once.
#include <boost/program_options.hpp>
#include <chrono>
#include <iostream>

#include "patient_db/store.h"
#include "patient_db/store_factory.h"
#include "server/admin/commands.h"
#include "server/auth.h"

namespace ves::admin {

namespace po = boost::program_options;

int RunInitCommand(const CommandArgs& args) {
  std::string db, institution, label = "first admin";
  po::options_description options("options");
  options.add_options()("help,h", "show this help")(
      "db", po::value(&db)->required(), "database URL, e.g. sqlite:/var/lib/ves/ves.db")(
      "institution", po::value(&institution)->required(), "the admin's institution")(
      "label", po::value(&label), "who holds the token (audit log)");
  po::variables_map vm;
  try {
    po::store(po::command_line_parser(args).options(options).run(), vm);
    if (vm.count("help")) {
      std::cout << "usage: ves-admin init --db sqlite:PATH --institution NAME\n" << options;
      return 0;
    }
    po::notify(vm);
  } catch (const po::error& e) {
    std::cerr << "ves-admin init: " << e.what() << "\n";
    return 2;
  }
  try {
    auto store = patient_db::OpenStoreFromUrl(db);
    // The first audit row of a database is its init: a second init is refused
    // so the first admin token is printed only once.
    auto first = store->ListAudit(0, 1);
    if (!first.ok()) throw std::runtime_error(first.status.message);
    if (!first.value.empty() && first.value[0].action == "admin.init") {
      std::cerr << "ves-admin init: " << db << " is already initialised (create more tokens "
                << "with `ves-admin token create`)\n";
      return 1;
    }
    const int64_t now = std::chrono::duration_cast<std::chrono::milliseconds>(
                            std::chrono::system_clock::now().time_since_epoch())
                            .count();
    auto st = store->AddInstitution(institution, now);
    const std::string token = ves::server::NewToken();
    const std::string hash = ves::server::Sha256Hex(token);
    if (st.ok()) {
      st = store->AddToken({hash, patient_db::StoreRole::kAdmin, institution, "", label, now});
    }
    patient_db::WriteBatch batch;
    batch.audit.push_back({0, now, ves::server::TokenIdOf(hash), label, "admin", institution,
                           "admin.init", db, "OK"});
    if (st.ok()) st = store->CommitBatch(batch).status;
    if (!st.ok()) throw std::runtime_error(st.message);
    std::cout << token << "\n";
    std::cerr << "admin token for institution '" << institution
              << "': shown once, the database keeps only its hash\n";
    return 0;
  } catch (const std::invalid_argument& e) {
    std::cerr << "ves-admin init: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "ves-admin init: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace ves::admin
