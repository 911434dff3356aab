// The hybrid's part of a Robot (robot.hpp): its family name, the design
// inputs its geometry is built from, and what only it has — core's
// geometry, the gauge's size and seed 000's source errors.
#pragma once

#include <Eigen/Core>

#include "kincal/core/hybrid.hpp"
#include "kincal/core/pose.hpp"

namespace kincal::identify {

inline constexpr const char* kHybridFamily = "hybrid-3ups-up-3r";

// The design inputs of a hybrid machine from which HybridGeometry's derived
// members (workpiece frame, tool offset, home) follow, exactly as core's
// make_hybrid_seed000 derives them (reference_machines.hpp).
struct HybridDesign {
  Mat3<double> base_joints = Mat3<double>::Zero();      // A1i in {R0}, columns, mm
  Mat3<double> platform_joints = Mat3<double>::Zero();  // a_i in the platform frame, columns, mm
  double platform_to_wrist = 0;  // |A64 Q|, mm
  double wrist_link = 0;         // |Q P0|, mm
  double tool_length = 0;        // |P0 P|, mm
  double beta = 0;               // structural angle β, rad
  double reference_extension = 0;  // c = |A0 A64| at the reference pose, mm
  Vec6<double> min_joint = Vec6<double>::Zero(), max_joint = Vec6<double>::Zero();
  double min_extension = 0, max_extension = 0;
  Vec6<double> joint_offset = Vec6<double>::Zero();
};

// Builds the geometry: wR0 = Rot(y, π − β)·Rot(z, π/2) (seed 000 Eq. (8)); at
// the reference configuration (θ1 = θ2 = 0, c = reference_extension,
// wrist angles (0, β, 0)) the tool point P is the origin of {R} and the tool
// frame is aligned with {R}.
HybridGeometry<double> make_hybrid_geometry(const HybridDesign& d);
// The inverse: reads the design inputs back (β from the workpiece rotation).
HybridDesign hybrid_design_of(const HybridGeometry<double>& g);

// The hybrid (hybrid-3ups-up-3r).
struct HybridDescription {
  HybridGeometry<double> geometry;
  double gauge_radius = 0.0;  // |P0 Pj| of seed 000's three-target gauge, mm
  // Seed 000's joint/link source errors Δχ (150, in the order of
  // HybridErrorModel, identify/hybrid_error_model.hpp), set from PARAMS.csv.
  // Empty = none; then the machine is the (possibly modified) ideal geometry.
  Eigen::VectorXd source_errors;
};

}  // namespace kincal::identify
