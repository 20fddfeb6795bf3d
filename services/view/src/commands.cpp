#include "tandem/view/commands.hpp"

#include <fstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

namespace tandem::view {

namespace {

/// Names as the deployment has them: letters, digits, '_', '-', '.', '@' and '/', at most 64 characters (nothing a
/// shell or an option could make more of: a leading '-' is refused too).
bool plain_name(const std::string& s) {
  if (s.empty() || s.size() > 64 || s[0] == '-') return false;
  for (const char c : s) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
                    c == '-' || c == '.' || c == '@' || c == '/';
    if (!ok) return false;
  }
  return true;
}

std::string text_field(const nlohmann::json& j, const char* key) {
  if (!j.contains(key)) return "";
  if (!j[key].is_string()) throw std::invalid_argument(std::string("'") + key + "' must be a string");
  return j[key].get<std::string>();
}

}  // namespace

LiveCommand parse_live_command(const std::string& body) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(body);
  } catch (const std::exception&) {
    throw std::invalid_argument("the request is not JSON; expected {\"command\": ..., \"target\": ...}");
  }
  if (!j.is_object()) throw std::invalid_argument("the request is not a JSON object");
  LiveCommand c;
  c.verb = text_field(j, "command");
  if (c.verb != "down" && c.verb != "kill" && c.verb != "plug" && c.verb != "unplug") {
    throw std::invalid_argument("unknown command '" + c.verb + "'; accepted: down, kill, plug, unplug");
  }
  c.kind = text_field(j, "kind");
  c.target = text_field(j, "target");
  if (j.contains("standby")) {
    if (!j["standby"].is_boolean()) throw std::invalid_argument("'standby' must be true or false");
    c.standby = j["standby"].get<bool>();
  }
  if (c.verb == "down") {
    if (!c.target.empty() || !c.kind.empty()) throw std::invalid_argument("down takes no target");
    return c;
  }
  if (!plain_name(c.target)) {
    throw std::invalid_argument("target '" + c.target + "' is not a process, robot or module name (letters, digits, "
                                "_ - . @ /, at most 64, not starting with -)");
  }
  if (c.verb == "kill") {
    if (!c.kind.empty()) throw std::invalid_argument("kill takes no kind (the target says what it is)");
    return c;
  }
  if (c.kind != "robot" && c.kind != "module") {
    throw std::invalid_argument(c.verb + " needs kind 'robot' or 'module', got '" + c.kind + "'");
  }
  if (c.standby && !(c.verb == "plug" && c.kind == "robot")) throw std::invalid_argument("standby is for plug robot only");
  return c;
}

std::vector<std::string> cli_args(const LiveCommand& c, const std::string& file) {
  std::vector<std::string> a{c.verb, file};
  if (c.verb == "kill") a.push_back(c.target);
  if (c.verb == "plug" || c.verb == "unplug") {
    a.push_back(c.kind);
    a.push_back(c.target);
    if (c.standby) a.emplace_back("--standby");
  }
  return a;
}

bool is_loopback(const std::string& addr) {
  const std::string v4 = addr.rfind("::ffff:", 0) == 0 ? addr.substr(7) : addr;
  return v4.rfind("127.", 0) == 0 || addr == "::1";
}

std::string refusal(const std::string& addr, const std::string& given, const std::string& token) {
  if (is_loopback(addr)) return "";
  if (token.empty()) {
    return "live commands from another machine (" + addr + ") need the viewer's token, and this viewer has none "
           "(tandem view --bind ADDR makes one, or --token-file FILE)";
  }
  // Constant time in the token's length: no early exit on the first differing character.
  unsigned diff = given.size() == token.size() ? 0U : 1U;
  for (size_t i = 0; i < token.size(); ++i) {
    diff |= static_cast<unsigned>(static_cast<unsigned char>(i < given.size() ? given[i] : 0) ^
                                  static_cast<unsigned char>(token[i]));
  }
  if (diff != 0U) return "live commands from another machine (" + addr + ") need the viewer's token; it was " +
                         (given.empty() ? "not given" : "wrong");
  return "";
}

std::string browser_refusal(const std::string& content_type, const std::string& origin, const std::string& host,
                            const std::string& bind, int port) {
  if (content_type.rfind("application/json", 0) != 0) {
    return "a live command is JSON: Content-Type application/json, got '" + content_type + "'";
  }
  const std::string p = ":" + std::to_string(port);
  bool ours = false;
  for (const std::string& name : {bind, std::string("127.0.0.1"), std::string("localhost"), std::string("[::1]")}) {
    ours = ours || host == name + p;
  }
  if (!ours) return "the request's Host '" + host + "' is not this viewer's (" + bind + p + ")";
  if (!origin.empty() && origin != "http://" + host) {
    return "a page of another origin (" + origin + ") may not send live commands";
  }
  return "";
}

std::string make_token() {
  std::ifstream r("/dev/urandom", std::ios::binary);
  unsigned char b[16];
  if (!r.read(reinterpret_cast<char*>(b), sizeof b)) throw std::runtime_error("cannot read /dev/urandom for a token");
  static const char* hex = "0123456789abcdef";
  std::string t;
  for (const unsigned char c : b) {
    t += hex[c >> 4];
    t += hex[c & 15];
  }
  return t;
}

std::string answer_json(bool ok, const std::string& text) {
  return nlohmann::json{{"ok", ok}, {"text", text}}.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace tandem::view
