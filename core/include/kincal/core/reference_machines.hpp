// The built-in reference machines (GUIDE "Reference machines"), usable by name
// on the host and compiled into firmware without any file parsing.
#pragma once

#include "kincal/core/hybrid.hpp"
#include "kincal/core/stewart.hpp"

namespace kincal {

// `stewart-seed001`: seed 001 Table 2. Home pose (0, 0, 200, 0, 0, 0) where all
// legs are 233.23808 mm. Seed 001 gives no stroke; we adopt ±50 mm about the
// home length (docs/reference-machines.md).
template <class Scalar> StewartGeometry<Scalar> make_stewart_seed001() {
  StewartGeometry<Scalar> g;
  // Columns B_i, seed 001 Table 2 (mm).
  g.base << Scalar(120), Scalar(120), Scalar(61.243557), Scalar(-181.24356), Scalar(-181.24356), Scalar(61.243557),
      Scalar(-140), Scalar(140), Scalar(173.92305), Scalar(33.92305), Scalar(-33.92305), Scalar(-173.92305),  //
      Scalar(0), Scalar(0), Scalar(0), Scalar(0), Scalar(0), Scalar(0);
  // Columns P_i, seed 001 Table 2 (mm).
  g.platform << Scalar(120), Scalar(120), Scalar(-42.679489), Scalar(-77.320511), Scalar(-77.320511),
      Scalar(-42.679489),  //
      Scalar(-20), Scalar(20), Scalar(113.92304), Scalar(93.923042), Scalar(-93.923042), Scalar(-113.92304),  //
      Scalar(0), Scalar(0), Scalar(0), Scalar(0), Scalar(0), Scalar(0);
  g.min_length.setConstant(Scalar(233.23808 - 50.0));
  g.max_length.setConstant(Scalar(233.23808 + 50.0));
  g.home = Pose<Scalar>::from_xyz_rpy(Scalar(0), Scalar(0), Scalar(200), Scalar(0), Scalar(0), Scalar(0));
  return g;
}

// Dimensions of `hybrid-seed000` (seed 000 Table 1 and docs/hybrid-geometry.md).
struct HybridSeed000Dimensions {
  static constexpr double base_radius = 350.0;      // |A0 A1i|
  static constexpr double platform_radius = 135.0;  // |A64 A6i|
  static constexpr double platform_to_wrist = 405.0;  // |A64 Q|
  static constexpr double wrist_link = 120.0;       // |Q P0|
  static constexpr double tool_length = 250.0;      // |P0 P|
  static constexpr double gauge_radius = 200.0;     // |P0 Pj|
  static constexpr double min_ups = 628.0, max_ups = 1178.0;
  static constexpr double beta = 3.14159265358979323846 / 6.0;  // structural angle β
  // UP-limb extension c = q34 + e at the reference pose (limb along z0): chosen
  // so the UPS lengths over the 500 × 500 × 120 mm task cuboid sit inside
  // [628, 1178] with margin at both ends (docs/hybrid-geometry.md).
  static constexpr double reference_extension = 850.0;
};

// `hybrid-seed000`. Poses are in the workpiece frame {R} (seed 000 Eq. (8),
// wR0 = Rot(y, π − β)·Rot(z, π/2)) with its origin at the reference pose, the
// centre of the task cuboid; the tool frame is aligned with {R} there, so the
// task cuboid is [−250, 250] × [−250, 250] × [−60, 60] mm at orientation 0.
template <class Scalar> HybridGeometry<Scalar> make_hybrid_seed000() {
  using D = HybridSeed000Dimensions;
  HybridGeometry<Scalar> g;
  // Limb 1 in the machine's symmetry plane (the y0–z0 plane, normal to the tilt
  // axis x0), limbs 2 and 3 mirror images: seed 000 notes limbs 2 and 3 share
  // a symmetry plane with the measurement nodes.
  for (int i = 0; i < 3; ++i) {
    const double phi = 3.14159265358979323846 * (0.5 + 2.0 * i / 3.0);
    g.base_joints.col(i) = Vec3<Scalar>(Scalar(D::base_radius * std::cos(phi)), Scalar(D::base_radius * std::sin(phi)), Scalar(0));
    g.platform_joints.col(i) =
        Vec3<Scalar>(Scalar(D::platform_radius * std::cos(phi)), Scalar(D::platform_radius * std::sin(phi)), Scalar(0));
  }
  g.platform_to_wrist = Scalar(D::platform_to_wrist);
  g.wrist_link = Scalar(D::wrist_link);
  g.tool_length = Scalar(D::tool_length);
  const Scalar beta = Scalar(D::beta);
  g.workpiece_rotation = rot_y(pi<Scalar>() - beta) * rot_z(pi<Scalar>() / Scalar(2));
  g.home.extension = Scalar(D::reference_extension);
  // Reference pose: limb along z0, θ4 = 0, θ5 = β turns the tool from z0 to
  // −z of {R}, θ6 = 0 (then z5 ∥ y and z6 ∥ x of {R}, as seed 000 Section 3 says).
  const HybridFrames<Scalar> ref = hybrid_frames(g, g.home, Vec3<Scalar>(Scalar(0), beta, Scalar(0)));
  g.workpiece_origin = ref.P;
  g.tool_offset = ref.F6.transpose() * g.workpiece_rotation.transpose();
  g.min_joint << Scalar(D::min_ups), Scalar(D::min_ups), Scalar(D::min_ups), Scalar(-2.9), Scalar(-1.4), Scalar(-1.4);
  g.max_joint << Scalar(D::max_ups), Scalar(D::max_ups), Scalar(D::max_ups), Scalar(2.9), Scalar(1.4), Scalar(1.4);
  g.min_extension = Scalar(400);
  g.max_extension = Scalar(1400);
  return g;
}

}  // namespace kincal
