#include "tandem/view/server.hpp"

#include <civetweb.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <thread>

#include "tandem/view/outbox.hpp"

namespace tandem::view {

struct Server::Client {
  mg_connection* conn = nullptr;
  std::string address;
  Outbox out;
  std::mutex mu;                            ///< the subscriptions
  std::map<uint32_t, uint32_t> sub_of;      ///< channel -> subscription id
  std::map<uint32_t, uint32_t> channel_of;  ///< subscription id -> channel
  std::thread writer;
  std::atomic<bool> gone{false};
  std::atomic<uint64_t> sent{0};
  Client(size_t channel_limit) : out(channel_limit) {}
};

namespace {

/// The page's files: a fixed set of names (nothing else of the disk is served).
struct WebFile {
  const char* uri;
  const char* file;
  const char* mime;
};
constexpr WebFile kWebFiles[] = {
    {"/", "index.html", "text/html; charset=utf-8"},
    {"/index.html", "index.html", "text/html; charset=utf-8"},
    {"/app.js", "app.js", "text/javascript; charset=utf-8"},
    {"/style.css", "style.css", "text/css; charset=utf-8"},
    {"/uPlot.iife.min.js", "uPlot.iife.min.js", "text/javascript; charset=utf-8"},
    {"/uPlot.min.css", "uPlot.min.css", "text/css; charset=utf-8"},
};

}  // namespace

Server::Server(Options o, std::vector<Channel> channels) : o_(std::move(o)), channels_(std::move(channels)) {
  for (size_t i = 0; i < channels_.size(); ++i) {
    channels_[i].id = static_cast<uint32_t>(i);
    subscribers_.push_back(std::make_unique<std::atomic<int>>(0));
  }
  session_ = std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(
                                std::chrono::system_clock::now().time_since_epoch())
                                .count());
}

Server::~Server() {
  stop();
}

bool Server::start(std::string& error) {
  mg_init_library(0);
  const std::string ports = o_.bind + ":" + std::to_string(o_.port);
  // A WebSocket holds one of civetweb's worker threads while it is open: 32 of them serve the page's requests
  // and the clients; a peer that vanished without closing is found by ping/pong within websocket_timeout_ms.
  const char* options[] = {"listening_ports", ports.c_str(), "num_threads", "32", "request_timeout_ms", "10000",
                           "enable_keep_alive", "yes", "enable_websocket_ping_pong", "yes", "websocket_timeout_ms",
                           "30000", nullptr};
  mg_callbacks cb{};
  ctx_ = mg_start(&cb, this, options);
  if (ctx_ == nullptr) {
    error = "cannot listen on " + ports + " (is the port taken, or the address not one of this machine's?)";
    return false;
  }
  mg_server_port sp[4]{};
  const int n = mg_get_server_ports(ctx_, 4, sp);
  port_ = n > 0 ? sp[0].port : o_.port;
  for (const auto& f : kWebFiles) mg_set_request_handler(ctx_, f.uri, &Server::on_http, this);
  for (const auto& [uri, fn] : json_) mg_set_request_handler(ctx_, uri.c_str(), &Server::on_http, this);
  for (const auto& [uri, fn] : post_) mg_set_request_handler(ctx_, uri.c_str(), &Server::on_http, this);
  static const char* names[] = {kSubprotocols[0], kSubprotocols[1]};
  static mg_websocket_subprotocols subs{2, names};
  mg_set_websocket_handler_with_subprotocols(ctx_, "/", &subs, &Server::on_ws_connect, &Server::on_ws_ready,
                                             &Server::on_ws_data, &Server::on_ws_close, this);
  return true;
}

void Server::stop() {
  if (ctx_ == nullptr) return;
  mg_stop(ctx_);  // closes every connection: on_ws_close ends each writer
  ctx_ = nullptr;
  std::vector<std::shared_ptr<Client>> left;
  {
    std::lock_guard<std::mutex> lock(mu_);
    left.swap(clients_);
  }
  for (auto& c : left) {
    c->gone = true;
    c->out.close();
    if (c->writer.joinable()) c->writer.join();
  }
}

std::string Server::url() const {
  return "http://" + o_.bind + ":" + std::to_string(port_) + "/";
}

