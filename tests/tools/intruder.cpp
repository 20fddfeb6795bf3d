// Test participant for the security tests (tests/security/security.sh): tries to become a torque writer of an
// arm. With DDS-Security the participant uses TANDEM_SECURITY_DIR/TANDEM_IDENTITY like any tandem process
// (none set: no credentials). Prints "writer=created matched=N" or "writer=refused: <why>".
// usage: tandem_intruder --domain ID --arm M/ROBOT [--seconds S] [--until-matched] [--transport shm|udp]
// Exit: 0 the writer was created (matched readers: see the output), 3 refused, 2 bad arguments.
#include <tandemPubSubTypes.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

#include "tandem/dds/bus.hpp"

namespace bus = tandem::dds;
using namespace tandem;

int main(int argc, char** argv) {
  int domain = -1;
  std::string arm;
  double seconds = 3.0;
  bool until_matched = false;  // a positive control: stop as soon as the world matched (at most --seconds)
  bus::Transport transport = bus::Transport::SharedMemory;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--until-matched") {
      until_matched = true;
      continue;
    }
    if (i + 1 >= argc) break;
    const std::string v = argv[++i];
    if (a == "--domain") domain = std::atoi(v.c_str());
    if (a == "--arm") arm = v;
    if (a == "--seconds") seconds = std::atof(v.c_str());
    if (a == "--transport") transport = v == "udp" ? bus::Transport::Udp : bus::Transport::SharedMemory;
  }
  if (domain < 0 || arm.empty()) {
    std::fprintf(stderr, "usage: tandem_intruder --domain ID --arm M/ROBOT [--seconds S] [--until-matched] [--transport shm|udp]\n");
    return 2;
  }
  try {
    bus::Participant part(domain, "test-intruder", transport);
    // The strongest strength there is: if the world matched this writer, its commands would take the arm.
    bus::Writer<msg::TorqueCommand, msg::TorqueCommandPubSubType> w(part, bus::arm_topic(bus::kTorquesTopic, arm),
                                                                   bus::TopicKind::Torques, 100);
    int matched = 0;
    const auto t0 = std::chrono::steady_clock::now();
    while (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < seconds) {
      matched = std::max(matched, w.matched());
      if (until_matched && matched > 0) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    std::printf("writer=created matched=%d\n", matched);
    return 0;
  } catch (const std::exception& e) {
    std::printf("writer=refused: %s\n", e.what());
    return 3;
  }
}
