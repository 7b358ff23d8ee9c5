// `ves-admin account create|revoke|list|password --db URL ...`: the accounts
// people sign in to the web pages with (docs/web.md, "Accounts"). Run on the
// server's host against its database, as `init` is: the server reads the
// account on every request, so a revocation holds from the next one.
// Passwords are read from standard input (never from the command line, which
// other users of the host can see), one line.
#include <pwd.h>
#include <termios.h>
#include <unistd.h>

#include <boost/program_options.hpp>
#include <ctime>
#include <iostream>

#include "patient_db/clock.h"
#include "patient_db/store.h"
#include "patient_db/store_factory.h"
#include "server/accounts.h"
#include "server/admin/commands.h"

namespace ves::admin {
namespace {

namespace po = boost::program_options;
using patient_db::AccountRow;
using patient_db::StoreRole;

// "YYYY-MM-DD" as 00:00 UTC of that day, in ms; -1 when malformed.
int64_t ParseDate(const std::string& text) {
  std::tm tm{};
  char rest = 0;
  if (text.size() != 10 ||
      std::sscanf(text.c_str(), "%4d-%2d-%2d%c", &tm.tm_year, &tm.tm_mon, &tm.tm_mday, &rest) !=
          3) {
    return -1;
  }
  const int year = tm.tm_year, month = tm.tm_mon, day = tm.tm_mday;
  tm.tm_year -= 1900;
  tm.tm_mon -= 1;
  const time_t t = timegm(&tm);
  std::tm back{};
  gmtime_r(&t, &back);
  if (back.tm_year + 1900 != year || back.tm_mon + 1 != month || back.tm_mday != day) return -1;
  return static_cast<int64_t>(t) * 1000;
}

std::string FormatDate(int64_t unix_ms) {
  if (unix_ms == 0) return "-";
  const time_t t = static_cast<time_t>(unix_ms / 1000);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char out[32];
  std::strftime(out, sizeof out, "%Y-%m-%dT%H:%MZ", &tm);
  return out;
}

// One line from stdin, without echo when it is a terminal.
bool ReadPassword(const std::string& prompt, std::string* password) {
  const bool tty = ::isatty(STDIN_FILENO) != 0;
  termios saved{};
  if (tty) {
    std::cerr << prompt << std::flush;
    ::tcgetattr(STDIN_FILENO, &saved);
    termios quiet = saved;
    quiet.c_lflag &= ~static_cast<tcflag_t>(ECHO);
    ::tcsetattr(STDIN_FILENO, TCSANOW, &quiet);
  }
  const bool got = static_cast<bool>(std::getline(std::cin, *password));
  if (tty) {
    ::tcsetattr(STDIN_FILENO, TCSANOW, &saved);
    std::cerr << "\n";
  }
  if (!password->empty() && password->back() == '\r') password->pop_back();
  return got;
}

std::string OsUser() {
  const passwd* pw = ::getpwuid(::getuid());
  return pw != nullptr ? pw->pw_name : "uid " + std::to_string(::getuid());
}

// The audit row of a change made here: the actor is this command, labelled
// with the operating-system user who ran it.
patient_db::StoreStatus Audit(patient_db::Store& store, const std::string& action,
                              const AccountRow& account) {
  patient_db::WriteBatch batch;
  batch.audit.push_back({0, patient_db::NowUnixMs(), "ves-admin", OsUser(), "admin",
                         account.institution, action, account.username, "OK"});
  return store.CommitBatch(batch).status;
}

int Fail(const std::string& message, int status) {
  std::cerr << "ves-admin account: " << message << "\n";
  return status;
}

// The command line's options (a verb takes the ones it needs).
struct AccountOptions {
  std::string db;
  std::string username;
  std::string role_name;
  std::string institution;
  std::string expires;
  std::string idp_identity;
  bool no_password = false;
};

int CreateAccount(const AccountOptions& o) {
  AccountRow a;
  a.username = o.username;
  if (!patient_db::ParseRoleName(o.role_name, &a.role) ||
      (a.role != StoreRole::kAdmin && a.role != StoreRole::kSupervisor)) {
    return Fail("--role '" + o.role_name + "': must be supervisor or admin", 2);
  }
  if (o.institution.empty()) return Fail("--institution is required", 2);
  a.institution = o.institution;
  if (!o.expires.empty()) {
    a.expires_unix_ms = ParseDate(o.expires);
    if (a.expires_unix_ms < 0) return Fail("--expires '" + o.expires + "': not YYYY-MM-DD", 2);
  }
  if (o.idp_identity.size() > 255) return Fail("--idp-identity: over 255 bytes", 2);
  a.idp_identity = o.idp_identity;
  if (!o.no_password) {
    std::string password;
    if (!ReadPassword("password for " + o.username + ": ", &password)) {
      return Fail("no password on standard input (or --no-password)", 2);
    }
    if (std::string why = server::CheckNewPassword(password); !why.empty()) return Fail(why, 2);
    a.password_hash = server::HashPassword(password);
  } else if (o.idp_identity.empty()) {
    return Fail("--no-password needs --idp-identity (else nobody can sign in)", 2);
  }
  a.created_unix_ms = patient_db::NowUnixMs();
  auto store = patient_db::OpenStoreFromUrl(o.db);
  auto st = store->AddAccount(a);
  if (!st.ok()) return Fail(st.message, 1);
  st = Audit(*store, "account.create", a);
  if (!st.ok()) return Fail(st.message, 1);
  std::cout << "account '" << o.username << "' created (" << o.role_name << ", " << o.institution
            << (a.expires_unix_ms ? ", expires " + FormatDate(a.expires_unix_ms) : "") << ")\n";
  return 0;
}

int ListAccounts(patient_db::Store& store, const AccountOptions& o) {
  auto rows = store.ListAccounts(o.institution);
  if (!rows.ok()) return Fail(rows.status.message, 1);
  std::cout << "username\trole\tinstitution\tpassword\tidp_identity\texpires\trevoked\n";
  for (const AccountRow& a : rows.value) {
    std::cout << a.username << "\t" << patient_db::RoleName(a.role) << "\t" << a.institution << "\t"
              << (a.password_hash.empty() ? "no" : "yes") << "\t"
              << (a.idp_identity.empty() ? "-" : a.idp_identity) << "\t"
              << FormatDate(a.expires_unix_ms) << "\t" << FormatDate(a.revoked_unix_ms) << "\n";
  }
  return 0;
}

// `revoke` or `password` of the existing account `found`, named `username`.
int ChangeAccount(patient_db::Store& store, const std::string& verb, const std::string& username,
                  const AccountRow& found) {
  if (verb == "revoke") {
    auto st = store.RevokeAccount(username, patient_db::NowUnixMs());
    if (st.ok()) st = Audit(store, "account.revoke", found);
    if (!st.ok()) return Fail(st.message, 1);
    std::cout << "account '" << username << "' revoked\n";
    return 0;
  }
  std::string password;  // verb == "password"
  if (!ReadPassword("new password for " + username + ": ", &password)) {
    return Fail("no password on standard input", 2);
  }
  if (std::string why = server::CheckNewPassword(password); !why.empty()) return Fail(why, 2);
  auto st = store.SetAccountPassword(username, server::HashPassword(password));
  if (st.ok()) st = Audit(store, "account.password", found);
  if (!st.ok()) return Fail(st.message, 1);
  std::cout << "account '" << username << "': password set\n";
  return 0;
}

}  // namespace

int RunAccountCommand(const CommandArgs& args) {
  const std::string usage =
      "usage: ves-admin account create --db URL --username NAME --role supervisor|admin "
      "--institution NAME [--expires YYYY-MM-DD] [--idp-identity SUB] [--no-password]\n"
      "       ves-admin account revoke --db URL --username NAME\n"
      "       ves-admin account password --db URL --username NAME\n"
      "       ves-admin account list --db URL [--institution NAME]\n"
      "The password is read from standard input (one line).\n";
  if (args.empty() || args[0] == "--help" || args[0] == "-h") {
    std::cout << usage;
    return args.empty() ? 2 : 0;
  }
  const std::string verb = args[0];
  if (verb != "create" && verb != "revoke" && verb != "password" && verb != "list") {
    return Fail("unknown subcommand '" + verb + "' (create, revoke, password, list)", 2);
  }
  AccountOptions o;
  po::options_description options("options");
  options.add_options()("help,h", "show this help")(
      "db", po::value(&o.db)->required(), "database URL, e.g. sqlite:/var/lib/ves/ves.db")(
      "username", po::value(&o.username), "the account's name (a-z 0-9 . _ @ -)")(
      "role", po::value(&o.role_name), "supervisor or admin")(
      "institution", po::value(&o.institution), "the account's institution")(
      "expires", po::value(&o.expires), "refused from 00:00 UTC of this day (default: never)")(
      "idp-identity", po::value(&o.idp_identity),
      "the identity provider's `sub` (or verified email) that signs in as this account")(
      "no-password", "no password sign-in: only through the identity provider");
  po::variables_map vm;
  try {
    po::store(po::command_line_parser(CommandArgs(args.begin() + 1, args.end()))
                  .options(options)
                  .run(),
              vm);
    if (vm.count("help")) {
      std::cout << usage << options;
      return 0;
    }
    po::notify(vm);
    o.no_password = vm.count("no-password") > 0;
  } catch (const po::error& e) {
    return Fail(e.what(), 2);
  }
  if (verb != "list") {
    if (std::string why = server::CheckUsername(o.username); !why.empty()) return Fail(why, 2);
  }
  try {
    if (verb == "create") return CreateAccount(o);
    auto store = patient_db::OpenStoreFromUrl(o.db);
    if (verb == "list") return ListAccounts(*store, o);
    auto found = store->GetAccount(o.username);
    if (!found.ok()) return Fail("no account '" + o.username + "'", 1);
    return ChangeAccount(*store, verb, o.username, found.value);
  } catch (const std::invalid_argument& e) {
    return Fail(e.what(), 2);
  } catch (const std::exception& e) {
    return Fail(e.what(), 1);
  }
}

}  // namespace ves::admin
