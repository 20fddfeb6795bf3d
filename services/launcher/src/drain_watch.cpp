#include "tandem/launcher/drain_watch.hpp"

namespace tandem::launcher {

void DrainWatch::start(double now) {
  first_ = sent_ = now;
  warned_ = leader_stopped_ = false;
}

DrainStep DrainWatch::step(double now, bool acked) {
  DrainStep s;
  if (!active() || now - sent_ < kResendEvery) return s;
  if (now - first_ > kTimeout) {
    s.force = true;
    first_ = sent_ = -1.0;
    return s;
  }
  if (acked) return s;
  s.stop_leader = !leader_stopped_ && now - first_ > kDeafLeader;
  s.warn = !warned_ && now - first_ > kWarnAfter;
  warned_ = warned_ || s.warn;
  s.resend = true;
  sent_ = now;
  return s;
}

}  // namespace tandem::launcher
