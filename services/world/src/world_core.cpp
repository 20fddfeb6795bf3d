#include "tandem/world/world_core.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>

#include "tandem/model/grasp.hpp"

namespace tandem::world {

namespace {
std::string ms_text(double ms) {
  char b[32];
  std::snprintf(b, sizeof b, "%.0f ms", ms);
  return b;
}
}  // namespace

WorldCore::WorldCore(const sim::ModuleSetup& m, const WorldOptions& o)
    : m_(m), o_(o), plant_(m.plant), follower_(m, o.continuous),
      // An arm whose controller has gone quiet for this long is braked (real time: time without a command
      // while the world ticks on; lockstep: time the tick waited). Longer than a standby's failover (10 ticks,
      // or 20 ms of waiting in lockstep), so a failover never brakes.
      brake_after_s_(o.realtime ? 0.1 : 1.0),
      backoff_s_(o.overload.backoff_s) {
  plant_.reset(m.initial);
  for (int j = 0; j < 2; ++j) tau_[static_cast<size_t>(j)] = model::JointVec::Zero(plant_.arm(j).dof());
  if (o.realtime) {
    // As a real arm at power-on: the brakes hold it until its controller answers a tick in time (a first
    // command that comes late would otherwise leave the arm on zero torque, and drop the object).
    for (int j = 0; j < 2; ++j) {
      link_[static_cast<size_t>(j)].braked = true;
      link_[static_cast<size_t>(j)].start_brake = true;
      plant_.set_brake(j, true);
    }
  }
  const model::ObjectParams& obj = m.plant.object;
  // A grasp with no margin (h_ref <= h_sg: the scenario's own checks refuse it) still gets a damped drive.
  const double a_stop = model::stop_deceleration_bound(m.reference_force, m.safe_grasp_force, obj.mass, obj.mu_s, m.plant.g0);
  drive_acc_max_ = kDriveFeedbackShare * (a_stop > 0.0 ? a_stop : 1.0);
  o_.overload.window = std::clamp(o_.overload.window, 1, 256);
  o_.overload.probe_every = std::max(o_.overload.probe_every, 1);
  jitter_ = static_cast<double>(std::hash<std::string>{}(o.arm_ids[0]) % 1000) / 1000.0;
}

std::string WorldCore::robot_name(int j, int32_t strength) const {
  const std::string& arm = o_.arm_ids[static_cast<size_t>(j)];
  return strength == plan::kPrimaryStrength ? arm : arm + "@" + std::to_string(strength);
}

WorldCore::Owner WorldCore::owner(int j) const {
  const ArmLink& L = link_[static_cast<size_t>(j)];
  Owner o;
  if (L.braked) {
    o.state = load_paused_ ? Owner::State::BrakedLoad : Owner::State::Braked;
  } else if (L.stopping) {
    o.state = Owner::State::Stopping;
  } else {
    o.state = Owner::State::Served;
    o.robot = L.owner;
    o.strength = L.strength;
    o.handover_ticks = L.handover_ticks;
  }
  return o;
}

const std::string& WorldCore::arm_name(int j) const { return o_.arm_names[static_cast<size_t>(j)]; }

std::string WorldCore::serving_text() const {
  std::string out;
  for (int j = 0; j < 2; ++j) {
    const Owner o = owner(j);
    out += (j ? "," : "") + arm_name(j) + "=" +
           (o.state == Owner::State::BrakedLoad ? "braked(load)"
            : o.state == Owner::State::Braked   ? "braked"
            : o.state == Owner::State::Stopping ? "stopping"
                                                : o.robot);
  }
  return out;
}

void WorldCore::mark_late(ArmLink& L, long tick) {
  // Overload is commands that come, but late: a robot that sends nothing is silence, which the 100 ms
  // no-live-controller brake handles (and a late command for an arm is only counted once per tick).
  const long w = o_.overload.window;
  if (!o_.realtime || tick < 0 || tick > k_ || k_ - tick >= w || L.braked) return;
  bool& slot = L.late_ring[static_cast<size_t>(tick % w)];
  if (slot) return;
  slot = true;
  ++L.late_count;
  ++L.late_run;
}

void WorldCore::set_brake(int j, bool on, const std::string& why) {
  ArmLink& L = link_[static_cast<size_t>(j)];
  if (L.braked == on && !L.start_brake) return;
  auto any = [&] {
    return (link_[0].braked && !link_[0].start_brake) || (link_[1].braked && !link_[1].start_brake);
  };
  const bool was = any();
  L.braked = on;
  L.start_brake = false;
  plant_.set_brake(j, on);
  const bool now = any();
  if (now && !was && !load_pending_) braked_since_ = k_;
  if (!now && was) {
    braked_since_ = -1;
    released_at_ = k_;
  }
  report_now_ = true;
  serving_changed_ = true;
  log(o_.arm_ids[static_cast<size_t>(j)] + (on ? " braked at tick " : " released at tick ") + std::to_string(k_) + " (" +
      why + ")");
}

model::Vec3 WorldCore::drive_acceleration(int j, const model::ArmReference& ref, const model::Vec3& x,
                                          const model::Vec3& xd) {
  const size_t a = static_cast<size_t>(j);
  if (drive_tick_[a] != k_ && drive_tick_[a] != k_ - 1) {
    // A new run: bumpless. The offset along the approach axis is left out: it is squeeze the grasp lost (the
    // reference carries the preload), and the drive brings it back, within the bound below.
    drive_offset_[a] = x - ref.x;
    const model::Vec2 n = model::approach_axis(ref.x(2));
    drive_offset_[a].head<2>() -= n * n.dot(drive_offset_[a].head<2>());
  }
  drive_tick_[a] = k_;
  model::Vec3 fb = kDriveKd * (ref.xd - xd) + kDriveKp * (ref.x + drive_offset_[a] - x);
  // Bounded: at most drive_acc_max_ along the faces' plane, and a rotation that moves a stick tip no faster.
  const double lin = fb.head<2>().norm();
  if (lin > drive_acc_max_) fb.head<2>() *= drive_acc_max_ / lin;
  const double stick = std::max({m_.geometry.stick_length[0], m_.geometry.stick_length[1], 1e-3});
  fb(2) = std::clamp(fb(2), -drive_acc_max_ / stick, drive_acc_max_ / stick);
  return ref.xdd + fb;
}

model::JointVec WorldCore::drive_torque(int j) {
  const size_t a = static_cast<size_t>(j);
  const model::ArmReference ref = follower_.reference(j, k_);
  const model::Vec3 h(contact_.h[a](0), contact_.h[a](1), 0.0);
  const model::JointVec& qv = plant_.state().q[a];
  const model::JointVec& qdv = plant_.state().qd[a];
  const model::Manipulator& arm = plant_.arm(j);
  if (const model::ArmParams* p3 = plant_.planar3r(j)) {  // the identified 3R: fixed-size Eigen
    const model::ArmParams& ap = *p3;
    const model::Vec3 q = qv, qd = qdv;
    const model::Mat3 J = model::jacobian(ap, q);
    const model::Vec3 x = model::forward_kinematics(ap, q);
    // Task-space computed torque: q'' = J^-1 (x'' - J' q'), x'' from drive_acceleration.
    const model::Vec3 acc = drive_acceleration(j, ref, x, J * qd) - model::jacobian_dot(ap, q, qd) * qd;
    const model::Vec3 qdd = J.partialPivLu().solve(acc);
    const model::Vec3 tau = model::inertia(ap, q) * qdd + model::nonlinear_terms(ap, q, qd) + J.transpose() * h;
    return model::JointVec(tau.cwiseMax(-ap.tau_max).cwiseMin(ap.tau_max));
  }
  // Any type: the same law; a redundant arm takes the minimum-norm joint acceleration plus a damping of its
  // self-motion (the null space of J), so that the stop does not let the free joint drift.
  const model::TaskJacobian J = arm.jacobian(qv);
  const model::Vec3 x = arm.forward_kinematics(qv);
  const model::Vec3 acc = drive_acceleration(j, ref, x, J * qdv) - arm.jacobian_dot(qv, qdv) * qdv;
  const model::Mat3 JJt = J * J.transpose();
  const model::TaskJacobian W = JJt.partialPivLu().solve(J);  // (J J^T)^-1 J: its transpose is J^+
  model::JointVec qdd = W.transpose() * acc;
  if (arm.dof() > 3) {
    const model::JointMat P = model::JointMat::Identity(arm.dof(), arm.dof()) - W.transpose() * J;
    qdd += P * (-kDriveKd * qdv);
  }
  model::JointVec tau = arm.inertia(qv) * qdd + arm.nonlinear_terms(qv, qdv) + J.transpose() * h;
  for (int i = 0; i < arm.dof(); ++i) {
    const double lim = arm.joints().effort_max[static_cast<size_t>(i)];
    tau(i) = std::clamp(tau(i), -lim, lim);
  }
  return tau;
}

model::JointVec WorldCore::holding_torque(int j) const {
  const size_t a = static_cast<size_t>(j);
  const model::Vec3 h(contact_.h[a](0), contact_.h[a](1), 0.0);
  const model::JointVec& q = plant_.state().q[a];
  const model::Manipulator& arm = plant_.arm(j);
  if (const model::ArmParams* p3 = plant_.planar3r(j)) {
    const model::Vec3 q3 = q;
    return model::JointVec(model::gravity(*p3, q3) + model::jacobian(*p3, q3).transpose() * h);
  }
  return arm.gravity(q) + arm.jacobian(q).transpose() * h;
}

void WorldCore::begin_stop(int j, const std::string& why, int64_t /*now_ns*/) {
  ArmLink& L = link_[static_cast<size_t>(j)];
  if (L.stopping || L.braked) return;
  L.stopping = true;
  L.stop_tick = k_;
  L.release_run = 0;
  if (braked_since_ < 0) braked_since_ = k_;
  report_now_ = true;
  serving_changed_ = true;
  log(o_.arm_ids[static_cast<size_t>(j)] + " has no live controller (" + why + ") at tick " + std::to_string(k_) +
      ": the world drives it to rest along the plan, then brakes it");
}

void WorldCore::begin_tick(long k, int64_t /*now_ns*/, std::array<SampleOut, 2>& out) {
  k_ = k;
  t_ = static_cast<double>(k) * m_.period;
  contact_ = plant_.contacts();
  const model::ContactReading& contact = contact_;
  const double hn = std::min(contact.normal[0], contact.normal[1]);
  status_normal_min_ = std::min(status_normal_min_, hn);
  report_normal_min_ = std::min(report_normal_min_, hn);
  // Tracking error as the world sees it (from the plan the robots follow), and the windows after switches.
  TickRecord& rec = history_[static_cast<size_t>(k) % kHistory];
  for (int j = 0; j < 2; ++j) {
    if (follower_.has_plan()) {
      const model::Vec3 ref = follower_.reference(j, k).x, x = plant_.end_effector(j);
      ep_[static_cast<size_t>(j)] = (ref.head<2>() - x.head<2>()).norm();
      ephi_[static_cast<size_t>(j)] = ref(2) - x(2);
    }
    rec.ep[static_cast<size_t>(j)] = ep_[static_cast<size_t>(j)];
    rec.ephi[static_cast<size_t>(j)] = ephi_[static_cast<size_t>(j)];
  }
  rec.hn_min = hn;
  for (auto it = windows_.begin(); it != windows_.end();) {
    Switch& s = switches[it->index];
    s.ep_max = std::max(s.ep_max, ep_[static_cast<size_t>(it->arm)]);
    s.hn_min = std::min(s.hn_min, hn);
    it = k >= it->end ? windows_.erase(it) : it + 1;
  }
  have_ = {false, false};
  fallback_ = {};
  // The overload window: tick k's slot starts unmarked (dropping tick k - window's mark); a command for it
  // that comes late marks it (mark_late).
  for (ArmLink& L : link_) {
    bool& slot = L.late_ring[static_cast<size_t>(k % o_.overload.window)];
    if (slot) --L.late_count;
    slot = false;
  }
  // Paused for load: a probe sample every probe_every ticks only (during the trial before a release: all).
  const bool probe = !load_paused_ || trial_ticks_ >= 0 || k % o_.overload.probe_every == 0;
  for (size_t j = 0; j < 2; ++j) {
    SampleOut& s = out[j];
    s.publish = probe;
    s.t = t_;
    s.q = plant_.state().q[j];
    s.qd = plant_.state().qd[j];
    s.h = contact.h[j];
    s.braked = link_[j].braked;
    s.tau_applied = link_[j].braked ? holding_torque(static_cast<int>(j)) : tau_[j];
    s.applied_from = link_[j].braked ? 0 : applied_from_[j];
    expect_[j] = probe;
  }
}

bool WorldCore::plan_at_rest(long k, double still_speed) const {
  if (!follower_.has_plan()) return true;
  if (follower_.blending(k)) return false;  // a late version's blend still moves the reference
  const plan::ModulePlan& p = follower_.plan();
  if (p.paused_at(k)) return true;
  const model::PoseSample now = p.sample(k);
  if (now.vel.head<2>().norm() >= still_speed) return false;
  // Slow now, and still so kPlanRestLookTicks on (not a segment boundary, nor a task about to start).
  return (p.sample(k + kPlanRestLookTicks).pose - now.pose).head<2>().norm() < kPlanRestM;
}

ReportOut WorldCore::take_report() {
  ReportOut r;
  r.tick = k_;
  r.braked = {link_[0].braked && !link_[0].start_brake, link_[1].braked && !link_[1].start_brake};
  r.hold = load_pending_ || load_paused_ || link_[0].stopping || link_[1].stopping;
  r.braked_since = braked_since_;
  r.released_at = released_at_;
  r.normal_min = report_normal_min_;
  r.object = model::Vec3(plant_.state().c(0), plant_.state().c(1), plant_.state().psi);
  r.failed = failed_;
  r.failure = failure_;
  r.plan_rank = plan_rank();
  r.plan_version = follower_.has_plan() ? follower_.version() : 0;
  report_normal_min_ = 1e300;
  report_now_ = false;
  return r;
}

double WorldCore::normal_min_since_status() {
  const double v = status_normal_min_;
  status_normal_min_ = 1e300;
  return v;
}

WorldCore::Verdict WorldCore::on_command(int j, long tick, const model::JointVec& tau, int32_t strength, int64_t at_ns,
                                         bool late_arrival, bool leaving) {
  ArmLink& L = link_[static_cast<size_t>(j)];
  if (strength < 1 || strength > plan::kPrimaryStrength) {  // robots are 1 (weakest standby) .. 100 (primary)
    ++rejected;
    return Verdict::Rejected;
  }
  if (leaving) {
    // A robot's last word (unplugged or stopped): if it served the arm, follow the next one at once.
    if (!L.owner.empty() && strength == L.strength) {
      L.owner_gone = true;
      Fallback& f = fallback_[static_cast<size_t>(j)];
      if (f.has && !have_[static_cast<size_t>(j)]) apply(j, f.tau, f.strength, f.at_ns, at_ns);
    }
    ++stale;
    return Verdict::Stale;
  }
  if (o_.realtime && late_arrival) {  // after the deadline: too late for this tick, but its controller lives
    ++stale;
    L.heard = at_ns;
    mark_late(L, tick);
    return Verdict::Stale;
  }
  // A future tick is invalid, and so is a command of another joint count than the arm's.
  if (!plan::all_finite(tau) || tau.size() != plant_.arm(j).dof() || tick > k_) {
    ++rejected;
    return Verdict::Rejected;
  }
  if (L.braked || L.stopping) {
    // Which robots compute the ticks of the release trial: a robot's answer comes from a law warm with the brake's
    // holding torque only when it computed the tick before too (RobotCore::on_sample), whether or not that answer
    // was the one taken.
    auto& seen = L.trial_answers;
    auto it = std::find_if(seen.begin(), seen.end(), [strength](const TrialAnswer& a) { return a.strength == strength; });
    if (it == seen.end()) {
      it = std::min_element(seen.begin(), seen.end(), [](const TrialAnswer& a, const TrialAnswer& b) { return a.last < b.last; });
      *it = TrialAnswer{strength, -2, 0};
    }
    if (tick > it->last) {  // (an older answer, a repeat or one overtaken, changes nothing)
      it->run = tick == it->last + 1 ? it->run + 1 : 1;
      it->last = tick;
    }
  }
  if (have_[static_cast<size_t>(j)] && tick == k_ && !(strength > L.strength && !L.braked)) {
    // A second command for an arm that has this tick's already (a repeat, or a standby's answer after the
    // owner's). The first one stands, unless a stronger robot's comes: it takes the arm over at once.
    ++stale;
    return Verdict::Stale;
  }
  for (int i = 0; i < tau.size(); ++i) {  // beyond the drive's limit: not a command this arm can have been sent
    if (std::abs(tau(i)) > plant_.arm(j).joints().effort_max[static_cast<size_t>(i)]) {
      ++rejected;
      return Verdict::Rejected;
    }
  }
  L.heard = at_ns;
  if (tick != k_) {
    // An older tick is a late answer or a repeat: dropped. From a braked arm's robot it means a
    // controller is back: lockstep waits for its answers from the next tick on, the arm braked until they came
    // kLockstepReleaseTicks in a row (the release trial, in apply).
    ++stale;
    if ((L.braked || L.stopping) && !o_.realtime && !failed_ && tick + 64 > k_) L.trial = true;
    mark_late(L, tick);
    return Verdict::Stale;
  }
  const bool orphan = (L.braked && !load_paused_) || L.stopping;  // no live controller: any robot may take it
  if (!L.owner.empty() && !orphan && !L.owner_gone && strength < L.strength) {
    // A weaker robot (a standby in shadow): kept for this tick, in case the owner falls silent.
    Fallback& f = fallback_[static_cast<size_t>(j)];
    if (!f.has || strength > f.strength) f = {true, tau, strength, at_ns};
    return Verdict::Shadow;
  }
  if (!L.owner.empty() && !orphan && !L.braked && !L.owner_gone && strength > L.strength && k_ >= 50) {
    // A stronger robot: it warms up in shadow for kTakeoverTicks ticks in a row before it takes over.
    if (strength != L.challenger || tick != L.challenger_tick + 1) {
      L.challenger = strength;
      L.challenger_run = 0;
    }
    L.challenger_tick = tick;
    if (++L.challenger_run < kTakeoverTicks) {
      Fallback& f = fallback_[static_cast<size_t>(j)];
      if (!f.has || strength > f.strength) f = {true, tau, strength, at_ns};
      return Verdict::Shadow;
    }
    L.challenger = 0;
    L.challenger_run = 0;
  }
  apply(j, tau, strength, at_ns, at_ns);
  return Verdict::Applied;
}

void WorldCore::apply(int j, const model::JointVec& tau, int32_t strength, int64_t at_ns, int64_t decided_ns) {
  ArmLink& L = link_[static_cast<size_t>(j)];
  tau_[static_cast<size_t>(j)] = tau;
  have_[static_cast<size_t>(j)] = true;
  applied_from_[static_cast<size_t>(j)] = strength;
  const std::string name = robot_name(j, strength);
  if (L.start_brake) {
    L.start_brake = false;
    L.braked = false;
    plant_.set_brake(j, false);
    L.owner = name;
    L.strength = strength;
    serving_changed_ = true;
    if (k_ > 10) {  // a normal start answers the first ticks: said only when it took a while
      log(o_.arm_ids[static_cast<size_t>(j)] + " brakes off at tick " + std::to_string(k_) + ": " + name +
          " answered in time");
    }
  } else if (failed_) {
    // Dropped: the arms stay braked whatever the robots send, until the module is cleared (a new world).
    L.release_run = 0;
    L.owner = name;
    L.strength = strength;
  } else if ((L.braked && !load_paused_) || L.stopping) {
    // The trial: still braked (or still driven by the world; end_tick puts the drive's torque back).
    // Released by an answer of a robot that computed the tick before as well: a robot's first answer comes from a
    // law just reset (lockstep soak run 38: a release 10 answers into the trial, the last of them, perhaps, a
    // rejoined robot's first; the object slipped 6 ticks later).
    const bool warm = std::any_of(L.trial_answers.begin(), L.trial_answers.end(), [this, strength](const TrialAnswer& a) {
      return a.strength == strength && a.last == k_ && a.run >= 2;
    });
    if (++L.release_run < (o_.realtime ? kReleaseTrialTicks : kLockstepReleaseTicks) || !warm) {
      if (!o_.realtime) L.trial = true;  // answered in step: lockstep waits for the next one too
      return;
    }
    L.release_run = 0;
    L.trial = false;
    log(o_.arm_ids[static_cast<size_t>(j)] + " follows " + name +
        (L.last_at > 0 ? " after " + ms_text(static_cast<double>(at_ns - L.last_at) * 1e-6) +
                             (L.stopping ? " driven by the world" : " braked")
                       : ""));
    L.owner = name;
    L.strength = strength;
    L.handover_ticks = L.last_tick >= 0 ? k_ - L.last_tick : -1;  // the whole stop or brake, not an older handover
    if (L.stopping) {
      L.stopping = false;
      report_now_ = true;
      serving_changed_ = true;
      if (!link_[0].braked && !link_[1].braked && !holding() && !load_paused_) {
        braked_since_ = -1;
        released_at_ = k_;
      }
    } else {
      set_brake(j, false, "a robot answers again");
    }
  } else if (!L.owner.empty() && name != L.owner && k_ >= 50) {
    // A change of owner: to a weaker robot it is a failover (the owner fell silent or left), to a stronger one
    // a takeover (a robot plugged or restarted as primary). In the first 50 ticks discovery order decides which
    // of a primary and its shadow is heard first: not a switch.
    // The gap: from the old owner's last command to the moment the arm follows the new one (a standby's answer
    // may have come earlier; in real time it served the ticks in between, see `covered`).
    const double gap_ms = static_cast<double>(std::max(at_ns, decided_ns) - L.last_at) * 1e-6;
    const bool failover = strength < L.strength;
    if (failover) {
      ++failovers;
      failover_last_ms = gap_ms;
      failover_max_ms = std::max(failover_max_ms, gap_ms);
    }
    char line[320];
    std::snprintf(line, sizeof line, "%s now follows %s (was %s): %s %.1f ms after the last command of the old one",
                  o_.arm_ids[static_cast<size_t>(j)].c_str(), name.c_str(), L.owner.c_str(),
                  failover ? "failover" : "takeover", gap_ms);
    log(line);
    if (switches.size() < kMaxSwitches) {
      // The window starts at the old owner's last command: the gap, held on its last torque, counts.
      Switch s;
      s.gap_ms = gap_ms;
      s.failover = failover;
      s.ep_max = 0.0;
      s.hn_min = 1e300;
      for (long kk = std::max({L.last_tick, k_ - static_cast<long>(kHistory) + 1, 0L}); kk <= k_; ++kk) {
        s.ep_max = std::max(s.ep_max, history_[static_cast<size_t>(kk) % kHistory].ep[static_cast<size_t>(j)]);
        s.hn_min = std::min(s.hn_min, history_[static_cast<size_t>(kk) % kHistory].hn_min);
      }
      switches.push_back(s);
      windows_.push_back({j, k_ + kWindowTicks, switches.size() - 1});
    }
    L.owner = name;
    L.strength = strength;
    L.handover_ticks = L.last_tick >= 0 ? k_ - L.last_tick : -1;
    serving_changed_ = true;
  } else if (L.owner != name || L.strength != strength) {
    L.owner = name;
    L.strength = strength;
    serving_changed_ = true;
  }
  L.last_tick = k_;
  L.last_at = at_ns;
  L.owner_gone = false;
}



bool WorldCore::lockstep_done() const {
  // A braked arm, or one the world drives, is not waited for, unless a robot is on its release trial.
  auto done = [this](size_t a) {
    const ArmLink& L = link_[a];
    return have_[a] || ((L.braked || L.stopping) && !L.trial);
  };
  return done(0) && done(1);
}

bool WorldCore::lockstep_waited(double waited_s, double timeout_s, int64_t now_ns) {
  bool give_up = false;
  for (int j = 0; j < 2; ++j) {
    ArmLink& L = link_[static_cast<size_t>(j)];
    if ((L.braked || L.stopping) && L.trial && !have_[static_cast<size_t>(j)] && waited_s > brake_after_s_) {
      // The robot on its release trial fell silent: the arm stays braked, and the trial starts over if it answers.
      L.trial = false;
      L.release_run = 0;
      continue;
    }
    if (have_[static_cast<size_t>(j)] || L.braked || L.stopping) continue;
    const Fallback& f = fallback_[static_cast<size_t>(j)];
    if (f.has && (L.owner_gone || waited_s > kFailoverLockstepS)) {
      apply(j, f.tau, f.strength, f.at_ns, now_ns);  // the owner fell silent: its standby's answer of this tick
      continue;
    }
    if (L.last_tick >= 0 && waited_s > brake_after_s_) {
      begin_stop(j, "no command for " + ms_text(waited_s * 1e3), now_ns);
      ++timeouts;
    } else if (L.last_tick < 0 && waited_s > timeout_s) {
      give_up = true;
    }
  }
  return !give_up;
}

bool WorldCore::end_tick(int64_t now_ns) {
  bool go_on = true;
  const OverloadRule& rule = o_.overload;
  if (k_ == kStartGraceTicks) {
    // A start brake still on: its robot has not answered in time yet. From now on it is a braking like any
    // other: reported, so that the supervisor holds the path (the other arm is controlled and the path would
    // run away from the braked one).
    for (size_t j = 0; j < 2; ++j) {
      if (!link_[j].start_brake) continue;
      link_[j].start_brake = false;
      if (braked_since_ < 0) braked_since_ = k_;
      report_now_ = true;
      serving_changed_ = true;
      log(o_.arm_ids[j] + " still braked at tick " + std::to_string(k_) + ": its robot has not answered in time yet");
    }
  }
  for (int j = 0; j < 2; ++j) {
    ArmLink& L = link_[static_cast<size_t>(j)];
    const Fallback& f = fallback_[static_cast<size_t>(j)];
    // (An arm braked for want of a controller is released by whichever robot answers, in on_command.)
    if (have_[static_cast<size_t>(j)] || !f.has || (L.braked && !load_paused_)) continue;
    // Paused for load the robots answer only every probe_every ticks: silence is counted in probes.
    const long silent_after = kFailoverTicks * (load_paused_ && trial_ticks_ < 0 ? rule.probe_every : 1);
    if (L.owner_gone || k_ - L.last_tick >= silent_after) {
      apply(j, f.tau, f.strength, f.at_ns, now_ns);  // the owner fell silent: follow its strongest standby
    } else {
      // The owner missed this tick: its standby's answer (the same law on the same samples) serves it.
      tau_[static_cast<size_t>(j)] = f.tau;
      have_[static_cast<size_t>(j)] = true;
      applied_from_[static_cast<size_t>(j)] = f.strength;
      ++covered;
    }
  }
  // The object's speed: a stop brakes only once it is still (braking a moving object makes it slip).
  const model::ModuleState& st = plant_.state();
  still_count_ = st.cd.norm() < rule.still_speed && std::abs(st.psid) < 10.0 * rule.still_speed ? still_count_ + 1 : 0;
  for (int j = 0; j < 2; ++j) {
    ArmLink& L = link_[static_cast<size_t>(j)];
    const size_t a = static_cast<size_t>(j);
    const bool had = have_[a];
    if (L.braked && !L.start_brake) ++braked_ticks;
    if ((L.braked || L.stopping) && !had) L.release_run = 0;  // the release trial wants answers in a row
    if (L.stopping) {
      // No live controller: the world's drive, along the plan, whatever a robot on trial sent.
      tau_[a] = drive_torque(j);
      applied_from_[a] = -1;
      ++driven;
      continue;
    }
    if (o_.realtime && expect_[a] && !L.braked && had) L.late_run = 0;
    if (had) L.miss_run = 0;
    if (!o_.brakes && o_.realtime && !had && !failed_ && L.last_tick >= 0 &&
        static_cast<double>(now_ns - L.heard) * 1e-9 > brake_after_s_) {
      // Test only (no brakes): an arm whose controller is gone goes limp, as its drives would with nobody to
      // command them: zero torque, and it falls with what it holds. Braked for load or not: an arm with no brakes
      // has nothing to hold it (the drop test killed a robot while its module was paused for load, and nothing fell).
      if (L.braked) set_brake(j, false, "test only: no brakes, and no command for " + ms_text(static_cast<double>(now_ns - L.heard) * 1e-6));
      tau_[a].setZero();
      continue;
    }
    if (had || L.braked) continue;
    if (o_.realtime) {
      // A late or missing command (counted). For a tick or two the arm keeps its previous torque; from the
      // kDriveAfterMisses-th missed tick in a row (at once while the world holds the path) the world's drive
      // serves it, never a stale torque on a moving object. An arm from which no command at all (late ones
      // included) came for brake_after_s has no live controller: the world drives it to rest, then brakes it.
      ++late;
      ++L.miss_run;
      const double quiet = static_cast<double>(now_ns - L.heard) * 1e-9;
      if (L.last_tick >= 0 && quiet > brake_after_s_ && o_.brakes) begin_stop(j, "no command for " + ms_text(quiet * 1e3), now_ns);
      if (o_.brakes && (L.stopping || load_pending_ || L.miss_run > kDriveAfterMisses)) {
        tau_[a] = drive_torque(j);
        applied_from_[a] = -1;
        ++driven;
      }
    } else if (L.last_tick < 0) {
      ++timeouts;
      go_on = false;
    }
  }
  for (int j = 0; j < 2; ++j) {
    ArmLink& L = link_[static_cast<size_t>(j)];
    if (!L.stopping) continue;
    const double stopped_s = static_cast<double>(k_ - L.stop_tick) * m_.period;
    // Braked once the object is still and the plan has stopped too: where the plan's speed passes zero (between a
    // task's segments) the object is still for a few ticks while the plan goes on, and a brake then leaves the
    // other arm to move the object against it (soak-small hour: dropped 148 ticks later).
    if ((still_count_ >= rule.still_ticks && plan_at_rest(k_, rule.still_speed)) || stopped_s > kStopMaxS) {
      L.stopping = false;
      ++stops;
      char why[160];
      std::snprintf(why, sizeof why, "no live controller; %s after %.0f ms driven along the plan",
                    still_count_ >= rule.still_ticks ? "object at rest" : "object still moving", stopped_s * 1e3);
      set_brake(j, true, why);
    }
  }
  if (!o_.realtime || !rule.enabled) return go_on;
  auto clear_rings = [&] {
    for (ArmLink& L : link_) {
      L.late_ring.fill(false);
      L.late_count = 0;
      L.late_run = 0;
    }
  };
  if (load_pending_) {
    // Holding: the supervisor stops the path while the drive serves every tick an arm misses; brake once the
    // object is still (braking a moving object makes it slip: the arms stop at once, the object does not),
    // or after hold_max_s at the latest.
    // In ticks, not wall time: a world starved for longer than hold_max_s (a hog on every core) wakes with its
    // object still moving, and braking it then makes it slip (CI soak, 2026-11-27: a 1.2 s two-core hog).
    const double held_s = static_cast<double>(k_ - load_pending_tick_) * m_.period;
    if (still_count_ >= rule.still_ticks || held_s > rule.hold_max_s) {
      load_pending_ = false;
      load_paused_ = true;
      good_probes_ = 0;
      trial_ticks_ = -1;
      load_until_ns_ = now_ns + static_cast<int64_t>(backoff_s_ * (1.0 + 0.5 * jitter_) * 1e9);
      char why[192];
      std::snprintf(why, sizeof why, "%s; paused for load, object %s after %.0f ms", load_why_.c_str(),
                    still_count_ >= rule.still_ticks ? "still" : "still moving", held_s * 1e3);
      for (int j = 0; j < 2; ++j) {
        link_[static_cast<size_t>(j)].stopping = false;
        set_brake(j, true, why);
      }
      serving_changed_ = true;
      clear_rings();
    }
    return go_on;
  }
  if (!load_paused_) {
    const int worst = std::max(link_[0].late_count, link_[1].late_count);
    const int run = std::max(link_[0].late_run, link_[1].late_run);
    if (worst > rule.max_late || run >= rule.max_consecutive) {
      // Overload: hold the object still, then brake both arms and shed the module's load.
      backoff_s_ = now_ns - load_released_ns_ < 10'000'000'000LL && load_pauses > 0
                       ? std::min(backoff_s_ * 2.0, rule.backoff_max_s)
                       : rule.backoff_s;
      load_pending_ = true;
      load_pending_tick_ = k_;
      still_count_ = 0;
      for (ArmLink& L : link_) L.late_run = 0;
      ++load_pauses;
      if (braked_since_ < 0) braked_since_ = k_;
      report_now_ = true;
      serving_changed_ = true;
      load_why_ = "overload: " + std::to_string(worst) + " late commands in the last " + std::to_string(rule.window) +
                  " ticks, " + std::to_string(run) + " in a row";
      log(load_why_ + " at tick " + std::to_string(k_) + "; stopping the path, the brakes follow once the object is still");
    }
    return go_on;
  }
  ++load_paused_ticks;
  if (trial_ticks_ >= 0) {
    // The trial: full-rate samples with the arms still braked. Released only if the robots kept up.
    for (size_t a = 0; a < 2; ++a) trial_late_[a] += have_[a] ? 0 : 1;
    if (++trial_ticks_ < rule.trial_ticks) return go_on;
    const int worst = std::max(trial_late_[0], trial_late_[1]);
    if (worst <= rule.trial_max_late) {
      load_paused_ = false;
      load_released_ns_ = now_ns;
      char why[160];
      std::snprintf(why, sizeof why, "back in time: %d and %d of %d full-rate ticks answered in time after %.1f s braked",
                    rule.trial_ticks - trial_late_[0], rule.trial_ticks - trial_late_[1], rule.trial_ticks, backoff_s_);
      for (int j = 0; j < 2; ++j) set_brake(j, false, why);
      serving_changed_ = true;
      clear_rings();
    } else {
      // Not yet: back to probes, and try again after a longer backoff.
      backoff_s_ = std::min(backoff_s_ * 2.0, rule.backoff_max_s);
      load_until_ns_ = now_ns + static_cast<int64_t>(backoff_s_ * (1.0 + 0.5 * jitter_) * 1e9);
      log("still overloaded: " + std::to_string(worst) + " late commands of one arm in a " + std::to_string(rule.trial_ticks) +
          "-tick trial (" + std::to_string(rule.trial_max_late) + " allowed) at tick " + std::to_string(k_) + "; next try in " +
          std::to_string(backoff_s_).substr(0, 4) + " s");
      good_probes_ = 0;
    }
    trial_ticks_ = -1;
    return go_on;
  }
  if (expect_[0] && expect_[1]) {  // a probe tick
    good_probes_ = have_[0] && have_[1] ? good_probes_ + 1 : 0;
  }
  if (good_probes_ >= rule.resume_probes && now_ns >= load_until_ns_) {
    trial_ticks_ = 0;  // from the next tick: the full-rate trial
    trial_late_ = {0, 0};
  }
  return go_on;
}

void WorldCore::fail(const std::string& why) {
  if (failed_) return;
  failed_ = true;
  failure_ = why + " at tick " + std::to_string(k_);
  load_pending_ = false;
  load_paused_ = false;
  trial_ticks_ = -1;
  for (int j = 0; j < 2; ++j) {
    link_[static_cast<size_t>(j)].stopping = false;
    set_brake(j, true, "object dropped: " + why);
  }
  report_now_ = true;
  serving_changed_ = true;
  log("module failed: " + failure_ + "; both arms braked, the module takes no task until it is cleared; its last " +
      std::to_string(kFlightTicks) + " ticks:\n" + flight_record(kFlightTicks));
}

std::string WorldCore::flight_record(long ticks) const {
  std::string out;
  const long first = std::max(0L, std::max(k_ - ticks + 1, k_ - static_cast<long>(kHistory) + 1));
  char line[320];
  const auto efforts = [](const model::JointVec& tau) {
    std::string t;
    char v[32];
    for (int i = 0; i < tau.size(); ++i) {
      std::snprintf(v, sizeof v, " %.2f", tau(i));
      t += v;
    }
    return t;
  };
  for (long k = first; k <= k_; ++k) {
    const TickRecord& r = history_[static_cast<size_t>(k) % kHistory];
    std::snprintf(line, sizeof line,
                  "  tick %ld: h_n %.2f %.2f N, h_t %.2f %.2f N, e_p %.2e %.2e m, e_phi %.1e %.1e rad; left %c from %d tau%s; "
                  "right %c from %d tau%s\n",
                  k, r.hn[0], r.hn[1], r.ht[0], r.ht[1], r.ep[0], r.ep[1], r.ephi[0], r.ephi[1], r.how[0], r.from[0],
                  efforts(r.tau[0]).c_str(),
                  r.how[1], r.from[1], efforts(r.tau[1]).c_str());
    out += line;
  }
  return out;
}

void WorldCore::step() {
  TickRecord& rec = history_[static_cast<size_t>(k_) % kHistory];  // this tick's inputs, for the flight record
  for (size_t j = 0; j < 2; ++j) {
    rec.hn[j] = contact_.normal[j];
    rec.ht[j] = contact_.tangential[j];
    rec.tau[j] = tau_[j];
    rec.from[j] = applied_from_[j];
    rec.how[j] = link_[j].stopping ? 's' : link_[j].braked ? 'b' : have_[j] ? 'c' : 'l';
  }
  plant_.step(tau_, t_, m_.period, m_.substeps);
  const model::PlantCounters& pc = plant_.counters();
  no_contact_run_ = pc.contact_lost > contact_lost_seen_ ? no_contact_run_ + 1 : 0;
  contact_lost_seen_ = pc.contact_lost;
  if (!failed_ && o_.drop_is_failure) {
    char why[128];
    if (no_contact_run_ >= kDropContactTicks) {
      std::snprintf(why, sizeof why, "a contact carried no force for %ld ms", no_contact_run_);
      fail(why);
    } else if (pc.slip_distance > kDropSlideM) {
      std::snprintf(why, sizeof why, "the contacts slid %.1f mm along the faces (bound %.1f mm)", pc.slip_distance * 1e3,
                    kDropSlideM * 1e3);
      fail(why);
    }
  }
  const long slips = plant_.counters().slip_events;
  if (slips > slips_seen_ && k_ - slip_logged_ >= 100) {  // at most one line per 100 ticks
    char line[160];
    std::snprintf(line, sizeof line, "slip at tick %ld (%ld so far)%s%s", k_, slips, load_paused_ ? ", paused for load" : "",
                  link_[0].braked || link_[1].braked ? ", braked" : "");
    log(line);
    slip_logged_ = k_;
  }
  slips_seen_ = slips;
}

}  // namespace tandem::world
