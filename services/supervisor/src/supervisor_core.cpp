#include "tandem/supervisor/supervisor_core.hpp"

#include "tandem/model/grasp.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace tandem::supervisor {

using plan::TaskStateCode;

SupervisorCore::SupervisorCore(const sim::ModuleSetup& m, const SupervisorOptions& o, int64_t now_ns)
    : m_(m), o_(o), plan_(m, o.continuous), active_(o.strength == plan::kPrimaryStrength), rank_{0, o.strength},
      t_start_(now_ns), last_report_(now_ns), last_stronger_(now_ns), last_state_sent_(now_ns) {
  if (!active_) out_detail_ = kColdDetail;
  publish_state(true, now_ns);
}

TaskStateCode SupervisorCore::state() const {
  if (failed_) return TaskStateCode::Failed;
  const long k = std::max(heard_tick_, 0L);
  const bool busy = o_.continuous ? plan_.running() : !plan_.motion_over(k);
  if (draining_ && !busy) return TaskStateCode::Left;
  // Draining before paused: a paused module that was asked to drain says so (the launcher takes a leader that
  // does not for one that cannot hear it, and stops it); both keep their task for the coordinator.
  if (draining_) return TaskStateCode::Draining;
  if (plan_.target_rate() == 0.0 && plan_.paused_at(k)) return TaskStateCode::Paused;
  if (busy) return TaskStateCode::Running;
  return plan_.done() > 0 ? TaskStateCode::Done : TaskStateCode::Idle;
}

void SupervisorCore::publish_plan(TaskStateCode st, int64_t now_ns) {
  const bool changed = plan_.version() != plan_sent_version_ || pause_requested_ != plan_sent_pause_ ||
                       draining_ != plan_sent_drain_ || static_cast<uint8_t>(st) != plan_sent_state_;
  // Lockstep: at every report heard (the periodic ones and those a brake or a stop sends between them), so that the
  // lease always covers the newest tick the world has reported.
  const bool lease_due = o_.lease_every > 0 && heard_tick_ > plan_sent_heard_;
  if (!changed && !lease_due && now_ns - plan_sent_at_ < kHeartbeatNs) return;
  plan::PlanData p;
  plan_.export_to(p);
  p.supervisor_id = o_.self_id;
  p.strength = o_.strength;
  p.epoch = rank_.epoch;
  p.pause_requested = pause_requested_;
  p.draining = draining_;
  p.state = static_cast<uint8_t>(st);
  p.heard_tick = heard_tick_;
  out_plan_ = std::move(p);
  plan_sent_version_ = plan_.version();
  plan_sent_pause_ = pause_requested_;
  plan_sent_drain_ = draining_;
  plan_sent_state_ = static_cast<uint8_t>(st);
  plan_sent_at_ = now_ns;
  plan_sent_heard_ = heard_tick_;
}

void SupervisorCore::publish_state(bool force, int64_t now_ns) {
  if (!active_) return;  // a standby's duties start when it takes over
  const TaskStateCode st = state();
  publish_plan(st, now_ns);
  if (!force && st == reported_ && now_ns - last_state_sent_ < 100'000'000) return;
  out_state_ = StateOut{plan_.task_id(), static_cast<uint8_t>(st), plan_.done(),
                        static_cast<uint64_t>(std::max(heard_tick_, 0L))};
  if (st != reported_) {
    std::string detail = plan::task_state_name(static_cast<uint8_t>(st));
    if (st == TaskStateCode::Paused) {
      detail += hold_ ? " (for load)" : braked_[0] || braked_[1] ? " (arm braked)" : " (requested)";
    }
    if (o_.continuous) detail += ", " + std::to_string(plan_.done()) + " task(s) done";
    out_detail_ = detail;
  }
  reported_ = st;
  last_state_sent_ = now_ns;
}

bool SupervisorCore::adopt(const plan::PlanData& p, bool from_new_leader) {
  // From the same leader, never back to an older task than this one already started or finished on its own
  // (its plan may come a little after the assignment); a new leader's plan is the module's plan.
  if (!from_new_leader && (p.task_id < plan_.task_id() || (p.task_id == plan_.task_id() && p.tasks_done < plan_.done()))) {
    return true;
  }
  if (!plan_.import_from(p)) {
    log("a malformed plan from " + p.supervisor_id + " was ignored: " + plan::ModulePlan::check(p));
    return true;
  }
  if (p.rank().outranks(followed_)) followed_ = p.rank();
  pause_requested_ = p.pause_requested;
  draining_ = p.draining;
  if (p.state == static_cast<uint8_t>(TaskStateCode::Left)) {
    log(p.supervisor_id + " drained the module; leaving with it");
    return false;
  }
  return true;
}

