// The Foxglove WebSocket protocol (foxglove/ws-protocol, docs/spec.md; subprotocol `foxglove.websocket.v1`,
// also offered by newer clients as `foxglove.sdk.v1`): what `tandem view` sends and what it accepts, as pure
// functions. No socket here: services/view/src/server.cpp carries the frames.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace tandem::view {

/// The subprotocol names accepted (the first is the classic name, the second the same protocol's newer name).
inline constexpr const char* kSubprotocols[] = {"foxglove.websocket.v1", "foxglove.sdk.v1"};

/// One advertised channel: a DDS topic as recording messages (encoding "protobuf", schema the
/// FileDescriptorSet the recordings embed), or one of the viewer's own JSON channels (encoding "json", schema
/// a JSON Schema).
struct Channel {
  uint32_t id = 0;
  std::string topic;
  std::string encoding;     ///< "protobuf" | "json"
  std::string schema_name;  ///< the fully qualified message name, or the JSON channel's name
  std::string schema;  ///< protobuf: the binary FileDescriptorSet (base64-encoded on the wire); json: text
  std::string schema_encoding;  ///< "protobuf" | "jsonschema"
};

std::string base64(std::string_view bytes);

/// serverInfo: name, capabilities ("time"), supported encodings, metadata, and a session id that changes when
/// the viewer restarts (clients reset their state on a new one).
std::string server_info(const std::string& name, const std::string& session_id,
                        const std::vector<std::pair<std::string, std::string>>& metadata);
std::string advertise(const std::vector<Channel>& channels);
/// status: level 0 info, 1 warning, 2 error.
std::string status(int level, const std::string& message);

/// Binary messageData: op 0x01 | u32 LE subscription id | u64 LE receive time [ns] | payload.
std::string message_data(uint32_t subscription, uint64_t time_ns, std::string_view payload);
/// Binary time: op 0x02 | u64 LE [ns].
std::string time_frame(uint64_t time_ns);

/// A client's request, parsed. Anything not understood is Kind::Bad with the reason in `error` (sent back as
/// a status warning; the connection and everything else go on).
struct ClientOp {
  enum class Kind { Subscribe, Unsubscribe, Ignored, Bad } kind = Kind::Bad;
  std::vector<std::pair<uint32_t, uint32_t>> subscriptions;  ///< Subscribe: (subscription id, channel id)
  std::vector<uint32_t> unsubscribe;                         ///< Unsubscribe: subscription ids
  std::string error;
};
ClientOp parse_client_op(std::string_view json);

}  // namespace tandem::view
