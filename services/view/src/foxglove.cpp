#include "tandem/view/foxglove.hpp"

#include <nlohmann/json.hpp>

namespace tandem::view {

using nlohmann::json;

std::string base64(std::string_view bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t v = (static_cast<uint8_t>(bytes[i]) << 16) | (static_cast<uint8_t>(bytes[i + 1]) << 8) |
                       static_cast<uint8_t>(bytes[i + 2]);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i + 1 == bytes.size()) {
    const uint32_t v = static_cast<uint8_t>(bytes[i]) << 16;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == bytes.size()) {
    const uint32_t v = (static_cast<uint8_t>(bytes[i]) << 16) | (static_cast<uint8_t>(bytes[i + 1]) << 8);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

std::string server_info(const std::string& name, const std::string& session_id,
                        const std::vector<std::pair<std::string, std::string>>& metadata) {
  json meta = json::object();
  for (const auto& [k, v] : metadata) meta[k] = v;
  return json{{"op", "serverInfo"},
              {"name", name},
              {"capabilities", json::array({"time"})},
              {"supportedEncodings", json::array()},
              {"metadata", meta},
              {"sessionId", session_id}}
      .dump();
}

std::string advertise(const std::vector<Channel>& channels) {
  json list = json::array();
  for (const auto& c : channels) {
    list.push_back({{"id", c.id},
                    {"topic", c.topic},
                    {"encoding", c.encoding},
                    {"schemaName", c.schema_name},
                    {"schema", c.schema_encoding == "protobuf" ? base64(c.schema) : c.schema},
                    {"schemaEncoding", c.schema_encoding}});
  }
  return json{{"op", "advertise"}, {"channels", list}}.dump();
}

std::string status(int level, const std::string& message) {
  return json{{"op", "status"}, {"level", level}, {"message", message}}.dump();
}

namespace {
void put_le(std::string& out, uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out += static_cast<char>((v >> (8 * i)) & 0xff);
}
}  // namespace

std::string message_data(uint32_t subscription, uint64_t time_ns, std::string_view payload) {
  std::string out;
  out.reserve(13 + payload.size());
  out += static_cast<char>(0x01);
  put_le(out, subscription, 4);
  put_le(out, time_ns, 8);
  out.append(payload.data(), payload.size());
  return out;
}

std::string time_frame(uint64_t time_ns) {
  std::string out;
  out += static_cast<char>(0x02);
  put_le(out, time_ns, 8);
  return out;
}

namespace {
bool as_u32(const json& j, uint32_t& out) {
  if (!j.is_number_unsigned() && !(j.is_number_integer() && j.get<long long>() >= 0)) return false;
  const auto v = j.get<unsigned long long>();
  if (v > 0xffffffffULL) return false;
  out = static_cast<uint32_t>(v);
  return true;
}
}  // namespace

ClientOp parse_client_op(std::string_view text) {
  ClientOp r;
  const json j = json::parse(text.begin(), text.end(), nullptr, false);
  if (j.is_discarded() || !j.is_object()) {
    r.error = "not a JSON object";
    return r;
  }
  const auto op = j.find("op");
  if (op == j.end() || !op->is_string()) {
    r.error = "no \"op\" string";
    return r;
  }
  const std::string name = op->get<std::string>();
  if (name == "subscribe") {
    const auto subs = j.find("subscriptions");
    if (subs == j.end() || !subs->is_array()) {
      r.error = "subscribe needs \"subscriptions\": [{\"id\", \"channelId\"}]";
      return r;
    }
    for (const auto& s : *subs) {
      uint32_t id = 0, channel = 0;
      if (!s.is_object() || !s.contains("id") || !s.contains("channelId") || !as_u32(s["id"], id) ||
          !as_u32(s["channelId"], channel)) {
        r.error = "subscribe: each subscription needs \"id\" and \"channelId\" (unsigned 32-bit integers)";
        r.subscriptions.clear();
        return r;
      }
      r.subscriptions.emplace_back(id, channel);
    }
    r.kind = ClientOp::Kind::Subscribe;
    return r;
  }
  if (name == "unsubscribe") {
    const auto ids = j.find("subscriptionIds");
    if (ids == j.end() || !ids->is_array()) {
      r.error = "unsubscribe needs \"subscriptionIds\": [ids]";
      return r;
    }
    for (const auto& i : *ids) {
      uint32_t id = 0;
      if (!as_u32(i, id)) {
        r.error = "unsubscribe: subscription ids are unsigned 32-bit integers";
        r.unsubscribe.clear();
        return r;
      }
      r.unsubscribe.push_back(id);
    }
    r.kind = ClientOp::Kind::Unsubscribe;
    return r;
  }
  // Operations of capabilities this server does not advertise (publishing, parameters, services): ignored.
  r.kind = ClientOp::Kind::Ignored;
  r.error = "operation '" + name + "' is not supported by this server";
  return r;
}

}  // namespace tandem::view
