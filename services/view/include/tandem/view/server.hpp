// The viewer's server (civetweb): the page and its files over HTTP, and the Foxglove WebSocket protocol on
// the same port (services/view/include/tandem/view/foxglove.hpp). Each client has its own writer thread and a
// bounded Outbox, so a slow or stalled client never blocks the publisher, the deployment or the other
// clients.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "tandem/view/foxglove.hpp"

struct mg_context;
struct mg_connection;

namespace tandem::view {

class Server {
 public:
  struct Options {
    std::string bind = "127.0.0.1";  ///< other addresses are opt-in (tandem view --bind)
    int port = 8765;                 ///< 0: any free port (port() says which)
    std::string web_dir;             ///< the page's files (index.html, app.js, uplot)
    std::string name = "tandem";     ///< serverInfo's name
    std::vector<std::pair<std::string, std::string>> metadata;
    size_t channel_limit = 1000;  ///< frames kept per channel and client (a second of a 1 kHz topic)
    size_t page_limit = 64;       ///< ... for the viewer's own JSON channels (state, plot)
  };
  Server(Options o, std::vector<Channel> channels);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  /// Listens; false with the reason in `error` (the port taken, the address not this machine's).
  bool start(std::string& error);
  void stop();
  int port() const { return port_; }
  std::string url() const;

  /// Whether any client subscribes to `channel` now (else the caller need not serialize its message).
  bool wanted(uint32_t channel) const {
    return channel < subscribers_.size() && subscribers_[channel]->load() > 0;
  }
  /// Sends `payload` on `channel` to every client subscribed to it (queued; dropped oldest-first per client).
  void publish(uint32_t channel, uint64_t time_ns, std::string_view payload);
  /// Sends to each new subscriber of `channel` first, before anything published (the events a late page
  /// missed).
  void set_history(uint32_t channel, std::vector<std::string> messages);
  void broadcast_time(uint64_t time_ns);
  /// Serves GET `uri` with the JSON `answer` returns for the request's query string (a recording's timeline).
  void set_json(const std::string& uri, std::function<std::string(const std::string& query)> answer);
  /// A POST request as a handler sees it: the client's address, its X-Tandem-Token, Content-Type, Origin and Host
  /// headers ("" when absent), its body (at most 4 kB).
  struct PostIn {
    std::string remote, token, content_type, origin, host, body;
  };
  struct PostOut {
    int status = 200;  ///< the HTTP status
    std::string json;  ///< the answer's body
  };
  /// Serves POST `uri` with what `answer` returns (live commands); set before start().
  void set_post(const std::string& uri, std::function<PostOut(const PostIn&)> answer);
  void broadcast_status(int level, const std::string& message);

  struct ClientInfo {
    std::string address;
    uint64_t sent = 0, dropped = 0;
    size_t queued = 0;
  };
  std::vector<ClientInfo> clients() const;
  /// Frames dropped so far per channel topic, over every client (connected or gone).
  std::map<std::string, uint64_t> drops() const;

  const std::vector<Channel>& channels() const { return channels_; }

 private:
  struct Client;
  static int on_http(mg_connection* c, void* self);
  static int on_ws_connect(const mg_connection* c, void* self);
  static void on_ws_ready(mg_connection* c, void* self);
  static int on_ws_data(mg_connection* c, int bits, char* data, size_t len, void* self);
  static void on_ws_close(const mg_connection* c, void* self);
  void handle_op(Client& cl, std::string_view text);

  Options o_;
  std::vector<Channel> channels_;
  std::vector<std::unique_ptr<std::atomic<int>>>
      subscribers_;  ///< per channel id: subscriptions over all clients
  mg_context* ctx_ = nullptr;
  int port_ = 0;
  std::string session_;
  mutable std::mutex mu_;  ///< clients_, history_, dropped_gone_
  std::vector<std::shared_ptr<Client>> clients_;
  std::map<uint32_t, std::vector<std::string>> history_;
  std::map<uint32_t, uint64_t> dropped_gone_;  ///< drops of clients gone, per channel
  std::map<std::string, std::function<std::string(const std::string&)>> json_;  ///< set before start()
  std::map<std::string, std::function<PostOut(const PostIn&)>> post_;            ///< set before start()
};

}  // namespace tandem::view
