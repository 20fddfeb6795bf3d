#include "tandem/runtime/status.hpp"

namespace tandem::runtime {

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
