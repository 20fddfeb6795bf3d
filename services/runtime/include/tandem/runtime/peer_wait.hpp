// A role's wait for its peers at start-up, on the caller's clock (seconds) and the caller's counts of matched
// endpoints: no DDS, no clock, no thread inside. Each peer is a named count with what is needed, and optionally
// less that is enough once half the timeout has gone (a reader that is slow to come must not hold a module for
// long: the world starts with one standby or recorder reader fewer). Past the timeout the wait has failed, and
// missing() says what was not there.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace tandem::runtime {

class PeerWait {
 public:
  struct Peer {
    std::string name;  ///< what a person calls it ("sensor readers of m1/left")
    int need = 1;      ///< matched endpoints needed
    int enough = -1;   ///< ... enough after half the timeout (-1: the same as need)
  };
  enum class Verdict { Wait, Ready, TimedOut };

  PeerWait(std::vector<Peer> peers, double timeout_s, double start) : peers_(std::move(peers)), timeout_s_(timeout_s), start_(start) {
    for (Peer& p : peers_) {
      if (p.enough < 0 || p.enough > p.need) p.enough = p.need;
    }
  }

  /// One pass: `counts[i]` is what peers[i] has matched now (fewer counts than peers count as 0).
  Verdict pass(double now, const std::vector<int>& counts) {
    counts_ = counts;
    counts_.resize(peers_.size(), 0);
    if (!relaxed_ && now - start_ > 0.5 * timeout_s_) {
      relaxed_ = true;
      for (size_t i = 0; i < peers_.size(); ++i) {
        if (peers_[i].enough < peers_[i].need && counts_[i] < peers_[i].need) lowered_.push_back(i);
      }
    }
    bool ready = true;
    for (size_t i = 0; i < peers_.size(); ++i) ready = ready && counts_[i] >= needed(i);
    if (ready) return Verdict::Ready;
    return now - start_ > timeout_s_ ? Verdict::TimedOut : Verdict::Wait;
  }

  /// What peers[i] needs now (less once half the timeout has gone, if it says so).
  int needed(size_t i) const { return relaxed_ ? peers_[i].enough : peers_[i].need; }
  /// The peers whose need was lowered at half the timeout (each said once, by the pass that lowered it): taken.
  std::vector<size_t> take_lowered() { return std::exchange(lowered_, {}); }
  /// "sensor readers of m1/left 1/2, launcher 0/1": the peers short of what they need, as of the last pass.
  std::string missing() const {
    std::string out;
    for (size_t i = 0; i < peers_.size(); ++i) {
      if (i < counts_.size() && counts_[i] >= needed(i)) continue;
      if (!out.empty()) out += ", ";
      out += peers_[i].name + " " + std::to_string(i < counts_.size() ? counts_[i] : 0) + "/" + std::to_string(needed(i));
    }
    return out;
  }
  const Peer& peer(size_t i) const { return peers_[i]; }
  double timeout_s() const { return timeout_s_; }

 private:
  std::vector<Peer> peers_;
  double timeout_s_, start_;
  bool relaxed_ = false;
  std::vector<int> counts_;
  std::vector<size_t> lowered_;
};

}  // namespace tandem::runtime