void SupervisorCore::on_plan(const plan::PlanData& p, int64_t now_ns) {
  // A malformed plan says nothing about who leads (a stranger's plan with a high epoch must not make the leader
  // step down).
  if (p.supervisor_id == o_.self_id || !plan::ModulePlan::check(p).empty()) return;
  others_newest_ = std::max(others_newest_, static_cast<long>(p.heard_tick));
  max_epoch_ = std::max(max_epoch_, p.epoch);
  const plan::SupervisorRank r = p.rank();
  if (!r.outranks(rank_)) return;
  if (!active_ && r.outranks(followed_) && p.version < plan_.version()) {
    // A standby holds a newer version than another standby's takeover: the followers refuse that takeover (they hold
    // the newer version too), so it neither replaces this replica nor counts as a live leader (this one takes over
    // from a silent leader above its epoch, and the stale taker steps down to it).
    if (note_stale_taker(p)) {
      log(p.supervisor_id + " took over in epoch " + std::to_string(p.epoch) + " with plan version " +
          std::to_string(p.version) + ", older than this replica's version " + std::to_string(plan_.version()) +
          ": not followed");
    }
    return;
  }
  if (active_ && p.version < plan_.version()) {
    // A takeover older than this leader's plan: a standby that missed this one's newest version took over (this
    // one was only stalled). Followers that hold the newer version refuse it (plan::PlanFollower); update() steps
    // down if the world followed it all the same, and retakes above it if the world refused it.
    if (note_stale_taker(p)) {
      char line[256];
      std::snprintf(line, sizeof line, "%s took over in epoch %llu with plan version %llu, older than this leader's "
                    "version %llu; waiting for the world to refuse it (then retaking) or follow it (then stepping down)",
                    p.supervisor_id.c_str(), static_cast<unsigned long long>(p.epoch),
                    static_cast<unsigned long long>(p.version), static_cast<unsigned long long>(plan_.version()));
      log(line);
    }
    if (!latest_plan_ || r.outranks(latest_plan_->rank()) || p.version != latest_plan_->version) latest_plan_ = p;
    return;
  }
  heard_stronger_ = true;
  last_stronger_ = now_ns;
  stronger_tick_ = std::max(stronger_tick_, static_cast<long>(p.heard_tick));
  stronger_now_ = true;
  if (followed_.outranks(r)) return;  // a former leader's
  const bool newer = !latest_plan_ || r.outranks(latest_plan_->rank()) || p.version != latest_plan_->version;
  if (!newer) return;  // a heartbeat of the plan already adopted
  latest_plan_ = p;
  if (!active_ && !adopt(p, r.outranks(followed_))) {
    leaving_ = true;
  } else if (!active_ && !replica_) {
    replica_ = true;
    out_detail_ = kReplicaDetail;
  }
}

void SupervisorCore::on_request(Request r) {
  const bool pause = pause_requested_, drain = draining_;
  if (r == Request::Pause) pause_requested_ = true;
  if (r == Request::Resume) pause_requested_ = false;
  if (r == Request::Drain) draining_ = true;
  if (pause_requested_ == pause && draining_ == drain) return;  // a request sent again (the launcher re-sends drains)
  log(std::string(r == Request::Pause ? "pause" : r == Request::Resume ? "resume" : "drain") + " requested");
}

void SupervisorCore::on_assignment(uint64_t id, const std::string& name, const std::vector<double>& waypoints) {
  assignments_.push_back({id, name, waypoints});
  if (assignments_.size() > 8) assignments_.erase(assignments_.begin());  // a replica keeps the latest few
}

