#include "tandem/runtime/status.hpp"

namespace tandem::runtime {

const char* command_name(msg::ControlCommand c) {
  switch (c) {
    case msg::CMD_DOWN: return "down";
    case msg::CMD_KILL: return "kill";
    case msg::CMD_PLUG: return "plug";
    case msg::CMD_UNPLUG: return "unplug";
    case msg::CMD_PAUSE: return "pause";
    case msg::CMD_RESUME: return "resume";
    case msg::CMD_DRAIN: return "drain";
  }
  return "?";
}

const char* role_name(msg::ServingRole role) {
  return role == msg::ROLE_PRIMARY ? "primary" : role == msg::ROLE_STANDBY ? "standby" : "";
}

std::string owner_text(const msg::ArmOwner& o) {
  switch (o.state()) {
    case msg::ARM_SERVED: return o.robot();
    case msg::ARM_STOPPING: return "stopping";
    case msg::ARM_BRAKED: return "braked";
    case msg::ARM_BRAKED_LOAD: return "braked(load)";
  }
  return "?";
}

std::string owners_text(const std::vector<msg::ArmOwner>& owners) {
  std::string out;
  for (const auto& o : owners) out += (out.empty() ? "" : ",") + o.arm() + "=" + owner_text(o);
  return out;
}

const char* lifecycle_name(uint8_t state) {
  switch (state) {
    case 0: return "unconfigured";
    case 1: return "inactive";
    case 2: return "active";
    case 3: return "finalized";
    case 4: return "error";
    default: return "?";
  }
}

}  // namespace tandem::runtime
