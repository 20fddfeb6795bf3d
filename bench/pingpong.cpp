// Bare Fast DDS ping-pong between two processes, with the same participant set-up and QoS as the runtime's
// per-tick topics: the floor against which `bench/loop.sh` compares the runtime's sample->command latency.
// usage: tandem_bench_pingpong pong --domain D [--seconds S]
//        tandem_bench_pingpong ping --domain D [--count N] [--transport shm|udp]
#include <tandemPubSubTypes.h>
#include <time.h>

#include <algorithm>
#include <csignal>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include "tandem/dds/bus.hpp"

namespace bus = tandem::dds;
using tandem::msg::TorqueCommand;
using tandem::msg::TorqueCommandPubSubType;

namespace {
volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }
long long now_ns() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<long long>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || (std::string(argv[1]) != "ping" && std::string(argv[1]) != "pong")) {
    std::fprintf(stderr, "usage: tandem_bench_pingpong ping|pong --domain D [--count N] [--seconds S] [--transport shm|udp]\n");
    return 2;
  }
  const bool ping = std::string(argv[1]) == "ping";
  std::signal(SIGINT, on_signal);  // stop cleanly, so the participant removes its shared-memory files
  std::signal(SIGTERM, on_signal);
  int domain = 0, count = 5000;
  double seconds = 30.0;
  bus::Transport transport = bus::Transport::SharedMemory;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--domain") domain = std::atoi(argv[i + 1]);
    if (a == "--count") count = std::atoi(argv[i + 1]);
    if (a == "--seconds") seconds = std::atof(argv[i + 1]);
    if (a == "--transport") transport = std::string(argv[i + 1]) == "udp" ? bus::Transport::Udp : bus::Transport::SharedMemory;
  }
  bus::Participant part(domain, ping ? "bench-ping" : "bench-pong", transport);
  bus::Writer<TorqueCommand, TorqueCommandPubSubType> out(part, ping ? "bench/ping" : "bench/pong", bus::TopicKind::Torques);
  bus::Reader<TorqueCommand, TorqueCommandPubSubType> in(part, ping ? "bench/pong" : "bench/ping", bus::TopicKind::Torques);
  TorqueCommand msg;
  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  if (!ping) {
    while (elapsed() < seconds && g_stop == 0) {
      if (!in.wait(0.1)) continue;
      while (in.take(msg)) out.write(msg);  // echo
    }
    return 0;
  }
  while ((out.matched() < 1 || in.matched() < 1) && elapsed() < 10.0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  std::vector<double> rtt;
  rtt.reserve(static_cast<size_t>(count));
  long lost = 0;
  timespec next{};
  ::clock_gettime(CLOCK_MONOTONIC, &next);
  for (int k = 0; k < count; ++k) {
    next.tv_nsec += 1000000;  // 1 kHz, as the control loop
    if (next.tv_nsec >= 1000000000L) {
      next.tv_nsec -= 1000000000L;
      ++next.tv_sec;
    }
    ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
    msg.tick(static_cast<uint64_t>(k));
    const long long sent = now_ns();
    out.write(msg);
    bool back = false;
    while (!back && now_ns() - sent < 100000000LL) {
      if (!in.wait(0.1)) break;
      while (in.take(msg)) {
        if (msg.tick() == static_cast<uint64_t>(k)) back = true;
      }
    }
    if (back) {
      rtt.push_back(static_cast<double>(now_ns() - sent) * 1e-3);
    } else {
      ++lost;
    }
  }
  std::sort(rtt.begin(), rtt.end());
  auto pct = [&](double p) { return rtt.empty() ? 0.0 : rtt[std::min(rtt.size() - 1, static_cast<size_t>(p * static_cast<double>(rtt.size())))]; };
  long over = 0;
  for (double v : rtt) over += v > 1000.0 ? 1 : 0;
  std::printf("pingpong_p50_us=%.1f\npingpong_p99_us=%.1f\npingpong_max_us=%.1f\npingpong_over_1ms=%ld\npingpong_lost=%ld\npingpong_samples=%zu\n",
              pct(0.5), pct(0.99), pct(1.0), over, lost, rtt.size());
  return 0;
}