void SupervisorCore::on_report(const ReportIn& r, int64_t now_ns) {
  last_report_ = now_ns;
  if (active_ && suspect_from_ < 0 && heard_tick_ >= 0 && r.tick > heard_tick_ + kTakeOverTicks && others_newest_ >= 0 &&
      heard_tick_ - others_newest_ < kOthersRecentTicks) {
    // Back from a stall: another supervisor may have taken over meanwhile.
    suspect_from_ = r.tick;
    suspect_since_ = now_ns;
    log("the world is at tick " + std::to_string(r.tick) + ", " + std::to_string(r.tick - heard_tick_) +
        " past the newest this one had heard (it was stalled); silent until it hears whether another supervisor "
        "took over");
  }
  if (!active_ && heard_stronger_ && heard_tick_ >= 0 && r.tick > heard_tick_ + kTakeOverTicks) {
    // This standby did not hear the world for a while although its loop ran (its DDS threads starved on a busy
    // machine): the leader's plans of that time may still be on their way. Its silence counts from now, as after
    // standing still. Found by the one-hour soak: a standby heard the world again 320 ticks on, before the
    // leader's plans, took over at once with a replica that lacked the leader's last task, the references
    // jumped 9.3 mm under the held object, and it was dropped.
    last_stronger_ = now_ns;
    // Lockstep: the silence in ticks still counts from the leader's last plan. The world runs at most a lease past
    // it, and waits there for a leader that died: counted from this report, a silence the world cannot add to (it
    // waits) kept the standby from taking over until the lease lapsed, 1-4 s (the lockstep soak hour: a supervisor
    // kill with a warm standby took 4.1 s). Real time: from this report (the world runs on whatever the leader does).
    if (o_.lease_every <= 0) stronger_tick_ = std::max(stronger_tick_, r.tick);
    log("heard the world again " + std::to_string(r.tick - heard_tick_) +
        " ticks on (this one heard nothing meanwhile); the leader's silence counts from now");
  }
  if (!active_ && heard_stronger_ && heard_tick_ < 0 && r.tick <= kTakeOverTicks) {
    // A fresh world's first report: a leader plans and publishes only once it hears the world (update), so its
    // silence before the world ran was no failure. (A standby that joins a running module keeps its count: lockstep
    // must not wait for the lease to lapse, finding 52.) It counts from now (the lockstep soak hour, finding 53: a standby in a
    // fresh module counted the leader's silence from its first plan, heard 0.8 s before the world's first tick).
    last_stronger_ = std::max(last_stronger_, now_ns);
    stronger_tick_ = std::max(stronger_tick_, r.tick);
  }
  // The world follows a plan of a higher rank than this leader's, and this one never heard it (else on_plan would
  // have stepped it down within a few ticks): its plan reader missed a takeover's writer. Found by a soak-small hour:
  // a leader in epoch 2 never heard its standby take over in epoch 3; the module's arms followed epoch 3 while
  // this one went on assigning itself tasks nobody carried out, and after epoch 3's leader was killed no
  // supervisor took over. It steps down: as a standby it takes over above the world's epoch if its replica has
  // the object where the module's plan has it, else the module has lost its plan (restarted).
  const bool rank_known = plan::valid_rank(r.world_rank.strength, r.world_rank.epoch);  // {0, 0}: no plan yet
  if (rank_known) max_epoch_ = std::max(max_epoch_, r.world_rank.epoch);
  world_rank_ = rank_known ? r.world_rank : plan::SupervisorRank{};
  world_version_ = rank_known ? r.world_plan_version : 0;
  if (!rank_known || (world_rank_.epoch == rank_.epoch && world_rank_.strength == rank_.strength)) confirmed_ = true;
  if (!first_world_heard_) {
    first_world_heard_ = true;
    first_world_ = {world_rank_, world_version_};
  }
  if (active_ && rank_known && r.world_rank.outranks(rank_)) {
    if (outranked_since_ < 0) outranked_since_ = r.tick;
    if (r.tick - outranked_since_ >= kOutrankedTicks) {
      active_ = false;
      suspect_from_ = -1;
      outranked_since_ = -1;
      heard_stronger_ = true;  // a leader exists (the world follows it): its silence counts from now
      last_stronger_ = now_ns;
      stronger_tick_ = std::max(stronger_tick_, r.tick);
      log("stepping down: the world has followed a plan of epoch " + std::to_string(r.world_rank.epoch) + " (strength " +
          std::to_string(r.world_rank.strength) + ") for " + std::to_string(kOutrankedTicks) +
          " ticks, above this one's, and this one never heard it");
    }
  } else {
    outranked_since_ = -1;
  }
  if (r.object_known && (!object_known_ || (r.object_xy - object_xy_).norm() > kStillStepM)) still_since_ = r.tick;
  if (r.object_known && (trail_n_ == 0 || r.tick > trail_[(trail_next_ + kTrail - 1) % kTrail].first)) {
    trail_[trail_next_] = {r.tick, r.object_xy};
    trail_next_ = (trail_next_ + 1) % kTrail;
    trail_n_ = std::min(trail_n_ + 1, kTrail);
  }
  heard_tick_ = std::max(heard_tick_, r.tick);
  braked_ = r.braked;
  hold_ = r.hold;
  braked_since_ = r.braked_since;
  released_at_ = r.released_at;
  object_xy_ = r.object_xy;
  object_known_ = r.object_known;
  if (r.failed && !failed_) {
    failed_ = true;  // latched: the module takes no task, and its task is not done, until it is cleared
    log("the world reports the object dropped: the module is failed; its task is not done");
  }
  if (r.normal_min < m_.safe_grasp_force && r.tick > static_cast<long>(o_.transient_s / m_.period) &&
      r.tick - low_force_reported_ > 1000) {
    low_force_reported_ = r.tick;  // eq. (14) violated: at most one line a second
    char line[160];
    std::snprintf(line, sizeof line, "grasp below the safe force at tick %ld: %.2f N < h_sg %.2f N", r.tick,
                  r.normal_min, m_.safe_grasp_force);
    log(line);
  }
}

