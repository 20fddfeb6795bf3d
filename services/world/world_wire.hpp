// The world's results on the wire: WorldCore and the process's timing figures into a WorldSummary, and the
// running counters of a WorldReport.
#pragma once

#include <tandemPubSubTypes.h>

#include <string>
#include <vector>

#include "tandem/runtime/histogram.hpp"
#include "tandem/world/world_core.hpp"

namespace tandem::world_wire {

void fill_summary(const world::WorldCore& core, const std::string& module, long ticks, bool realtime,
                  unsigned long long overruns, const runtime::Histogram& latency_us,
                  const runtime::Histogram& wake_late_us, msg::WorldSummary& ws);

/// The observers' part of a WorldReport: running counters (slips, contact losses, late ticks, failovers),
/// the load pause and who serves each arm.
void fill_report_counters(const world::WorldCore& core, bool realtime, msg::WorldReport& rep);

/// One arm's sensor sample of tick k (the arm of type `kind`), with the rank, version and start tick of the plan the
/// world follows.
void fill_sample(const world::SampleOut& o, model::ArmKind kind, long k, const plan::SupervisorRank& plan_rank, uint64_t plan_version,
                 long plan_since, msg::ArmSensors& s);

/// Who each arm follows now, as WorldReport.owners and the world's ProcessStatus.owners carry it.
std::vector<msg::ArmOwner> owners(const world::WorldCore& core);

}  // namespace tandem::world_wire
