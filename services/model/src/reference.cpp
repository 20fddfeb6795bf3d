#include "tandem/model/reference.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace tandem::model {

ObjectPath::ObjectPath(const Vec3& start, double hold, std::vector<Segment> segments)
    : start_(start), hold_(hold), segments_(std::move(segments)) {}

double ObjectPath::motion_end() const noexcept {
  double t = hold_;
  for (const auto& s : segments_) t += s.duration;
  return t;
}

PoseSample ObjectPath::sample(double t) const noexcept {
  PoseSample out;
  out.pose = start_;
  double t0 = hold_;
  for (const auto& seg : segments_) {
    if (t < t0) return out;  // holding at the start of this segment
    const double T = seg.duration;
    if (t >= t0 + T) {
      out.pose = seg.to;
      t0 += T;
      continue;
    }
    // Rest-to-rest quintic: s(u) = 10u^3 - 15u^4 + 6u^5, u = (t - t0) / T.
    const double u = (t - t0) / T;
    const double s = u * u * u * (10.0 + u * (-15.0 + 6.0 * u));
    const double sd = 30.0 * u * u * (1.0 - u) * (1.0 - u) / T;
    const double sdd = 60.0 * u * (1.0 - u) * (1.0 - 2.0 * u) / (T * T);
    const Vec3 delta = seg.to - out.pose;
    out.pose += s * delta;
    out.vel = sd * delta;
    out.acc = sdd * delta;
    return out;
  }
  return out;
}

void TimeScale::retarget(double t0, double rate, double ramp) {
  if (!breaks_.empty() && t0 < breaks_.back().t0) t0 = breaks_.back().t0;
  breaks_.push_back(next_break(t0, at(t0), rate, std::max(ramp, 0.0)));
}

TimeScale::Break TimeScale::next_break(double t0, const Sample& s, double rate, double ramp) noexcept {
  // The new ramp starts at the rate's slope where the scale stands (a cubic Hermite from (r0, r0') to (r1, 0)):
  // the path's acceleration p' r' stays continuous, so that a stop that cuts into a resume's ramp asks the
  // arms for no step in acceleration (they overshoot a step and then brake harder than the stop: soak finding 77).
  // The slope is bounded so that the rate stays within [0, 1] and never passes its target.
  const double dr = rate - s.rate;
  double slope = ramp > 0.0 ? s.rate_dot * ramp : 0.0;  // r0' T
  if (dr < 0.0) {
    slope = std::clamp(slope, 3.0 * dr, (1.0 - s.rate) * 27.0 / 4.0);
  } else if (dr > 0.0) {
    slope = std::clamp(slope, -s.rate * 27.0 / 4.0, 3.0 * dr);
  } else {
    slope = std::clamp(slope, -s.rate * 27.0 / 4.0, (1.0 - s.rate) * 27.0 / 4.0);
  }
  return Break{t0, s.tau, s.rate, rate, ramp, ramp > 0.0 ? slope / ramp : 0.0};
}

std::vector<double> TimeScale::export_breaks(size_t max) const {
  std::vector<double> out;
  const size_t first = breaks_.size() > max ? breaks_.size() - max : 0;
  out.reserve(5 * (breaks_.size() - first));
  for (size_t i = first; i < breaks_.size(); ++i) {
    const Break& b = breaks_[i];
    out.insert(out.end(), {b.t0, b.tau0, b.r0, b.r1, b.ramp});  // (the start slope follows from the breaks before)
  }
  return out;
}

bool TimeScale::restore(const std::vector<double>& flat) {
  if (flat.size() % 5 != 0) return false;
  TimeScale next;
  for (size_t i = 0; i < flat.size(); i += 5) {
    for (size_t j = i; j < i + 5; ++j) {
      if (!std::isfinite(flat[j])) return false;
    }
    const Break b{flat[i], flat[i + 1], flat[i + 2], flat[i + 3], flat[i + 4], 0.0};
    const bool rate_ok = b.r0 >= 0.0 && b.r0 <= 1.0 && b.r1 >= 0.0 && b.r1 <= 1.0;  // paused .. normal speed
    const std::vector<Break>& before = next.breaks_;
    if (!rate_ok || b.ramp < 0.0 || b.t0 < 0.0 || b.tau0 < 0.0 || (!before.empty() && b.t0 < before.back().t0)) return false;
    // The start slope as the maker computed it, from the breaks before (the oldest kept starts flat: it ended long
    // before any time a follower samples).
    Sample s = next.at(b.t0);
    s.tau = b.tau0;
    s.rate = b.r0;
    if (before.empty() || b.ramp <= 0.0) s.rate_dot = 0.0;
    next.breaks_.push_back(next_break(b.t0, s, b.r1, b.ramp));
  }
  breaks_ = std::move(next.breaks_);
  return true;
}