void SupervisorCore::update(int64_t now_ns) {
  const bool stronger = stronger_now_;
  stronger_now_ = false;
  if (leaving_) return;
  if (!active_ && last_update_ns_ > 0 && now_ns - last_update_ns_ > kTakeOverAfterNs && heard_stronger_) {
    // This standby itself stood still (SIGSTOP, starvation): the leader's silence counts from now, so that the
    // plans it published meanwhile (transient-local) arrive before any takeover. Found by the hour-long soak: a
    // standby back from a stall took over at once with a replica that lacked the leader's last task, and the
    // references jumped 10 mm under the held object.
    last_stronger_ = now_ns;
    if (o_.lease_every <= 0) stronger_tick_ = std::max(stronger_tick_, heard_tick_);  // (lockstep: as above)
    log("stood still for " + std::to_string((now_ns - last_update_ns_) / 1000000) +
        " ms; the leader's silence counts from now");
  }
  last_update_ns_ = now_ns;
  if (suspect_from_ >= 0 && !stronger && (others_newest_ >= suspect_from_ || now_ns - suspect_since_ > kSuspectMaxNs)) {
    log(std::string(others_newest_ >= suspect_from_ ? "no other supervisor took over" : "no other supervisor heard") +
        "; leading on");
    suspect_from_ = -1;
  }
  const bool flowing = now_ns - last_report_ < kTakeOverAfterNs;
  bool step_down = stronger;
  if (active_ && stale_taker_tick_ >= 0) {
    if (world_rank_.epoch == stale_taker_.epoch && world_rank_.strength == stale_taker_.strength) {
      // The world followed it (it had not had this one's newest version yet): the module follows the taker.
      step_down = true;
      heard_stronger_ = true;
      last_stronger_ = now_ns;
      stronger_tick_ = std::max(stronger_tick_, heard_tick_);
      stale_taker_tick_ = -1;
    } else if (world_rank_.epoch == rank_.epoch && world_rank_.strength == rank_.strength &&
               world_version_ > stale_taker_version_) {
      // The world follows this leader's plan in a version newer than the taker's: it refuses the taker, now or when
      // its plan arrives (proof, not a timer: a leader back from a stall hears the taker before the world's reports
      // of the meantime). Retake in an epoch above it, with the newer plan: every follower adopts that, and the
      // stale taker steps down to it.
      rank_.epoch = max_epoch_ + 1;
      max_epoch_ = rank_.epoch;
      plan_sent_version_ = ~0ULL;  // publish the plan now, under the new epoch
      confirmed_ = false;
      unconfirmed_since_ = -1;
      refused_said_ = false;
      log("the world refused the older takeover (it follows this leader's plan version " + std::to_string(world_version_) +
          "); retaking in epoch " + std::to_string(rank_.epoch) + " with plan version " + std::to_string(plan_.version()));
      stale_taker_tick_ = -1;
      latest_plan_.reset();
    }
  }
  // Never heard a leader: take over after kTakeOverAloneNs of the world's reports, and only if the object is
  // where this supervisor's own (initial) plan has it now: otherwise the module follows a plan this one never
  // heard, and leading with its own would jump the references (robots and world would refuse it anyway).
  const bool behind = behind_world();
  // A failed module (the world reports its object dropped, both arms braked for good) has no object to keep on a
  // plan: any supervisor may lead it, to report it failed until it is cleared. (A soak saw a failed module's standby
  // refuse the lead because the fallen object was "67 km off" its replica; the module was restarted as if its plan
  // were lost, which is not the "out until cleared" rule.)
  // The object moves as the replica's plan has it (a replica at rest with the object moving on a leader's plan it
  // missed is within kReplicaMatch for a while; finding 53). Not known yet (no report 10-200 ticks back: a world's
  // first ticks, or a starved standby that heard the world again after a gap): not matching until the next reports
  // tell (in lockstep a world that waits at its lease for a dead leader runs on once the lease lapses, 3 s). A
  // world that does not report the object: the version rule alone, as the position rule.
  const std::optional<double> speed_off = replica_speed_off();
  // A world that has not ticked yet (its start wait reports tick 0) has not moved the object: its speed is known, 0.
  const bool not_ticking = heard_tick_ <= 0 && stronger_tick_ <= 0;
  const bool moves_as_replica =
      !object_known_ || (not_ticking && plan_.sample(0).vel.head<2>().norm() == 0.0) ||
      (speed_off && *speed_off < kReplicaSpeedMatch);
  const bool alone_ok = failed_ || (heard_tick_ > kTakeOverTicks && !behind && moves_as_replica &&
                                    (plan_.sample(heard_tick_).pose.head<2>() - object_xy_).norm() < kAloneMatch);
  if (!heard_stronger_ && !active_ && now_ns - t_start_ > kTakeOverAloneNs && !alone_ok && !alone_refused_ && !deaf_) {
    give_up(first_world_, "never heard a leader, but the world's plan changed meanwhile",
            "never heard a leader, and the object is not where the initial plan has it: not taking over");
  }
  // Silent in wall time and in ticks. Lockstep (a lease): the world runs no further than kPlanLeaseTicks past what
  // the leader had heard, so a silent leader shows as half a lease of ticks, not kTakeOverTicks (never reached).
  const long silent_ticks = o_.lease_every > 0 ? o_.lease_every / 2 : kTakeOverTicks;
  const bool leader_silent =
      heard_stronger_ && now_ns - last_stronger_ > kTakeOverAfterNs &&
      (heard_tick_ - stronger_tick_ > silent_ticks || (not_ticking && now_ns - last_stronger_ > kTakeOverAtStartNs));
  // A silent leader is replaced only by a replica that has its plan: the object is where the replica's plan has it.
  const double replica_off =
      object_known_ && heard_tick_ >= 0 ? (plan_.sample(heard_tick_).pose.head<2>() - object_xy_).norm() : 0.0;
  // The world follows a leader this replica never heard (a takeover it missed, whose leader then died): its replica
  // is the plan of before, right only if the object rests where it has it (the dead leader's plan ran its task to
  // the end meanwhile). A soak-small hour saw such a standby take over with the object still 5 mm from its rest
  // pose: the references jumped 5 mm.
  const bool unheard = world_rank_.strength != 0 && world_rank_.outranks(followed_);
  const bool at_rest_there = !object_known_ || (heard_tick_ - still_since_ >= kStillTicks && replica_off < kAloneMatch);
  const bool replica_ok =
      failed_ || (replica_off < kReplicaMatch && moves_as_replica && !behind && (!unheard || at_rest_there));
  if (!active_ && flowing && leader_silent && !replica_ok) {
    if (stale_since_ < 0) {
      stale_since_ = now_ns;
      stale_world_ = {world_rank_, world_version_};
      char line[300];
      if (unheard && !behind) {
        std::snprintf(line, sizeof line, "the leader is silent, and the world follows a plan of epoch %llu (strength %d) "
                      "that this replica never heard; the object is %.1f mm from where the replica has it%s: not taking "
                      "over", static_cast<unsigned long long>(world_rank_.epoch), world_rank_.strength, replica_off * 1e3,
                      heard_tick_ - still_since_ >= kStillTicks ? "" : " and moving");
      } else if (behind) {
        std::snprintf(line, sizeof line, "the leader is silent, but the world follows plan version %llu of epoch %llu "
                      "(strength %d) and this replica has version %llu of epoch %llu (it missed the leader's newest "
                      "plan): not taking over", static_cast<unsigned long long>(world_version_),
                      static_cast<unsigned long long>(world_rank_.epoch), world_rank_.strength,
                      static_cast<unsigned long long>(plan_.version()), static_cast<unsigned long long>(followed_.epoch));
      } else if (replica_off < kReplicaMatch && !moves_as_replica && !speed_off) {
        std::snprintf(line, sizeof line, "the leader is silent, but the object's speed is not known yet at tick %ld (no "
                      "report 10-200 ticks back): not taking over until the next reports", heard_tick_);
      } else if (replica_off < kReplicaMatch && !moves_as_replica) {
        std::snprintf(line, sizeof line, "the leader is silent, but the object moves %.0f mm/s off this replica's plan "
                      "at tick %ld (it missed the leader's newest plan): not taking over", *speed_off * 1e3, heard_tick_);
      } else {
        // Both versions: a replica ahead of the world (the world never got the leader's newest version, soak finding
        // 58) reads differently from one behind it.
        std::snprintf(line, sizeof line, "the leader is silent, but this replica (version %llu) is %.1f mm off the object "
                      "at tick %ld, where the world follows version %llu: not taking over",
                      static_cast<unsigned long long>(plan_.version()), replica_off * 1e3, heard_tick_,
                      static_cast<unsigned long long>(world_version_));
      }
      log(line);
    } else if (now_ns - stale_since_ > kTakeOverAloneNs && !alone_refused_ && !deaf_) {
      give_up(stale_world_, "the world's plan changed while this replica heard nothing",
              "no leader and no replica that has the module's plan: the module has lost its plan");
    }
  } else if (!leader_silent || replica_ok) {
    stale_since_ = -1;
  }
  const bool quiet = heard_stronger_ ? (leader_silent && replica_ok) : (now_ns - t_start_ > kTakeOverAloneNs && alone_ok);
  if (!active_ && flowing && quiet) {
    active_ = true;
    rank_.epoch = max_epoch_ + 1;
    max_epoch_ = rank_.epoch;
    // A replica of a plan the world follows under a rank it never heard (accepted above only with the object at rest
    // where the replica has it), or of a failed module: its plan continues the world's, so it must not count as older
    // (plan::PlanFollower refuses an older takeover).
    if (unheard || failed_) plan_.raise_version(world_version_);
    confirmed_ = world_rank_.strength == 0;
    unconfirmed_since_ = -1;
    refused_said_ = false;
    stale_taker_tick_ = -1;
    plan_sent_version_ = ~0ULL;  // publish the plan now, under the new epoch
    latest_plan_.reset();
    char line[256];
    std::snprintf(line, sizeof line, "taking over in epoch %llu (%s) with plan version %llu: task %llu %s, %llu done",
                  static_cast<unsigned long long>(rank_.epoch),
                  heard_stronger_ ? ("no plan from the leader for " +
                                     std::to_string(std::llround(static_cast<double>(now_ns - last_stronger_) * 1e-6)) + " ms")
                                        .c_str()
                                  : "never heard a leader",
                  static_cast<unsigned long long>(plan_.version()), static_cast<unsigned long long>(plan_.task_id()),
                  plan_.running() ? "running" : "not running", static_cast<unsigned long long>(plan_.done()));
    log(line);
    out_detail_ = "leading in epoch " + std::to_string(rank_.epoch);
    reported_ = TaskStateCode::Idle;
    publish_state(true, now_ns);
  } else if (active_ && step_down) {
    // A higher rank leads: a standby that took over in a later epoch while this one was stalled, or a
    // stronger one of the same epoch. It decides from now on; this one follows its plan.
    active_ = false;
    suspect_from_ = -1;
    log("stepping down: a higher-ranked supervisor leads" +
        (latest_plan_ ? " (" + latest_plan_->supervisor_id + ", epoch " + std::to_string(latest_plan_->epoch) + ")"
                      : std::string()));
    if (latest_plan_ && !adopt(*latest_plan_, true)) {
      leaving_ = true;
      return;
    }
    replica_ = latest_plan_.has_value();
    out_detail_ = replica_ ? kReplicaDetail : kColdDetail;
  }
  if (heard_tick_ < 0 || suspect_from_ >= 0) return;
  if (active_ && !confirmed_) {
    // A new leader plans nothing until the world follows its plan: the world refuses a takeover older than the
    // plan it holds (the leader this one took over from was alive, stalled, and had moved on), and a plan made on
    // top of a refused one would then be a newer version of a stale plan.
    const bool refused = rank_.outranks(world_rank_) && world_version_ > plan_.version();
    if (refused && !refused_said_) {
      refused_said_ = true;
      log("the world refuses this takeover (" + world_plan_text() + ", newer than this replica's version " +
          std::to_string(plan_.version()) + "); planning nothing until its leader retakes");
    }
    if (unconfirmed_since_ < 0) unconfirmed_since_ = heard_tick_;
    if (heard_tick_ - unconfirmed_since_ > kOutrankedTicks && !alone_refused_ && !deaf_) {
      // Refused (a leader made a newer plan than this replica: the module has a plan, this one lacks it) or never
      // followed (the world does not hear this one's writer): not a lost plan, so not a module restart. The process
      // exits 6 and comes back as a standby with a fresh participant; a live leader goes on, or another standby with
      // the newer plan takes over (and if none has it, that one finds the plan lost).
      deaf_ = true;
      log(std::string(refused ? "no leader retook after the world refused this takeover"
                              : "the world has not followed this takeover") +
          " within " + std::to_string(kOutrankedTicks) + " ticks (" + world_plan_text() + "); leaving the lead");
    }
    if (!o_.continuous && heard_tick_ + 1 >= m_.steps) world_done_ = true;
    publish_state(false, now_ns);
    return;
  }
  if (!active_) {
    // A replica: it follows the leader's plan (on_plan) and plans nothing itself, so its plan never drifts from
    // the leader's. Assignments wait for a takeover (the leader may die before it starts one).
    if (!o_.continuous && heard_tick_ + 1 >= m_.steps) world_done_ = true;
    return;
  }
  // Pause while an arm is braked, the world holds for load, or a pause is asked for.
  const long next = heard_tick_ + kLeadTicks;
  if ((braked_[0] || braked_[1]) && braked_since_ != rebased_for_ && plan_.target_rate() == 0.0 &&
      plan_.paused_at(heard_tick_)) {
    // An arm braked with the path paused: the brakes may have stopped the object off the path. Rebase the path
    // to where the object is, so that the robots resume from it (not from a jump). On every brake.
    rebased_for_ = braked_since_;
    const double back = plan_.rebase_to(heard_tick_ + kLeadTicks, object_xy_, 3.0, kRebaseMin);
    if (back > 0.0) log("path rebased " + std::to_string(std::lround(back * 1e3)) + " ms back, to where the braked object stands");
  }
  if (braked_[0] || braked_[1] || hold_) {
    // Stop the path: overload, an arm driven to rest by the world, or braked. Never faster than the friction
    // bound allows (the world's drive and the other robot follow this same plan).
    const long from = heard_tick_ + kHoldLeadTicks;
    if (plan_.target_rate() != 0.0) plan_.set_rate(from, 0.0, stop_ramp(from));  // (once per stop: stop_ramp tries it)
  } else if (released_at_ >= 0 && heard_tick_ - released_at_ < kReleaseSettleTicks) {
    // Just released: the new controller settles on the still reference first.
  } else {
    plan_.set_rate(next, pause_requested_ ? 0.0 : 1.0, kPauseRamp);
  }
  // Where a task's path starts: lockstep, kLeadTicks after the newest tick heard (the world waits for the lease);
  // real time, kTaskLeadTicks after where the world is now, as far as the wall clock tells.
  const long task_start =
      o_.lease_every > 0
          ? next
          : heard_tick_ + std::max(0L, static_cast<long>(static_cast<double>(now_ns - last_report_) * 1e-9 / m_.period)) +
                kTaskLeadTicks;
  for (const Assignment& a : assignments_) {
    if (!o_.continuous || a.id <= plan_.task_id() || plan_.running() || draining_ || failed_) continue;
    plan_.assign(a.id, a.waypoints, task_start);
    out_detail_ = "task " + a.name;
    publish_state(true, now_ns);
  }
  assignments_.clear();
  if (o_.continuous && !failed_ && plan_.finish_if_done(heard_tick_)) publish_state(true, now_ns);
  publish_state(false, now_ns);
  if (!o_.continuous && heard_tick_ + 1 >= m_.steps) world_done_ = true;
  if (active_ && reported_ == TaskStateCode::Left) {
    log("drained; the module leaves");
    leaving_ = true;
  }
}

