// tandem keys: makes a deployment's DDS-Security files with openssl: a CA, one key and certificate per identity
// (runtime::identities: per slot), and the governance and permissions documents derived from the deployment,
// signed by the CA. Keys are made at set-up and never committed.
#include "keys_command.hpp"

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>

#include "tandem/runtime/args.hpp"
#include "tandem/runtime/deployment.hpp"
#include "tandem/runtime/security.hpp"
#include "tandem/page/files.hpp"

namespace tandem::cli {

namespace {

bool run(const std::string& cmd, std::string& err) {
  const std::string full = cmd + " 2>&1";
  FILE* p = ::popen(full.c_str(), "r");
  if (p == nullptr) {
    err = "cannot run: " + cmd;
    return false;
  }
  std::string out;
  char buf[256];
  while (std::fgets(buf, sizeof buf, p) != nullptr) out += buf;
  const int rc = ::pclose(p);
  if (rc != 0) {
    err = "openssl failed: " + cmd + "\n" + out;
    return false;
  }
  return true;
}

std::string iso(std::time_t t) {
  char b[32];
  std::tm tm{};
  ::gmtime_r(&t, &tm);
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%S", &tm);
  return b;
}



}  // namespace

namespace {

struct KeysArgs {
  std::string file, dir;
  int days = 365;
  bool new_ca = false;
};

/// The command line, on CLI11 (runtime::parse_args): `tandem help keys` prints the same text as --help.
void describe(CLI::App& app, KeysArgs& o) {
  app.description(
      "Makes the DDS-Security files of a deployment with openssl (docs/security.md), into DIR (default: the\n"
      "deployment's security.keys):\n"
      "  ca.pem, ca.key            the deployment's CA (identity and permissions CA); kept and reused on later\n"
      "                            runs (a module added later gets keys from the same CA); --new-ca replaces it\n"
      "  <identity>.pem, .key      one ECDSA P-256 key and certificate (CN=<identity>) per identity: robot.<m>.<r>\n"
      "                            (every robot of arm <m>/<r>: primary, standbys, restarts), world.<m>,\n"
      "                            supervisor.<m>, coordinator, launcher, cli, recorder\n"
      "  governance.p7s            authenticated participants only; read and write access control on every topic;\n"
      "                            discovery and data encrypted (AES-GCM)\n"
      "  permissions.p7s           least privilege per identity: a robot writes only its own arm's torques and\n"
      "                            reads only its own arm's sensors; only the launcher and the CLI write control\n"
      "                            requests; the recorder reads everything and writes only its status");
  app.add_option("deploy", o.file, "the deployment file")->required()->type_name("DEPLOY.yaml");
  app.add_option("--dir", o.dir, "where the files go (default: the deployment's security.keys)")->type_name("DIR");
  app.add_option("--days", o.days, "validity of the certificates and grants, in days")
      ->check(runtime::decimal())->check(CLI::Range(1, 3650))->capture_default_str()->type_name("N");
  app.add_flag("--new-ca", o.new_ca, "replace the deployment's CA (every identity gets new keys)");
  app.footer(
      "Keys are 0600 in a 0700 directory; never commit them. `tandem up` refuses to start with a missing or\n"
      "expired file and names it.\n"
      "Exit: 0 made, 1 openssl failed or DIR cannot be written, 2 bad command line or deployment.");
}

}  // namespace

void keys_usage(std::FILE* f) {
  KeysArgs o;
  CLI::App app("", "tandem keys");
  describe(app, o);
  std::fputs(app.help().c_str(), f);
}

namespace {

/// Reads the command line; -1 to go on, else the exit code (0 after --help).
int parse_keys_args(const std::vector<std::string>& args, KeysArgs& o) {
  CLI::App app("", "tandem keys");
  describe(app, o);
  return runtime::parse_args(app, args);
}

/// Makes the CA (unless one is there and no new one is asked for), then a key and certificate per identity, in
/// `dir` (quoted as q: "'<dir>/"); false with the reason in `err`.
bool make_certificates(const KeysArgs& o, const runtime::Deployment& d, const std::vector<runtime::Identity>& ids,
                       const std::string& dir, std::string& err) {
  const std::string q = "'" + dir + "/";
  const std::string ds = std::to_string(o.days);
  const bool have_ca = ::access((dir + "/ca.key").c_str(), R_OK) == 0 && ::access((dir + "/ca.pem").c_str(), R_OK) == 0;
  bool ok = true;
  if (!have_ca || o.new_ca) {
    ok = run("openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out " + q + "ca.key'", err) &&
         run("openssl req -new -x509 -sha256 -days " + ds + " -key " + q + "ca.key' -out " + q +
                 "ca.pem' -subj '/O=tandem/CN=tandem CA " + d.name + "'", err);
    if (ok) std::printf("tandem keys: made a CA for %s\n", d.name.c_str());
  } else {
    std::printf("tandem keys: reusing the CA in %s (--new-ca makes a new one)\n", dir.c_str());
  }
  for (size_t i = 0; ok && i < ids.size(); ++i) {
    const std::string& n = ids[i].name;
    ok = run("openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out " + q + n + ".key'", err) &&
         run("openssl req -new -sha256 -key " + q + n + ".key' -out " + q + n + ".csr' -subj '/CN=" + n + "'", err) &&
         run("openssl x509 -req -sha256 -days " + ds + " -in " + q + n + ".csr' -CA " + q + "ca.pem' -CAkey " + q +
                 "ca.key' -set_serial " + std::to_string(std::time(nullptr) * 100 + static_cast<long>(i)) + " -out " + q + n + ".pem'",
             err);
    ::unlink((dir + "/" + n + ".csr").c_str());
  }
  return ok;
}

/// Writes the governance and permissions documents and signs them with the CA; false with the reason in `err`.
bool make_documents(const KeysArgs& o, const runtime::Deployment& d, const std::vector<runtime::Identity>& ids,
                    const std::string& dir, std::string& err) {
  const std::string q = "'" + dir + "/";
  const std::time_t now = std::time(nullptr);
  try {
    page::write_file(dir + "/governance.xml", runtime::governance_xml(d));
    page::write_file(dir + "/permissions.xml",
                     runtime::permissions_xml(ids, d.domain_id, iso(now - 3600), iso(now + 86400L * o.days)));
  } catch (const std::exception& e) {
    err = std::string(e.what()) + " (the governance or permissions document)";
    return false;
  }
  bool ok = true;
  for (const char* doc : {"governance", "permissions"}) {
    ok = ok && run(std::string("openssl smime -sign -text -in ") + q + doc + ".xml' -out " + q + doc + ".p7s' -signer " +
                       q + "ca.pem' -inkey " + q + "ca.key'",
                   err);
  }
  return ok;
}

}  // namespace

int keys_command(const std::vector<std::string>& args) {
  KeysArgs o;
  if (const int code = parse_keys_args(args, o); code >= 0) return code;
  runtime::Deployment d;
  std::vector<runtime::Identity> ids;
  try {
    d = runtime::load_deployment(o.file);
    ids = runtime::identities(d);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem keys: %s\n", e.what());
    return 2;
  }
  const std::string dir = o.dir.empty() ? d.security_keys : o.dir;
  if (dir.empty()) {
    std::fprintf(stderr, "tandem keys: %s has no 'security: {keys: DIR}' and no --dir was given\n", o.file.c_str());
    return 2;
  }
  if (std::system("openssl version >/dev/null 2>&1") != 0) {
    std::fprintf(stderr, "tandem keys: needs the openssl command (Debian package openssl)\n");
    return 1;
  }
  if (!page::make_dirs(dir, 0700)) {
    std::fprintf(stderr, "tandem keys: cannot create %s: %s\n", dir.c_str(), std::strerror(errno));
    return 1;
  }
  ::chmod(dir.c_str(), 0700);
  std::string err;
  const mode_t old_mask = ::umask(077);
  const bool ok = make_certificates(o, d, ids, dir, err) && make_documents(o, d, ids, dir, err);
  ::umask(old_mask);
  if (!ok) {
    std::fprintf(stderr, "tandem keys: %s\n", err.c_str());
    return 1;
  }
  std::printf("tandem keys: %zu identities for %s (domain %d) in %s, valid %d days:", ids.size(), d.name.c_str(),
              d.domain_id, dir.c_str(), o.days);
  for (const auto& id : ids) std::printf(" %s", id.name.c_str());
  std::printf("\n");
  return 0;
}

}  // namespace tandem::cli