int Server::on_http(mg_connection* c, void* self) {
  auto* s = static_cast<Server*>(self);
  const mg_request_info* ri = mg_get_request_info(c);
  const std::string uri = ri->local_uri != nullptr ? ri->local_uri : "/";
  if (const auto p = s->post_.find(uri); p != s->post_.end()) {
    if (ri->request_method == nullptr || std::string(ri->request_method) != "POST") {
      mg_send_http_error(c, 405, "%s takes POST", uri.c_str());
      return 405;
    }
    if (ri->content_length > 4096) {
      mg_send_http_error(c, 413, "a request body of at most 4096 bytes");
      return 413;
    }
    PostIn in;
    in.remote = ri->remote_addr;
    auto header = [c](const char* name) {
      const char* v = mg_get_header(c, name);
      return std::string(v != nullptr ? v : "");
    };
    in.token = header("X-Tandem-Token");
    in.content_type = header("Content-Type");
    in.origin = header("Origin");
    in.host = header("Host");
    char buf[4096];
    for (int n = 0; in.body.size() < sizeof buf && (n = mg_read(c, buf, sizeof buf - in.body.size())) > 0;) {
      in.body.append(buf, static_cast<size_t>(n));
    }
    PostOut out;
    try {
      out = p->second(in);
    } catch (const std::exception&) {
      out = {500, std::string("{\"ok\":false,\"text\":\"internal error\"}")};
    }
    mg_printf(c, "HTTP/1.1 %d %s\r\nContent-Type: application/json\r\nContent-Length: %zu\r\nCache-Control: no-store\r\n\r\n",
              out.status, out.status == 200 ? "OK" : out.status == 400 ? "Bad Request" : out.status == 403 ? "Forbidden" : "Error",
              out.json.size());
    mg_write(c, out.json.data(), out.json.size());
    return out.status;
  }
  if (const auto j = s->json_.find(uri); j != s->json_.end()) {
    std::string body;
    try {
      body = j->second(ri->query_string != nullptr ? ri->query_string : "");
    } catch (const std::exception& e) {
      mg_send_http_error(c, 400, "%s", e.what());
      return 400;
    }
    mg_send_http_ok(c, "application/json", static_cast<long long>(body.size()));
    mg_write(c, body.data(), body.size());
    return 200;
  }
  for (const auto& f : kWebFiles) {
    if (uri != f.uri) continue;
    const std::string path = s->o_.web_dir + "/" + f.file;
    if (::access(path.c_str(), R_OK) != 0) {
      mg_send_http_error(c, 404, "%s is missing from %s (the build puts the page there)", f.file,
                         s->o_.web_dir.c_str());
      return 404;
    }
    mg_send_mime_file(c, path.c_str(), f.mime);
    return 200;
  }
  mg_send_http_error(c, 404, "not found: %s", uri.c_str());
  return 404;
}

int Server::on_ws_connect(const mg_connection*, void*) {
  return 0;
}  // accept (the subprotocol is chosen already)

void Server::on_ws_ready(mg_connection* c, void* self) {
  auto* s = static_cast<Server*>(self);
  auto cl = std::make_shared<Client>(s->o_.channel_limit);
  cl->conn = c;
  const mg_request_info* ri = mg_get_request_info(c);
  cl->address = std::string(ri->remote_addr) + ":" + std::to_string(ri->remote_port);
  for (const auto& ch : s->channels_) {
    if (ch.encoding == "json" && ch.topic != "tandem/view/events") cl->out.set_limit(ch.id, s->o_.page_limit);
  }
  cl->out.push_control(server_info(s->o_.name, s->session_, s->o_.metadata));
  cl->out.push_control(advertise(s->channels_));
  mg_set_user_connection_data(c, cl.get());
  cl->writer = std::thread([cl] {
    Frame f;
    while (!cl->gone) {
      if (!cl->out.pop(f, std::chrono::milliseconds(200))) continue;
      const int r =
          mg_websocket_write(cl->conn, f.text ? MG_WEBSOCKET_OPCODE_TEXT : MG_WEBSOCKET_OPCODE_BINARY,
                             f.data->data(), f.data->size());
      if (r <= 0) {  // closing, or a write that failed or timed out: this client is done (on_ws_close cleans up)
        cl->gone = true;
        cl->out.close();
        break;
      }
      ++cl->sent;
    }
  });
  std::lock_guard<std::mutex> lock(s->mu_);
  s->clients_.push_back(std::move(cl));
}

int Server::on_ws_data(mg_connection* c, int bits, char* data, size_t len, void* self) {
  auto* s = static_cast<Server*>(self);
  auto* cl = static_cast<Client*>(mg_get_user_connection_data(c));
  const int opcode = bits & 0x0f;
  if (opcode == MG_WEBSOCKET_OPCODE_CONNECTION_CLOSE) return 0;
  if (cl != nullptr && cl->gone) return 0;  // its writer failed: close the connection
  if (cl == nullptr || opcode != MG_WEBSOCKET_OPCODE_TEXT)
    return 1;  // binary ops (publishing) are not offered
  s->handle_op(*cl, std::string_view(data, len));
  return 1;
}

