// One viewer client's frames waiting to be sent. Bounded by design: a queue per channel that drops its oldest
// frame when full and counts it, and a send order that takes one frame from each waiting channel in turn, so
// that a busy per-tick channel can never starve a rare one (events, state) and a slow or stalled client costs
// the deployment nothing but its own drops. (foxglove_bridge drops by bytes across all topics: big frames
// starve small ones there.)
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>

namespace tandem::view {

struct Frame {
  bool text = false;  ///< a JSON text frame (else binary)
  std::shared_ptr<const std::string> data;
};

class Outbox {
 public:
  /// `channel_limit`: frames kept per channel; `control_limit`: text frames (serverInfo, advertise, status)
  /// kept.
  explicit Outbox(size_t channel_limit = 1000, size_t control_limit = 256)
      : channel_limit_(channel_limit), control_limit_(control_limit) {}

  /// A protocol frame (serverInfo, advertise, status): before any channel's; the oldest goes if over the
  /// limit.
  void push_control(std::string text);
  /// A frame of `channel`; returns false if the channel's oldest frame was dropped to make room.
  bool push(uint32_t channel, std::string frame);
  /// Sets one channel's limit (a per-tick channel may keep more than a page's).
  void set_limit(uint32_t channel, size_t limit);
  /// Forgets a channel's frames (its subscription ended).
  void clear(uint32_t channel);

  /// The next frame, waiting up to `wait`: control frames first, then one frame from each waiting channel in
  /// turn. false if none came or the outbox is closed.
  bool pop(Frame& out, std::chrono::milliseconds wait);
  /// Wakes the sender for good: pop() returns false from now on.
  void close();

  uint64_t dropped(uint32_t channel) const;
  uint64_t dropped_total() const;
  size_t queued() const;

 private:
  struct Queue {
    std::deque<std::shared_ptr<const std::string>> frames;
    size_t limit = 0;
    uint64_t dropped = 0;
  };
  mutable std::mutex mu_;
  std::condition_variable cv_;
  size_t channel_limit_, control_limit_;
  std::deque<std::shared_ptr<const std::string>> control_;
  std::map<uint32_t, Queue> channels_;
  uint32_t next_ = 0;  ///< round robin: the channel after the one served last
  uint64_t control_dropped_ = 0;
  bool closed_ = false;
};

}  // namespace tandem::view
