// The world's results on the wire: WorldCore and the process's timing figures into a WorldSummary.
#pragma once

#include <tandemPubSubTypes.h>

#include <string>

#include "tandem/runtime/histogram.hpp"
#include "tandem/world/world_core.hpp"

namespace tandem::world_wire {

void fill_summary(const world::WorldCore& core, const std::string& module, long ticks, bool realtime,
                  unsigned long long overruns, const runtime::Histogram& latency_us,
                  const runtime::Histogram& wake_late_us, msg::WorldSummary& ws);

}  // namespace tandem::world_wire
