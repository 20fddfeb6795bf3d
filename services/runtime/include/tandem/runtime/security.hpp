// DDS-Security of a deployment (docs/security.md): who may do what, derived from the deployment. One identity
// per slot, not per process: every robot of an arm (primary, standbys, restarts) is "robot.<module>.<robot>",
// every supervisor of a module "supervisor.<module>", every coordinator "coordinator", plus "world.<module>",
// "launcher", "cli", "recorder" and, on several hosts, "agent.<host>" per host. A slot is the unit of privilege (a standby must be able to do what the
// primary does, and restarts get new process labels), so a slot's processes share its key.
#pragma once

#include <string>
#include <vector>

#include "tandem/runtime/deployment.hpp"

namespace tandem::runtime {

struct Identity {
  std::string name;                    ///< "robot.m1.left": the certificate's CN and the files' base name
  std::vector<std::string> publish;    ///< topics it may write (Fast DDS matches them as fnmatch patterns)
  std::vector<std::string> subscribe;  ///< topics it may read
};

/// Every identity of the deployment (every module, autostart or not), with least-privilege topic lists.
/// Loads each module's scenario for its robot names. Throws sim::ConfigError as load_deployment does.
std::vector<Identity> identities(const Deployment& d);

/// The identity of a process of the deployment: role "world" | "supervisor" | "robot" | "coordinator" |
/// "launcher" | "cli" | "recorder" | "agent"; module and robot where the role has them (for "agent": the host
/// in `module`).
std::string identity_name(const std::string& role, const std::string& module = "", const std::string& robot = "");

/// The governance document (unsigned XML) for the deployment's domain: authenticated participants only, join
/// access control, read and write access control on every topic, discovery encrypted (AES-GCM). Data by topic
/// class (docs/security.md, "Threat model"): where the per-tick topics never leave the host's shared memory (one
/// host, `transport: shm`: data-sharing), they carry no per-sample crypto, so that they keep data-sharing
/// (Fast DDS 2.9.1 turns it off for any protected endpoint); everything else, and everything of a multi-host or
/// UDP deployment, is encrypted.
std::string governance_xml(const Deployment& d);
/// True if the deployment's per-tick topics stay in one host's shared memory (the class governed without crypto).
bool per_tick_local(const Deployment& d);

/// The permissions document (unsigned XML): one grant per identity, valid from `not_before` to `not_after`
/// (ISO 8601, "2026-11-23T00:00:00"), default DENY.
std::string permissions_xml(const std::vector<Identity>& ids, int domain_id, const std::string& not_before,
                            const std::string& not_after);

/// The directory of the deployment's keys (security.keys, resolved against the deployment file), "" if the
/// deployment has no `security:`.
inline const std::string& keys_dir(const Deployment& d) { return d.security_keys; }

/// The files a participant with identity `name` needs, in `dir`; the first missing one, or "" if all are there.
std::string missing_key_file(const std::string& dir, const std::string& name);

/// Every identity's files are in the keys' directory, its certificate is valid now (OpenSSL's X509 API), and the
/// permissions grant the deployment's domain. Returns "" or an error naming the file, what is wrong and the
/// command that makes new keys.
std::string check_keys(const Deployment& d);
/// Why the PEM certificate at `path` cannot be used now ("" if it can): "cannot be read", "is not a PEM
/// certificate", "has expired", "is not valid yet".
std::string certificate_problem(const std::string& path);

/// Makes the participants this process creates from now on (and the processes it starts) use DDS-Security
/// with identity `name` and the deployment's keys (TANDEM_SECURITY_DIR, TANDEM_IDENTITY, and TANDEM_DDS_PEERS:
/// the hosts to announce to; read by dds::Participant). Nothing for a deployment without `security:`. Returns ""
/// or an error naming the missing or unusable file (or keys made for another domain) and the command that makes
/// the keys.
std::string use_security(const Deployment& d, const std::string& name);

}  // namespace tandem::runtime
