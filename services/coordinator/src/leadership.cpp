#include "tandem/coordinator/leadership.hpp"

#include <cmath>
#include <cstdio>

namespace tandem::coordinator {

namespace {
std::string ms(double s) {
  char b[32];
  std::snprintf(b, sizeof b, "%.0f ms", s * 1e3);
  return b;
}
}  // namespace

std::string Leadership::on_loop(double now) {
  std::string line;
  if (primary_ && now - last_loop_ > kStallS && doubt_until_ < 0.0) {
    line = "stalled for " + ms(now - last_loop_) + " (a standby takes over after " + ms(kTakeoverS) +
           "): listening for a successor before deciding anything";
    doubt_until_ = now + kDoubtS;
    last_stall_ = now;
  } else if (!primary_ && now - last_loop_ > kStandbyDeafS) {
    // A standby that stood still heard nothing meanwhile: the primary's silence counts from now, not from before
    // its own stall (both coordinators stalled together in soak run 20, the standby took over on a silence that
    // was its own, and both left).
    line = "stood still for " + ms(now - last_loop_) + "; the primary's silence counts from now";
    listen_from_ = now;
  }
  last_loop_ = now;
  return line;
}

bool Leadership::on_peer(const std::string& id, bool active, bool claims_primary, double now, uint64_t peer_next,
                         uint64_t own_next) {
  if (id == o_.id) return false;
  if (primary_ && claims_primary && active) {
    if (doubting() || now - last_stall_ <= kStallMemoryS) return true;  // it may have been replaced meanwhile
    if (peer_next > own_next) return true;                               // the other's queue is further on
    if (peer_next == own_next && id < o_.id) return true;                // as far on: the smaller id stays
  }
  if (active) {
    peers_[id] = now;
  } else {
    peers_.erase(id);
  }
  return false;
}

bool Leadership::on_state(const Snapshot& s, double now) {
  if (!s.well_formed()) {
    ++malformed_;
    return false;
  }
  if (last_state_ && (s.next_task_id < last_state_->next_task_id ||
                      (s.next_task_id == last_state_->next_task_id && s.done_total < last_state_->done_total))) {
    return false;
  }
  last_state_ = s;
  last_state_at_ = now;
  return true;
}

bool Leadership::first_in_line(double now) const {
  for (const auto& [id, heard] : peers_) {
    if (id < o_.id && now - heard <= kTakeoverS) return false;
  }
  return true;
}

Leadership::Step Leadership::step(double now, size_t tasks, std::string* log) {
  if (!primary_) {
    if (last_state_ && last_state_->done_count() >= tasks) {
      if (log) *log = "the primary reports every task done; the standby exits";
      return Step::AllDone;
    }
    if (!last_state_ && o_.resume && now - start_ > kDeafS) {
      if (log) *log = "no queue state heard in " + ms(now - start_) + " (a restart never leads without one): this one "
                      "cannot hear the queue; exiting, to come back with a fresh participant";
      return Step::Deaf;
    }
    // A restarted one in its first kFirstStateS: the silence may be a primary it has not discovered yet, and the
    // state it holds the launcher's copy, older than the live queue (soak run 20: r10, 1.0 s after its start,
    // took over from r9 on such a copy, and a task heard done went back to the queue).
    if (o_.resume && now - start_ < kFirstStateS) return Step::Wait;
    const bool may = last_state_ || !o_.resume;
    const double bound = last_state_ ? kTakeoverS : kFirstStateS;
    if (!may || silent(now) <= bound) return Step::Wait;
    const bool passed_over = !first_in_line(now);
    if (passed_over && silent(now) <= bound + kPassOverS) return Step::Wait;
    primary_ = true;
    if (log) {
      *log = "primary silent for " + ms(silent(now)) + "; taking over" +
             (passed_over ? std::string(" (the standby before this one in line did not)") : std::string());
    }
    return Step::TakeOver;
  }
  if (doubting()) {
    if (now < doubt_until_) return Step::Wait;
    doubt_until_ = -1.0;
    if (log) *log = "no successor took over; carrying on as the primary";
  }
  return Step::Lead;
}

}  // namespace tandem::coordinator
