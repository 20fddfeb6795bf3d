// Lifecycle and live status of a role process, published on tandem/process_status (transient-local,
// keep-last 1 per process) so that the launcher and `tandem status` from another terminal see every
// process's current state.
#pragma once

#include <cstdlib>

#include <tandemPubSubTypes.h>
#include <unistd.h>

#include <string>
#include <vector>

#include "tandem/dds/bus.hpp"

namespace tandem::runtime {

enum class Lifecycle : uint8_t { Unconfigured = 0, Inactive = 1, Active = 2, Finalized = 3, Error = 4 };
const char* lifecycle_name(uint8_t state);
/// "down", "kill", "plug", "unplug", "pause", "resume", "drain" (ControlRequest.command).
const char* command_name(msg::ControlCommand c);
/// "primary", "standby" or "" (ProcessStatus.serving).
const char* role_name(msg::ServingRole role);
/// Who an arm follows, for people: its robot's label, or "stopping", "braked", "braked(load)".
std::string owner_text(const msg::ArmOwner& o);
/// Every arm: "left=m1/left@50,right=braked" (status lines, recorder events).
std::string owners_text(const std::vector<msg::ArmOwner>& owners);

class StatusPublisher {
 public:
  StatusPublisher(dds::Participant& p, const std::string& process_id, const std::string& role,
                  const std::string& module_id)
      : writer_(p, dds::kStatusTopic, dds::TopicKind::Status) {
    msg_.process_id(process_id);
    msg_.role(role);
    msg_.module_id(module_id);
    msg_.pid(static_cast<int64_t>(::getpid()));
    // Multi-host: the agent that started this process names its host (docs/multihost.md).
    if (const char* host = std::getenv("TANDEM_HOST")) msg_.host(host);
  }
  msg::ProcessStatus& msg() { return msg_; }
  void set(Lifecycle s, const std::string& detail = "") {
    msg_.state(static_cast<uint8_t>(s));
    msg_.detail(detail);
    publish();
  }
  void publish() { writer_.write(msg_); }

 private:
  dds::Writer<msg::ProcessStatus, msg::ProcessStatusPubSubType> writer_;
  msg::ProcessStatus msg_;
};

}  // namespace tandem::runtime
