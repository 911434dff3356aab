// Status codes of the controller path: one code per failure (Ruckig's Result,
// LinuxCNC's distinct kinematics returns). Every core routine that can fail
// returns one of these; outputs are written only when the status is Ok.
#pragma once

#include <cstdint>

namespace kincal {

enum class Status : std::uint8_t {
  Ok = 0,
  InvalidInput,   // NaN / Inf in an input, or a malformed parameter set
  Unreachable,    // no geometric solution for this pose (assembly impossible)
  Singular,       // the kinematic Jacobian is (numerically) singular here
  OutOfLimits,    // a joint would leave its stroke / angle range
  NotConverged,   // iterative solver (FK) did not reach its tolerance
};

constexpr const char* to_string(Status s) {
  switch (s) {
    case Status::Ok: return "ok";
    case Status::InvalidInput: return "invalid input";
    case Status::Unreachable: return "unreachable";
    case Status::Singular: return "singular";
    case Status::OutOfLimits: return "out of limits";
    case Status::NotConverged: return "not converged";
  }
  return "unknown";
}

}  // namespace kincal
