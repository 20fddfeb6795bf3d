#include "tandem/view/outbox.hpp"

namespace tandem::view {

void Outbox::push_control(std::string text) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (closed_) return;
    if (control_.size() >= control_limit_) {
      control_.pop_front();
      ++control_dropped_;
    }
    control_.push_back(std::make_shared<const std::string>(std::move(text)));
  }
  cv_.notify_one();
}

bool Outbox::push(uint32_t channel, std::string frame) {
  bool kept_all = true;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (closed_) return true;
    Queue& q = channels_[channel];
    if (q.limit == 0) q.limit = channel_limit_;
    if (q.frames.size() >= q.limit) {
      q.frames.pop_front();
      ++q.dropped;
      kept_all = false;
    }
    q.frames.push_back(std::make_shared<const std::string>(std::move(frame)));
  }
  cv_.notify_one();
  return kept_all;
}

void Outbox::set_limit(uint32_t channel, size_t limit) {
  std::lock_guard<std::mutex> lock(mu_);
  Queue& q = channels_[channel];
  q.limit = limit == 0 ? 1 : limit;
  while (q.frames.size() > q.limit) {
    q.frames.pop_front();
    ++q.dropped;
  }
}

void Outbox::clear(uint32_t channel) {
  std::lock_guard<std::mutex> lock(mu_);
  const auto it = channels_.find(channel);
  if (it != channels_.end()) it->second.frames.clear();
}

bool Outbox::pop(Frame& out, std::chrono::milliseconds wait) {
  std::unique_lock<std::mutex> lock(mu_);
  auto ready = [&] {
    if (closed_ || !control_.empty()) return true;
    for (const auto& [id, q] : channels_) {
      if (!q.frames.empty()) return true;
    }
    return false;
  };
  if (!cv_.wait_for(lock, wait, ready) || closed_) return false;
  if (!control_.empty()) {
    out = {true, std::move(control_.front())};
    control_.pop_front();
    return true;
  }
  // Round robin from next_: the first waiting channel at or after it, else from the start.
  auto it = channels_.lower_bound(next_);
  for (int pass = 0; pass < 2; ++pass) {
    for (; it != channels_.end(); ++it) {
      if (it->second.frames.empty()) continue;
      out = {false, std::move(it->second.frames.front())};
      it->second.frames.pop_front();
      next_ = it->first + 1;
      return true;
    }
    it = channels_.begin();
  }
  return false;
}

void Outbox::close() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    closed_ = true;
  }
  cv_.notify_all();
}

uint64_t Outbox::dropped(uint32_t channel) const {
  std::lock_guard<std::mutex> lock(mu_);
  const auto it = channels_.find(channel);
  return it == channels_.end() ? 0 : it->second.dropped;
}

uint64_t Outbox::dropped_total() const {
  std::lock_guard<std::mutex> lock(mu_);
  uint64_t n = control_dropped_;
  for (const auto& [id, q] : channels_) n += q.dropped;
  return n;
}

size_t Outbox::queued() const {
  std::lock_guard<std::mutex> lock(mu_);
  size_t n = control_.size();
  for (const auto& [id, q] : channels_) n += q.frames.size();
  return n;
}

}  // namespace tandem::view
