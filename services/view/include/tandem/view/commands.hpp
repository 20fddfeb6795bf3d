// Live commands from the page (docs/view.md, "Live commands"): `down`, `kill`, `plug` and `unplug`, carried out as
// the CLI does them (the viewer runs `tandem <command> <deployment file> ...`, so with security on they go through
// the `cli` identity, as a user's would). Who may send them: a client on this machine, as anyone here may run the
// CLI; a client on another machine only with the viewer's token. Pure: no DDS, no process, no socket here.
#pragma once

#include <string>
#include <vector>

namespace tandem::view {

struct LiveCommand {
  std::string verb;    ///< down, kill, plug, unplug
  std::string kind;    ///< plug/unplug: robot or module
  std::string target;  ///< kill: a process or module; plug/unplug: a robot (m1/left, m1/left@50) or module (m2)
  bool standby = false;  ///< plug robot: as a standby
};

/// The page's request body as a command: {"command": "down"}, {"command": "kill", "target": "m1/left"},
/// {"command": "unplug", "kind": "robot", "target": "m1/left@50"}, {"command": "plug", "kind": "robot", "target":
/// "m1/left", "standby": true}, {"command": "plug", "kind": "module", "target": "m2"}. Throws std::invalid_argument
/// naming the field that is wrong and what is accepted.
LiveCommand parse_live_command(const std::string& body);

/// The `tandem` command line (after the program) that carries `c` out on the deployment file `file`.
std::vector<std::string> cli_args(const LiveCommand& c, const std::string& file);

/// Whether `addr` (a client's address as the server saw it) is this machine's loopback: 127.0.0.0/8 or ::1 (also
/// as ::ffff:127.x.y.z).
bool is_loopback(const std::string& addr);

/// "" if a client at `addr` that sent `given` may command; else why not. A loopback client always may; another
/// only with the viewer's token (`token`; none set: no command from another machine), compared in constant time.
std::string refusal(const std::string& addr, const std::string& given, const std::string& token);

/// "" if a browser's request is what this viewer's own page sends; else why not. Against another web page that a
/// browser on this machine has open (cross-site requests, DNS rebinding): the body must be declared JSON
/// (`content_type` application/json, which a cross-origin page cannot send without a preflight this server
/// refuses), `host` (the Host header) must name this viewer (`bind` or a loopback name, at `port`), and an `origin`,
/// when sent, must be http:// + that host.
std::string browser_refusal(const std::string& content_type, const std::string& origin, const std::string& host,
                            const std::string& bind, int port);

/// A fresh token: 32 hexadecimal digits from /dev/urandom (throws if it cannot be read).
std::string make_token();

/// The answer's JSON body: {"ok": ok, "text": text}.
std::string answer_json(bool ok, const std::string& text);

}  // namespace tandem::view