void Server::handle_op(Client& cl, std::string_view text) {
  const ClientOp op = parse_client_op(text);
  switch (op.kind) {
    case ClientOp::Kind::Subscribe:
      for (const auto& [sub, channel] : op.subscriptions) {
        if (channel >= channels_.size()) {
          cl.out.push_control(status(1, "subscribe: no channel " + std::to_string(channel)));
          continue;
        }
        std::vector<std::string> hist;
        {
          std::lock_guard<std::mutex> lock(cl.mu);
          if (cl.channel_of.count(sub) != 0 || cl.sub_of.count(channel) != 0) {
            cl.out.push_control(status(1, "subscribe: subscription " + std::to_string(sub) + " or channel " +
                                              std::to_string(channel) + " is subscribed already"));
            continue;
          }
          cl.sub_of[channel] = sub;
          cl.channel_of[sub] = channel;
        }
        subscribers_[channel]->fetch_add(1);
        {
          std::lock_guard<std::mutex> lock(mu_);
          const auto h = history_.find(channel);
          if (h != history_.end()) hist = h->second;
        }
        const auto now = static_cast<uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                                   std::chrono::system_clock::now().time_since_epoch())
                                                   .count());
        for (const auto& m : hist) cl.out.push(channel, message_data(sub, now, m));
      }
      return;
    case ClientOp::Kind::Unsubscribe:
      for (const uint32_t sub : op.unsubscribe) {
        std::lock_guard<std::mutex> lock(cl.mu);
        const auto it = cl.channel_of.find(sub);
        if (it == cl.channel_of.end()) continue;
        subscribers_[it->second]->fetch_sub(1);
        cl.out.clear(it->second);
        cl.sub_of.erase(it->second);
        cl.channel_of.erase(it);
      }
      return;
    case ClientOp::Kind::Ignored:
    case ClientOp::Kind::Bad:
      cl.out.push_control(status(1, op.error));
      return;
  }
}

void Server::on_ws_close(const mg_connection* c, void* self) {
  auto* s = static_cast<Server*>(self);
  auto* raw = static_cast<Client*>(mg_get_user_connection_data(c));
  if (raw == nullptr) return;
  std::shared_ptr<Client> cl;
  {
    std::lock_guard<std::mutex> lock(s->mu_);
    for (auto it = s->clients_.begin(); it != s->clients_.end(); ++it) {
      if (it->get() != raw) continue;
      cl = *it;
      s->clients_.erase(it);
      break;
    }
  }
  if (!cl) return;
  cl->gone = true;
  cl->out.close();
  if (cl->writer.joinable()) cl->writer.join();
  std::lock_guard<std::mutex> lock(cl->mu);
  for (const auto& [channel, sub] : cl->sub_of) {
    s->subscribers_[channel]->fetch_sub(1);
    std::lock_guard<std::mutex> l2(s->mu_);
    s->dropped_gone_[channel] += cl->out.dropped(channel);
  }
  cl->sub_of.clear();
  cl->channel_of.clear();
}

void Server::publish(uint32_t channel, uint64_t time_ns, std::string_view payload) {
  if (!wanted(channel)) return;
  std::vector<std::shared_ptr<Client>> cs;
  {
    std::lock_guard<std::mutex> lock(mu_);
    cs = clients_;
  }
  for (const auto& cl : cs) {
    if (cl->gone) continue;
    uint32_t sub = 0;
    {
      std::lock_guard<std::mutex> lock(cl->mu);
      const auto it = cl->sub_of.find(channel);
      if (it == cl->sub_of.end()) continue;
      sub = it->second;
    }
    cl->out.push(channel, message_data(sub, time_ns, payload));
  }
}

void Server::set_json(const std::string& uri, std::function<std::string(const std::string&)> answer) {
  json_[uri] = std::move(answer);
}

void Server::set_post(const std::string& uri, std::function<PostOut(const PostIn&)> answer) {
  post_[uri] = std::move(answer);
}

void Server::set_history(uint32_t channel, std::vector<std::string> messages) {
  std::lock_guard<std::mutex> lock(mu_);
  history_[channel] = std::move(messages);
}

void Server::broadcast_time(uint64_t time_ns) {
  std::lock_guard<std::mutex> lock(mu_);
  for (const auto& cl : clients_)
    cl->out.push(0xffffffffU, time_frame(time_ns));  // its own queue
}

void Server::broadcast_status(int level, const std::string& message) {
  std::lock_guard<std::mutex> lock(mu_);
  for (const auto& cl : clients_) cl->out.push_control(status(level, message));
}

std::vector<Server::ClientInfo> Server::clients() const {
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<ClientInfo> out;
  for (const auto& cl : clients_)
    out.push_back({cl->address, cl->sent.load(), cl->out.dropped_total(), cl->out.queued()});
  return out;
}

std::map<std::string, uint64_t> Server::drops() const {
  std::lock_guard<std::mutex> lock(mu_);
  std::map<std::string, uint64_t> out;
  for (const auto& [channel, n] : dropped_gone_) out[channels_[channel].topic] += n;
  for (const auto& cl : clients_) {
    for (const auto& ch : channels_) {
      const uint64_t n = cl->out.dropped(ch.id);
      if (n > 0) out[ch.topic] += n;
    }
  }
  return out;
}

}  // namespace tandem::view
