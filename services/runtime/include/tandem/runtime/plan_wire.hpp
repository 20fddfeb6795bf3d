// The plan between its plain form (plan::PlanData, services/plan) and the wire (msg::SupervisorPlan).
#pragma once

#include <tandemPubSubTypes.h>

#include "tandem/plan/plan.hpp"

namespace tandem::runtime {

inline void to_wire(const plan::PlanData& p, msg::SupervisorPlan& w) {
  w.supervisor_id(p.supervisor_id);
  w.strength(p.strength);
  w.epoch(p.epoch);
  w.version(p.version);
  w.task_id(p.task_id);
  w.tasks_done(p.tasks_done);
  w.running(p.running);
  w.start_tick(p.start_tick);
  w.tau_start(p.tau_start);
  for (size_t i = 0; i < 3; ++i) {
    w.rest()[i] = p.rest[i];
    w.path_start()[i] = p.path_start[i];
  }
  w.waypoints(p.waypoints);
  w.breaks(p.breaks);
  w.pause_requested(p.pause_requested);
  w.draining(p.draining);
  w.state(p.state);
  w.heard_tick(p.heard_tick);
}

inline plan::PlanData from_wire(const msg::SupervisorPlan& w) {
  plan::PlanData p;
  p.supervisor_id = w.supervisor_id();
  p.strength = w.strength();
  p.epoch = w.epoch();
  p.version = w.version();
  p.task_id = w.task_id();
  p.tasks_done = w.tasks_done();
  p.running = w.running();
  p.start_tick = w.start_tick();
  p.tau_start = w.tau_start();
  for (size_t i = 0; i < 3; ++i) {
    p.rest[i] = w.rest()[i];
    p.path_start[i] = w.path_start()[i];
  }
  p.waypoints = w.waypoints();
  p.breaks.assign(w.breaks().begin(), w.breaks().end());
  p.pause_requested = w.pause_requested();
  p.draining = w.draining();
  p.state = w.state();
  p.heard_tick = w.heard_tick();
  return p;
}

}  // namespace tandem::runtime
