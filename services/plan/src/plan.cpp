#include "tandem/plan/plan.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include "tandem/model/grasp.hpp"

namespace tandem::plan {

ModulePlan::ModulePlan(const sim::ModuleSetup& m, bool continuous) : m_(&m), continuous_(continuous) {
  rest_ = m.path.sample(0.0).pose;
}

model::PoseSample ModulePlan::sample(long k) const {
  const model::TimeScale::Sample s = scale_.at(time(k));
  if (!continuous_) return model::sample_scaled(m_->path, s);
  if (task_id_ == 0 || k < start_) {
    model::PoseSample p;
    p.pose = rest_;
    return p;
  }
  return model::sample_scaled(path_, s, tau_start_);
}

void ModulePlan::assign(uint64_t id, const std::vector<double>& waypoints, long start) {
  build_path(rest_, waypoints);
  task_id_ = id;
  start_ = start;
  tau_start_ = scale_.at(time(start)).tau;
  running_ = true;
  ++version_;
}

bool ModulePlan::finish_if_done(long k) {
  if (!running_ || k < start_ || scale_.at(time(k)).tau - tau_start_ < path_.motion_end()) return false;
  running_ = false;
  rest_ = end_pose_;
  ++done_;
  ++version_;
  return true;
}

bool ModulePlan::motion_over(long k) const { return scale_.at(time(k)).tau >= m_->path.motion_end(); }

void ModulePlan::set_rate(long from, double rate, double ramp) {
  if (scale_.target() == rate) return;
  from = std::max(from, last_retarget_);
  scale_.retarget(time(from), rate, ramp);
  last_retarget_ = from;
  ++version_;
}

double ModulePlan::rebase_to(long from, const model::Vec2& object_xy, double window_s, double min_gain) {
  from = std::max(from, last_retarget_);
  const double now_tau = scale_.at(time(from)).tau;
  const double offset = continuous_ ? tau_start_ : 0.0;
  if (continuous_ && (task_id_ == 0 || !running_)) return 0.0;  // resting: nothing to rebase
  const model::ObjectPath& path = continuous_ ? path_ : m_->path;
  const double lo = std::max(offset, now_tau - window_s);
  double best_tau = now_tau, best = 1e300;
  for (double tau = now_tau; tau >= lo; tau -= m_->period) {
    const double d = (path.sample(tau - offset).pose.head<2>() - object_xy).norm();
    if (d < best) {
      best = d;
      best_tau = tau;
    }
  }
  const double now_d = (path.sample(now_tau - offset).pose.head<2>() - object_xy).norm();
  if (best_tau == now_tau || now_d - best < min_gain) return 0.0;
  scale_.rebase(time(from), best_tau);
  last_retarget_ = from;
  ++version_;
  return now_tau - best_tau;
}

void ModulePlan::export_to(PlanData& p) const {
  p.version = version_;
  p.task_id = task_id_;
  p.tasks_done = done_;
  p.running = running_;
  p.start_tick = start_;
  p.tau_start = tau_start_;
  for (int i = 0; i < 3; ++i) {
    p.rest[i] = rest_(i);
    p.path_start[i] = path_start_(i);
  }
  p.waypoints = waypoints_;
  p.breaks = scale_.export_breaks(64);
}

std::string ModulePlan::check(const PlanData& p) {
  const std::vector<double>& w = p.waypoints;
  if (!valid_rank(p.strength, p.epoch)) return "strength not in [1, 100] or epoch not below 2^32";
  if (w.size() % 4 != 0) return "waypoints are not (x, y, phi_E, duration) groups";
  if (!all_finite(w) || !all_finite(p.rest) || !all_finite(p.path_start) || !all_finite(p.breaks)) {
    return "a number is not finite";
  }
  for (size_t i = 3; i < w.size(); i += 4) {
    if (!(w[i] > 0.0)) return "a waypoint's duration is not positive";
  }
  if (!(p.tau_start >= 0.0 && p.tau_start < 1e9)) return "path time at the start not in [0, 1e9)";
  if (p.start_tick < 0 || p.start_tick >= (1LL << 40)) return "start tick not in [0, 2^40)";
  if (p.state > static_cast<uint8_t>(TaskStateCode::Failed)) return "state not in [0, 6]";
  if (p.heard_tick < -1 || p.heard_tick >= (1LL << 40)) return "heard tick not in [-1, 2^40)";
  model::TimeScale scale;
  if (!scale.restore(p.breaks)) return "time-scale retargets malformed";
  return "";
}

bool ModulePlan::import_from(const PlanData& p) {
  if (!check(p).empty()) return false;
  model::TimeScale scale;
  scale.restore(p.breaks);
  scale_ = scale;
  last_retarget_ = 0;
  if (p.breaks.size() >= 5) {
    last_retarget_ = static_cast<long>(std::ceil(p.breaks[p.breaks.size() - 5] / m_->period - 1e-6));
  }
  rest_ = model::Vec3(p.rest[0], p.rest[1], p.rest[2]);
  build_path(model::Vec3(p.path_start[0], p.path_start[1], p.path_start[2]), p.waypoints);
  task_id_ = p.task_id;
  done_ = p.tasks_done;
  running_ = p.running;
  start_ = static_cast<long>(p.start_tick);
  tau_start_ = p.tau_start;
  version_ = p.version;
  return true;
}

void ModulePlan::build_path(const model::Vec3& from, const std::vector<double>& waypoints) {
  std::vector<model::ObjectPath::Segment> segs;
  for (size_t i = 0; i + 3 < waypoints.size(); i += 4) {
    segs.push_back({model::Vec3(waypoints[i], waypoints[i + 1], waypoints[i + 2]), waypoints[i + 3]});
  }
  path_ = model::ObjectPath(from, 0.0, segs);
  path_start_ = from;
  waypoints_ = waypoints;
  end_pose_ = segs.empty() ? from : segs.back().to;
}

PlanFollower::Offer PlanFollower::offer(const PlanData& p, std::string* why, long now_tick) {
  const std::string problem = ModulePlan::check(p);
  if (!problem.empty()) {
    if (why != nullptr) *why = problem;
    return Offer::Rejected;
  }
  const SupervisorRank r = p.rank();
  if (have_ && (rank_.outranks(r) || (!r.outranks(rank_) && p.version <= version_))) return Offer::Ignored;
  if (have_ && p.version < version_) {
    const bool said = refused_rank_.epoch == r.epoch && refused_rank_.strength == r.strength && refused_version_ == p.version;
    if (why != nullptr && !said) {
      *why = "a takeover plan older than the one followed was refused (from " + p.supervisor_id + ", epoch " +
             std::to_string(p.epoch) + ", version " + std::to_string(p.version) + "; following epoch " +
             std::to_string(rank_.epoch) + ", version " + std::to_string(version_) + ")";
    }
    if (!said) refused_ = p;
    refused_rank_ = r;
    refused_version_ = p.version;
    return Offer::Ignored;
  }
  const bool takeover = have_ && (r.outranks(rank_) || rank_.outranks(r));
  const std::optional<model::PoseSample> before =
      have_ && now_tick >= 0 ? std::optional<model::PoseSample>(sample(now_tick)) : std::nullopt;
  plan_.import_from(p);
  have_ = true;
  rank_ = r;
  if (!before) (void)stop_blend();  // (no tick to anchor a blend at: a blend of the plan before would not fit this one)
  if (before) {
    // Measured for every plan adopted, a takeover's or the same leader's next version: a version that reaches a
    // follower after the tick its change was scheduled for (a lost sample its stalled leader could not send again,
    // and a lockstep world that went on once the lease lapsed: soak finding 58; a machine stall: finding 86) would
    // jump the references. Blended instead (bumpless adoption), and said.
    const model::Vec3 d = plan_.sample(now_tick).pose - before->pose;
    const double jump = std::max(d.head<2>().norm(), std::abs(d(2)));
    if (takeover) jump_ = jump;
    // A follower behind the tick the plan was made at (a robot back from a stall, or a standby that just joined: it
    // skips to the newest tick) is not serving that tick: it takes the plan as made, which the others follow.
    // A few ticks behind is no stall (a robot answers the world's sample the supervisor also heard): it blends, from
    // its own tick, as the others do.
    const bool behind = now_tick + kBehindGraceTicks < p.heard_tick;
    const double blend_s = behind ? stop_blend() : start_blend(*before, now_tick);
    if (jump > kMaxJump && why != nullptr) {
      char ms[80];
      if (behind) {
        std::snprintf(ms, sizeof ms, "as made (this follower is %lld ticks behind it)",
                      static_cast<long long>(p.heard_tick - now_tick));
      } else {
        std::snprintf(ms, sizeof ms, "blended into over %.0f ms", blend_s * 1e3);
      }
      *why = std::string(takeover ? "a takeover plan" : "a plan version") + " whose reference jumps by " +
             std::to_string(d.head<2>().norm() * 1e3).substr(0, 6) + " mm at tick " + std::to_string(now_tick) +
             " (from " + p.supervisor_id + ", epoch " + std::to_string(p.epoch) + ", version " +
             std::to_string(p.version) + " after " + std::to_string(version_) + ", made at tick " +
             std::to_string(p.heard_tick) + "); adopted, " + ms;
    }
  }
  version_ = p.version;
  return Offer::Adopted;
}

namespace {

// Quintic Hermite basis on s in [0, 1]: h0 takes a difference in position to 0, h1 (times the blend's length) one
// in velocity, each with zero velocity and acceleration at s = 1 and zero acceleration at s = 0.
double h0(double s) { return 1.0 + s * s * s * (-10.0 + s * (15.0 - 6.0 * s)); }
double h0d(double s) { return s * s * (-30.0 + s * (60.0 - 30.0 * s)); }
double h0dd(double s) { return s * (-60.0 + s * (180.0 - 120.0 * s)); }
double h1(double s) { return s + s * s * s * (-6.0 + s * (8.0 - 3.0 * s)); }
double h1d(double s) { return 1.0 + s * s * (-18.0 + s * (32.0 - 15.0 * s)); }
double h1dd(double s) { return s * (-36.0 + s * (96.0 - 60.0 * s)); }

}  // namespace

double PlanFollower::stop_blend() {
  blend_from_ = -1;
  blend_ticks_ = 0;
  return 0.0;
}

double PlanFollower::start_blend(const model::PoseSample& from, long now_tick) {
  const model::PoseSample to = plan_.sample(now_tick);
  blend_dp_ = from.pose - to.pose;
  blend_dv_ = from.vel - to.vel;
  blend_from_ = -1;
  blend_ticks_ = 0;
  if (blend_dp_.cwiseAbs().maxCoeff() < kBlendMin && blend_dv_.cwiseAbs().maxCoeff() < kBlendMin) return 0.0;
  // The shortest length whose peak acceleration at the faster stick tip stays within the share of the bound.
  const double stick = std::max(m_->geometry.stick_length[0], m_->geometry.stick_length[1]);
  const model::ObjectParams& o = m_->plant.object;
  const double a_max = model::stop_deceleration_bound(m_->reference_force, m_->safe_grasp_force, o.mass, o.mu_s, m_->plant.g0);
  const double limit = kBlendShare * (a_max > 0.0 ? a_max : 1.0);
  const auto peak = [&](double T) {
    double p = 0.0;
    for (int i = 0; i <= 64; ++i) {
      const double s = i / 64.0;
      const model::Vec3 a = blend_dp_ * (h0dd(s) / (T * T)) + blend_dv_ * (h1dd(s) / T);
      p = std::max(p, a.head<2>().norm() + stick * std::abs(a(2)));
    }
    return p;
  };
  double T = 10.0 * m_->period;
  while (peak(T) > limit && T < 10.0) T *= 1.1;
  blend_from_ = now_tick;
  blend_ticks_ = static_cast<long>(std::ceil(T / m_->period));
  return static_cast<double>(blend_ticks_) * m_->period;
}

model::PoseSample PlanFollower::sample(long k) const {
  model::PoseSample x = plan_.sample(k);
  if (!blending(k)) return x;
  const double T = static_cast<double>(blend_ticks_) * m_->period;
  const double s = static_cast<double>(k - blend_from_) / static_cast<double>(blend_ticks_);
  x.pose += blend_dp_ * h0(s) + blend_dv_ * (T * h1(s));
  x.vel += blend_dp_ * (h0d(s) / T) + blend_dv_ * h1d(s);
  x.acc += blend_dp_ * (h0dd(s) / (T * T)) + blend_dv_ * (h1dd(s) / T);
  return x;
}

model::ArmReference PlanFollower::reference(int j, long k) const {
  if (!blending(k)) return plan_.reference(j, k);
  return model::arm_reference(j, sample(k), m_->geometry, m_->reference_force);
}

bool PlanFollower::adopt_refused(const SupervisorRank& r, uint64_t version, long now_tick) {
  if (refused_rank_.strength == 0 || refused_rank_.epoch != r.epoch || refused_rank_.strength != r.strength ||
      refused_version_ != version || !r.outranks(rank_)) {
    return false;
  }
  const model::PoseSample before = sample(std::max(now_tick, 0L));
  plan_.import_from(refused_);
  if (have_ && now_tick >= 0 && now_tick >= refused_.heard_tick) {
    (void)start_blend(before, now_tick);
  } else {
    (void)stop_blend();
  }
  rank_ = r;
  version_ = version;
  refused_rank_ = SupervisorRank{};
  return true;
}

}  // namespace tandem::plan
