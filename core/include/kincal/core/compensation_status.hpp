// Outcome codes of the controller's compensation path and of the parameter
// table check: one code per failure (Ruckig's Result, LinuxCNC's distinct
// kinematics returns). The first six codes are core's Status, with the same
// names and values, so a kinematics status converts losslessly; the rest are
// the failures that only the controller path has (GUIDE "Reliability": an
// oversized correction and a corrupt parameter table — CRC, version, bounds —
// each give their own status).
#pragma once

#include <cstdint>

#include "kincal/core/status.hpp"

namespace kincal {

enum class CompensationStatus : std::uint8_t {
  Ok = 0,
  InvalidInput,         // NaN / Inf in the NC point (pose or temperature)
  Unreachable,          // no assembly reaches the (corrected) pose
  Singular,             // singular configuration at the NC point
  OutOfLimits,          // a joint command outside the stroke / angle limits
  NotConverged,         // hybrid: the error-twist fixed point diverged (compensation.hpp prepare())
  OversizedCorrection,  // |command − nominal IK| above the table's bound for a joint
  TableVersion,         // parameter table of another format version
  TableFamily,          // parameter table of another machine family
  TableCrc,             // parameter table CRC mismatch: corrupt table
  TableValues,          // non-finite value, or bounds / geometry out of range
  TableLimits,          // table outside the limits compiled in apart from it (machine_limits.hpp)
};

// Number of codes (size of the per-status event counters).
inline constexpr int kCompensationStatusCount = 12;

constexpr CompensationStatus to_compensation_status(Status s) { return static_cast<CompensationStatus>(s); }

static_assert(static_cast<int>(CompensationStatus::NotConverged) == static_cast<int>(Status::NotConverged) &&
                  static_cast<int>(CompensationStatus::OutOfLimits) == static_cast<int>(Status::OutOfLimits) &&
                  static_cast<int>(CompensationStatus::Singular) == static_cast<int>(Status::Singular) &&
                  static_cast<int>(CompensationStatus::Unreachable) == static_cast<int>(Status::Unreachable) &&
                  static_cast<int>(CompensationStatus::InvalidInput) == static_cast<int>(Status::InvalidInput),
              "CompensationStatus must extend Status value for value");
static_assert(static_cast<int>(CompensationStatus::TableLimits) + 1 == kCompensationStatusCount,
              "kCompensationStatusCount out of date");

// True for the codes that say the parameter table itself is unusable.
constexpr bool is_table_failure(CompensationStatus s) {
  return s == CompensationStatus::TableVersion || s == CompensationStatus::TableFamily ||
         s == CompensationStatus::TableCrc || s == CompensationStatus::TableValues ||
         s == CompensationStatus::TableLimits;
}

constexpr const char* to_string(CompensationStatus s) {
  switch (s) {
    case CompensationStatus::Ok: return "ok";
    case CompensationStatus::InvalidInput: return "invalid input";
    case CompensationStatus::Unreachable: return "unreachable";
    case CompensationStatus::Singular: return "singular";
    case CompensationStatus::OutOfLimits: return "out of limits";
    case CompensationStatus::NotConverged: return "not converged";
    case CompensationStatus::OversizedCorrection: return "oversized correction";
    case CompensationStatus::TableVersion: return "table version";
    case CompensationStatus::TableFamily: return "table family";
    case CompensationStatus::TableCrc: return "table crc";
    case CompensationStatus::TableValues: return "table values";
    case CompensationStatus::TableLimits: return "table outside machine limits";
  }
  return "unknown";
}

}  // namespace kincal
