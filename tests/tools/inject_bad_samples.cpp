// Test participant: joins a running deployment's domain and publishes invalid samples for a while:
// torque commands with NaN and over the torque limit; module plans with a NaN waypoint
// and with a strength out of range (every robot and the world must reject them). It follows the world's tick so that the bad samples compete with the good ones.
// usage: tandem_inject --domain ID --module NAME --seconds S
#include <tandemPubSubTypes.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <cstdlib>
#include <limits>
#include <string>

#include "tandem/dds/bus.hpp"

namespace bus = tandem::dds;
using namespace tandem;

namespace {
int run(int argc, char** argv) {
  int domain = -1;
  std::string module = "m1";
  double seconds = 2.0;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--domain") domain = std::atoi(argv[i + 1]);
    if (a == "--module") module = argv[i + 1];
    if (a == "--seconds") seconds = std::atof(argv[i + 1]);
  }
  if (domain < 0) {
    std::fprintf(stderr, "usage: tandem_inject --domain ID [--module NAME] [--seconds S]\n");
    return 2;
  }
  bus::Participant part(domain, "test-injector", bus::Transport::SharedMemory);
  bus::Reader<msg::ArmSensors, msg::ArmSensorsPubSubType> sensors(part, bus::arm_topic(bus::kSensorsTopic, module + "/left"),
                                                                  bus::TopicKind::Sensors);
  // Stronger than any robot: under EXCLUSIVE ownership the world hears only this writer while it is alive,
  // so every invalid command really reaches the world's checks (and the world must not apply any).
  bus::Writer<msg::TorqueCommand, msg::TorqueCommandPubSubType> left(part, bus::arm_topic(bus::kTorquesTopic, module + "/left"),
                                                                      bus::TopicKind::Torques, 1000);
  bus::Writer<msg::TorqueCommand, msg::TorqueCommandPubSubType> right(part, bus::arm_topic(bus::kTorquesTopic, module + "/right"),
                                                                       bus::TopicKind::Torques, 1000);
  bus::Writer<msg::SupervisorPlan, msg::SupervisorPlanPubSubType> plans(part, bus::module_topic(bus::kSupervisorPlanTopic, module),
                                                                        bus::TopicKind::Task);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  msg::ArmSensors s;
  unsigned long long sent = 0, sent_torques = 0;
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < seconds) {
    if (!sensors.wait(0.05)) continue;
    uint64_t tick = 0;
    bool got = false;
    while (sensors.take(s)) {
      tick = s.tick();
      got = true;
    }
    if (!got) continue;
    msg::TorqueCommand c;
    c.tick(tick);
    c.strength(1000);
    c.joints(3);
    c.tau({nan, 0.0, 0.0, 0.0});
    left.write(c);
    c.tau({1e7, 0.0, 0.0, 0.0});
    right.write(c);
    msg::SupervisorPlan p;  // outranks every supervisor (epoch 7), but malformed: must be rejected
    p.module_id(module);
    p.supervisor_id("injector");
    p.strength(100);
    p.epoch(7);
    p.version(1000 + sent);
    p.waypoints({inf, 0.8, 0.0, 1.0});
    plans.write(p);
    p.waypoints({});
    p.strength(1000);  // out of [1, 100]
    plans.write(p);
    sent += 4;
    sent_torques += 2;
  }
  std::printf("injected %llu invalid samples\ninjected_torques=%llu\n", sent, sent_torques);
  return sent > 0 ? 0 : 1;
}
}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem_inject: %s\n", e.what());
    return 2;
  }
}