bool SupervisorCore::note_stale_taker(const plan::PlanData& p) {
  if (stale_taker_tick_ >= 0 && !p.rank().outranks(stale_taker_)) return false;  // already noted
  stale_taker_ = p.rank();
  stale_taker_version_ = p.version;
  stale_taker_tick_ = std::max(heard_tick_, 0L);
  return true;
}

std::optional<double> SupervisorCore::replica_speed_off() const {
  if (trail_n_ < 2 || !object_known_) return std::nullopt;
  const std::pair<long, model::Vec2>& now = trail_[(trail_next_ + kTrail - 1) % kTrail];
  const std::pair<long, model::Vec2>* from = nullptr;
  for (size_t i = 1; i < trail_n_; ++i) {
    const std::pair<long, model::Vec2>& e = trail_[(trail_next_ + kTrail - 1 - i) % kTrail];
    const long back = now.first - e.first;
    if (back < 10 || back > 200) continue;
    if (from == nullptr || std::abs(back - kSpeedWindowTicks) < std::abs(now.first - from->first - kSpeedWindowTicks)) from = &e;
  }
  if (from == nullptr) return std::nullopt;
  const double dt = static_cast<double>(now.first - from->first) * m_.period;
  const model::Vec2 object_v = (now.second - from->second) / dt;
  const model::Vec2 plan_v = plan_.sample((now.first + from->first) / 2).vel.head<2>();
  return (object_v - plan_v).norm();
}

