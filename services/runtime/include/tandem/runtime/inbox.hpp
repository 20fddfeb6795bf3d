// A queue of samples taken in the DDS thread that received them, each with its arrival time (monotonic ns)
// and the index of the reader it came from: the owning thread is not woken per sample (it reads the queue when
// it wants, e.g. at a deadline), or is woken when `notify` is set (it waits with `wait`).
#pragma once

#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <time.h>

#include <array>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <mutex>

namespace tandem::runtime {

template <class T, size_t N>
class Inbox : public eprosima::fastdds::dds::DataReaderListener {
 public:
  struct Item {
    T sample;
    int source = 0;
    long long at_ns = 0;
  };
  /// Holds at most `max_items`: beyond that the oldest item is dropped (and counted), so that a reader of the
  /// queue that falls behind costs memory up to a bound, not without one.
  explicit Inbox(bool notify, size_t max_items = 4096) : notify_(notify), max_items_(max_items) {}
  /// The readers whose samples come here; an item's `source` is the index of its reader.
  void set_sources(const std::array<eprosima::fastdds::dds::DataReader*, N>& readers) {
    std::lock_guard<std::mutex> lock(mu_);
    readers_ = readers;
  }
  void on_data_available(eprosima::fastdds::dds::DataReader* r) override {
    eprosima::fastdds::dds::SampleInfo info;
    std::unique_lock<std::mutex> lock(mu_);
    int source = -1;  // a reader not (yet) registered: its samples are dropped
    for (size_t i = 0; i < N; ++i) {
      if (readers_[i] == r) source = static_cast<int>(i);
    }
    while (r->take_next_sample(&scratch_, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data || source < 0) continue;
      timespec now{};
      ::clock_gettime(CLOCK_MONOTONIC, &now);
      if (items_.size() >= max_items_) {
        items_.pop_front();
        ++dropped_;
      }
      items_.push_back({scratch_, source, static_cast<long long>(now.tv_sec) * 1000000000LL + now.tv_nsec});
    }
    lock.unlock();
    if (notify_) cv_.notify_one();
  }
  bool pop(Item& out) {
    std::lock_guard<std::mutex> lock(mu_);
    if (items_.empty()) return false;
    out = items_.front();
    items_.pop_front();
    return true;
  }
  /// Items dropped because the queue was full.
  unsigned long long dropped() const {
    std::lock_guard<std::mutex> lock(mu_);
    return dropped_;
  }
  /// Waits up to `seconds` for an item (with notify set).
  void wait(double seconds) {
    std::unique_lock<std::mutex> lock(mu_);
    cv_.wait_for(lock, std::chrono::duration<double>(seconds), [&] { return !items_.empty(); });
  }

 private:
  bool notify_;
  size_t max_items_;
  unsigned long long dropped_ = 0;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::deque<Item> items_;
  std::array<eprosima::fastdds::dds::DataReader*, N> readers_{};
  T scratch_;
};

}  // namespace tandem::runtime