TimeScale::Sample TimeScale::at(double t) const noexcept {
  Sample out;
  out.tau = t;
  // The last break at or before t (none: the identity, rate 1 from t = 0).
  const Break* b = nullptr;
  for (auto it = breaks_.rbegin(); it != breaks_.rend(); ++it) {
    if (it->t0 <= t) {
      b = &*it;
      break;
    }
  }
  if (b == nullptr) return out;
  const double dt = t - b->t0;
  const double dr = b->r1 - b->r0;
  const double T = b->ramp;
  const double m0 = b->rd0 * T;  // the start slope, in rate per ramp
  if (T <= 0.0 || dt >= T) {
    // Integral of the whole ramp: r0 T + (r1 - r0) T / 2 + r0' T^2 / 12; then the new rate.
    const double ramp_int = T > 0.0 ? b->r0 * T + 0.5 * dr * T + m0 * T / 12.0 : 0.0;
    out.tau = b->tau0 + ramp_int + b->r1 * (dt - std::max(T, 0.0));
    out.rate = b->r1;
    out.rate_dot = 0.0;
    return out;
  }
  const double u = dt / T;
  // Cubic Hermite: r = r0 + (r1 - r0) h01(u) + r0' T h10(u), h01 = 3u^2 - 2u^3, h10 = u^3 - 2u^2 + u;
  // int_0^u h01 = u^3 - u^4 / 2, int_0^u h10 = u^4 / 4 - 2u^3 / 3 + u^2 / 2.
  const double u2 = u * u, u3 = u2 * u, u4 = u3 * u;
  out.tau = b->tau0 + b->r0 * dt + dr * T * (u3 - 0.5 * u4) + m0 * T * (0.25 * u4 - 2.0 * u3 / 3.0 + 0.5 * u2);
  out.rate = b->r0 + dr * u2 * (3.0 - 2.0 * u) + m0 * (u3 - 2.0 * u2 + u);
  out.rate_dot = (dr * 6.0 * u * (1.0 - u) + m0 * (3.0 * u2 - 4.0 * u + 1.0)) / T;
  return out;
}

PoseSample sample_scaled(const ObjectPath& path, const TimeScale::Sample& s, double tau_offset) noexcept {
  const PoseSample p = path.sample(s.tau - tau_offset);
  PoseSample out;
  out.pose = p.pose;
  out.vel = p.vel * s.rate;
  out.acc = p.acc * s.rate * s.rate + p.vel * s.rate_dot;
  return out;
}

ArmReference arm_reference(int j, const PoseSample& obj, const GraspGeometry& g, double force) noexcept {
  const double sign = j == 0 ? -1.0 : 1.0;
  // eq. (15): orientation
  const double phi = obj.pose(2) + sign * 0.5 * g.phi_I;
  const double phid = obj.vel(2);
  const double phidd = obj.acc(2);
  // The end-effector sits at p_E - r_j + preload * a(phi) with r_j = L a(phi); both terms are along a(phi).
  const double L = g.stick_length[j] - g.preload;
  const Vec2 a = approach_axis(phi);
  const Vec2 a1(std::cos(phi), -std::sin(phi));  // da/dphi; d2a/dphi2 = -a
  ArmReference r;
  r.x.head<2>() = obj.pose.head<2>() + sign * 0.5 * g.p_I - L * a;
  r.xd.head<2>() = obj.vel.head<2>() - L * a1 * phid;
  r.xdd.head<2>() = obj.acc.head<2>() - L * (a1 * phidd - a * phid * phid);
  r.x(2) = phi;
  r.xd(2) = phid;
  r.xdd(2) = phidd;
  r.force = force;
  return r;
}

}  // namespace tandem::model
