#include "swerve/control/tracking_controller.hpp"

#include "swerve/core/config_error.hpp"

namespace swerve {

void TrackingController::set_module_fault(int module, ModuleFault fault) {
  if (module < 0 || module >= faults_->size()) {
    throw_invalid_field(name(), "set_module_fault.module", module,
                        "must name a module of the vehicle, 0 to " + std::to_string(faults_->size() - 1));
  }
  if (fault != ModuleFault::kNone && fault != ModuleFault::kStuckSteering) {
    throw_invalid_field(name(), "set_module_fault.fault", static_cast<int>(fault), "is not a ModuleFault");
  }
  record_module_fault(module, fault);
}

}  // namespace swerve
