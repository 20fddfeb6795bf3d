// tandem-supervisor: the supervisor of one basic module. For every sensor sample of tick k it publishes that
// arm's references for ticks k and k+1 (eq. 15 on the planned object path) with the grasp force h_ref (eq. 16).
#include <tandemPubSubTypes.h>

#include <algorithm>
#include <chrono>
#include <thread>
#include <cstdio>

#include "tandem/runtime/role.hpp"
#include "tandem/runtime/status.hpp"

using namespace tandem;
namespace bus = tandem::dds;

int main(int argc, char** argv) {
  runtime::RoleOptions opt;
  int code = 0;
  if (!runtime::parse_role_options("supervisor", argc, argv, false, opt, code)) return code;
  runtime::install_stop_handlers();
  runtime::RoleContext ctx;
  try {
    ctx = runtime::load_context(opt);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tandem-supervisor: %s\n", e.what());
    return 2;
  }
  const sim::ModuleSetup& m = ctx.module;
  bus::Participant part(opt.domain, "supervisor/" + opt.module, opt.transport);
  bus::Reader<msg::ArmSensors, msg::ArmSensorsPubSubType> sensors(part, bus::kSensorsTopic, bus::TopicKind::Sensors);
  bus::Writer<msg::ArmReference, msg::ArmReferencePubSubType> refs(part, bus::kReferencesTopic,
                                                                   bus::TopicKind::References);
  runtime::StatusPublisher status(part, opt.module + "/supervisor", "supervisor", opt.module);
  status.msg().deployment(opt.deployment);
  status.set(runtime::Lifecycle::Active, "publishing references");
  msg::ArmSensors s;
  msg::ArmReference r;
  std::array<long, 2> last{-1, -1};
  auto last_input = std::chrono::steady_clock::now();
  while (!runtime::g_stop && (last[0] + 1 < m.steps || last[1] + 1 < m.steps)) {
    bool got = false;
    while (sensors.take(s)) {
      got = true;
      const int j = ctx.arm_index(s.arm_id());
      if (j < 0) continue;  // another module's arm
      // The reference depends only on the planned path, so publish tick k and the next one: the robot then
      // holds the reference of tick k+1 before its sensor sample arrives (one DDS hop less per tick).
      const long k = static_cast<long>(s.tick());
      for (long kk = std::max(k, last[static_cast<size_t>(j)] + 1); kk <= std::min(k + 1, m.steps - 1); ++kk) {
        const model::ArmReference ref = sim::supervisor_reference(m, j, kk);  // eq. (15)
        r.arm_id(s.arm_id());
        r.tick(static_cast<uint64_t>(kk));
        for (int i = 0; i < 3; ++i) {
          r.x()[static_cast<size_t>(i)] = ref.x(i);
          r.xd()[static_cast<size_t>(i)] = ref.xd(i);
          r.xdd()[static_cast<size_t>(i)] = ref.xdd(i);
        }
        r.force(ref.force);
        refs.write(r);
        last[static_cast<size_t>(j)] = kk;
      }
    }
    const auto now = std::chrono::steady_clock::now();
    if (got) last_input = now;
    if (std::chrono::duration<double>(now - last_input).count() > opt.timeout) {
      std::fprintf(stderr, "tandem-supervisor %s: no sensor sample for %.1f s; stopping\n", opt.module.c_str(),
                   opt.timeout);
      status.set(runtime::Lifecycle::Error, "no sensor samples");
      return 4;
    }
    sensors.wait(0.01);
  }
  status.set(runtime::Lifecycle::Finalized, runtime::g_stop ? "stopped" : "task done");
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  return 0;
}
