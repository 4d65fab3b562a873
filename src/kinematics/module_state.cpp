#include "swerve/kinematics/module_state.hpp"

namespace swerve {

const char* to_string(KinematicsStatus status) {
  switch (status) {
    case KinematicsStatus::kOk: return "ok";
    case KinematicsStatus::kNonFiniteInput: return "non_finite_input";
    case KinematicsStatus::kWrongModuleCount: return "wrong_module_count";
    case KinematicsStatus::kInvalidDt: return "invalid_dt";
    case KinematicsStatus::kInvalidLimit: return "invalid_limit";
    case KinematicsStatus::kInvalidWeight: return "invalid_weight";
    case KinematicsStatus::kRankDeficient: return "rank_deficient";
  }
  return "unknown";
}

}  // namespace swerve
