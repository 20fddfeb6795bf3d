// A per-tick reader that outlives writers SIGKILLed in the middle of a write: the reproduction of a world that
// aborted inside Fast DDS 2.9.1 during a soak ("Interprocess mutex timeout when locking. Possible deadlock: owner
// died without unlocking?"). bench/peer_kill.sh starts one `reader` and SIGKILLs many `writer`s beside it.
// usage: tandem_bench_peer_kill reader --domain D [--seconds S] [--delivery datasharing|shm|udp]
//        tandem_bench_peer_kill writer --domain D [--delivery datasharing|shm|udp] [--rate HZ]
// --delivery: how the per-tick samples travel (both sides must agree): data-sharing (the runtime's default
// before 2026-11-25), the shared-memory transport, or UDP. --rate 0 (the default) writes as fast as it can,
// which widens the window in which a kill leaves a lock held. The reader prints one line per second:
// "reader t=<s> samples=<total>" and exits 0 after S seconds; the writer "writer t=<s> written=<n>
// worst_write_ms=<longest write() so far>".
#include <tandemPubSubTypes.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

#include "tandem/dds/bus.hpp"

namespace bus = tandem::dds;
using tandem::msg::TorqueCommand;
using tandem::msg::TorqueCommandPubSubType;

namespace {
volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

struct Counter : bus::fdds::DataReaderListener {
  std::atomic<long> n{0};
  void on_data_available(bus::fdds::DataReader* r) override {
    TorqueCommand m;
    bus::fdds::SampleInfo info;
    while (r->take_next_sample(&m, &info) == ReturnCode_t::RETCODE_OK) n.fetch_add(1, std::memory_order_relaxed);
  }
};
}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "";
  if (mode != "reader" && mode != "writer") {
    std::fprintf(stderr, "usage: tandem_bench_peer_kill reader|writer --domain D [--seconds S] [--rate HZ] "
                         "[--delivery datasharing|shm|udp]\n");
    return 2;
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  int domain = 0;
  double seconds = 60.0, rate = 0.0;
  std::string delivery = "datasharing";
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--domain") domain = std::atoi(argv[i + 1]);
    else if (a == "--seconds") seconds = std::atof(argv[i + 1]);
    else if (a == "--rate") rate = std::atof(argv[i + 1]);
    else if (a == "--delivery") delivery = argv[i + 1];
    else {
      std::fprintf(stderr, "tandem_bench_peer_kill: unknown option %s\n", a.c_str());
      return 2;
    }
  }
  if (delivery != "datasharing" && delivery != "shm" && delivery != "udp") {
    std::fprintf(stderr, "tandem_bench_peer_kill: --delivery %s: accepted: datasharing, shm, udp\n", delivery.c_str());
    return 2;
  }
  const bus::Transport transport = delivery == "udp" ? bus::Transport::Udp : bus::Transport::SharedMemory;
  bus::Participant part(domain, "peer-kill-" + mode, transport);
  const bool ds = delivery == "datasharing";
  bus::fdds::Topic* topic = part.topic("bench/peer_kill", new TorqueCommandPubSubType());
  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  if (mode == "reader") {
    Counter counter;
    auto* r = part.subscriber()->create_datareader(topic, bus::reader_qos(bus::TopicKind::TorquesRealtime, ds), &counter,
                                                   bus::fdds::StatusMask::data_available());
    if (r == nullptr) return 1;
    int last = -1;
    while (g_stop == 0 && elapsed() < seconds) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      const int s = static_cast<int>(elapsed());
      if (s != last) {
        last = s;
        std::printf("reader t=%d samples=%ld\n", s, counter.n.load());
        std::fflush(stdout);
      }
    }
    part.subscriber()->delete_datareader(r);
    return 0;
  }
  auto* w = part.publisher()->create_datawriter(topic, bus::writer_qos(bus::TopicKind::TorquesRealtime, 0, ds));
  if (w == nullptr) return 1;
  TorqueCommand m;
  double worst_ms = 0.0;
  int last = -1;
  const auto period = std::chrono::duration<double>(rate > 0 ? 1.0 / rate : 0.0);
  auto next = std::chrono::steady_clock::now();
  for (unsigned long k = 0; g_stop == 0 && elapsed() < seconds; ++k) {
    m.tick(k);
    const auto before = std::chrono::steady_clock::now();
    w->write(&m);
    worst_ms = std::max(worst_ms, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - before).count());
    if (static_cast<int>(elapsed()) != last) {
      last = static_cast<int>(elapsed());
      std::printf("writer t=%d written=%lu worst_write_ms=%.3f\n", last, k, worst_ms);
      std::fflush(stdout);
    }
    if (rate > 0) {
      next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
      std::this_thread::sleep_until(next);
    }
  }
  part.publisher()->delete_datawriter(w);
  return 0;
}