bool SupervisorCore::behind_world() const {
  if (world_rank_.strength == 0) return false;  // the world follows no plan yet (or an older world: not on the wire)
  return world_rank_.epoch == followed_.epoch && world_rank_.strength == followed_.strength &&
         world_version_ > plan_.version();
}

bool SupervisorCore::world_moved_on(const WorldPlan& since) const {
  if (world_rank_.strength == 0) return false;
  return world_rank_.epoch != since.rank.epoch || world_rank_.strength != since.rank.strength ||
         world_version_ != since.version;
}

void SupervisorCore::give_up(const WorldPlan& since, const std::string& changed, const std::string& lost) {
  if (world_moved_on(since)) {
    // The world's plan changed while this one heard nothing: its leader lives, this supervisor is deaf to it.
    deaf_ = true;
    log(changed + " (" + world_plan_text() + "): a leader lives that this supervisor cannot hear; not taking over");
  } else {
    alone_refused_ = true;
    log(lost);
  }
}

std::string SupervisorCore::world_plan_text() const {
  return "the world follows plan version " + std::to_string(world_version_) + " of epoch " +
         std::to_string(world_rank_.epoch) + ", strength " + std::to_string(world_rank_.strength);
}

double SupervisorCore::stop_ramp(long from) const {
  const model::PoseSample p = plan_.sample(from);
  // Speed of the faster stick tip: the centre's speed plus the rotation's share at the stick's length.
  const double stick = std::max(m_.geometry.stick_length[0], m_.geometry.stick_length[1]);
  const double v = p.vel.head<2>().norm() + stick * std::abs(p.vel(2));
  const model::ObjectParams& o = m_.plant.object;
  const double a_max = model::stop_deceleration_bound(m_.reference_force, m_.safe_grasp_force, o.mass, o.mu_s, m_.plant.g0);
  if (!(a_max > 0.0)) return 1.0;
  // From a steady rate the ramp's peak deceleration is 1.5 v / T. A stop that cuts into a resume starts at the
  // rate's slope (model::TimeScale), so the rate goes on rising for a while and then falls faster: the stop is
  // tried on a copy of the plan and lengthened until the stick tips' acceleration over it stays within the
  // margin (or, at most, 8 x; the path's own acceleration at full rate is far below it for the tasks used).
  double T = std::max(kHoldRamp, 1.5 * v / (kStopMargin * a_max));
  for (int i = 0; i < 8; ++i) {
    plan::ModulePlan trial = plan_;
    trial.set_rate(from, 0.0, T);
    double peak = 0.0;
    // (The stop begins at `from` or at a retarget already scheduled after it, at most kLeadTicks later.)
    const long end = from + static_cast<long>(std::ceil(T / m_.period)) + kLeadTicks + 1;
    for (long k = from; k <= end; ++k) {
      const model::PoseSample s = trial.sample(k);
      peak = std::max(peak, s.acc.head<2>().norm() + stick * std::abs(s.acc(2)));
    }
    if (peak <= kStopMargin * a_max) break;
    T *= 1.25;
  }
  return T;
}

std::optional<plan::PlanData> SupervisorCore::take_plan() {
  std::optional<plan::PlanData> p;
  p.swap(out_plan_);
  return p;
}

std::optional<StateOut> SupervisorCore::take_state() {
  std::optional<StateOut> s;
  s.swap(out_state_);
  return s;
}

std::optional<std::string> SupervisorCore::take_detail() {
  std::optional<std::string> d;
  d.swap(out_detail_);
  return d;
}

}  // namespace tandem::supervisor
