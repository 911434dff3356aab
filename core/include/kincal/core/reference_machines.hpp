// The built-in reference machines (GUIDE "Reference machines"), usable by name
// on the host and compiled into firmware without any file parsing.
#pragma once

#include "kincal/core/hybrid.hpp"
#include "kincal/core/rus6.hpp"
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

// Dimensions of `rus6-ref` (docs/reference-machines.md, "rus6-ref"): a
// 6-RUS of our own design, sized like a desktop motion platform.
struct Rus6RefDimensions {
  static constexpr double base_radius = 200.0;      // |s_i| from the base centre, shafts in z = 0
  static constexpr double motor_spread_deg = 25.0;  // motors of a pair at 120°·k ± this
  static constexpr double crank_length = 100.0;
  static constexpr double rod_length = 300.0;
  static constexpr double platform_radius = 130.0;
  static constexpr double platform_spread_deg = 25.0;  // spheres at 120°·k ± this, platform z = 0
  // Joint range about home (θ = 0, cranks horizontal). Asymmetric because
  // lowering the platform swings the cranks further than raising it: over
  // the ±40 mm / ±10° box about home θ spans −73.9°…+61.3°; the other IK
  // branch stays beyond ±105° there.
  static constexpr double min_joint_deg = -80.0, max_joint_deg = 70.0;
  // Each motor drives its crank through a 10:1 gearbox: the `cyclic`
  // effect's period (one motor revolution) is 2π/10 rad of crank.
  static constexpr double cyclic_period = 2.0 * 3.14159265358979323846 / 10.0;
};

// `rus6-ref`. Motor pairs centred at 0°, 120°, 240° about z; each shaft is
// horizontal and radial (a_i ∥ ±r̂), its crank at θ = 0 horizontal and
// tangential, pointing away from the pair's other motor; a_i × z_i = +z, so
// θ > 0 lifts every crank. Leg i's sphere sits at the same azimuth as its
// motor on the smaller platform circle, so each rod leans inward and
// sideways (the sideways lean is what resists rotation about z). Home is the
// pose at which every crank is horizontal (θ = 0): by the three-fold and
// mirror symmetry all six legs close there at one height, 274.04 mm.
template <class Scalar> Rus6Geometry<Scalar> make_rus6_ref() {
  using D = Rus6RefDimensions;
  const double deg = 3.14159265358979323846 / 180.0;
  Rus6Geometry<Scalar> g;
  for (int pair = 0; pair < 3; ++pair) {
    for (int side = 0; side < 2; ++side) {
      const int i = 2 * pair + side;
      const double sign = side == 0 ? -1.0 : 1.0;
      const double motor_azimuth = (120.0 * pair + sign * D::motor_spread_deg) * deg;
      const double sphere_azimuth = (120.0 * pair + sign * D::platform_spread_deg) * deg;
      const double cm = std::cos(motor_azimuth), sm = std::sin(motor_azimuth);
      g.shaft_points.col(i) = Vec3<Scalar>(Scalar(D::base_radius * cm), Scalar(D::base_radius * sm), Scalar(0));
      // Tangent away from the partner (sign · t̂), axis sign · r̂: r̂ × t̂ = +z.
      g.crank_zero.col(i) = Vec3<Scalar>(Scalar(-sign * sm), Scalar(sign * cm), Scalar(0));
      g.shaft_axes.col(i) = Vec3<Scalar>(Scalar(sign * cm), Scalar(sign * sm), Scalar(0));
      g.platform_joints.col(i) = Vec3<Scalar>(Scalar(D::platform_radius * std::cos(sphere_azimuth)),
                                              Scalar(D::platform_radius * std::sin(sphere_azimuth)), Scalar(0));
    }
  }
  g.crank_length.setConstant(Scalar(D::crank_length));
  g.rod_length.setConstant(Scalar(D::rod_length));
  g.min_joint.setConstant(Scalar(D::min_joint_deg * deg));
  g.max_joint.setConstant(Scalar(D::max_joint_deg * deg));
  // Home height: the rod's horizontal run h from the horizontal crank's tip
  // to its sphere, then z = √(ℓ² − h²) (in double, then cast).
  const double motor_azimuth = -D::motor_spread_deg * deg, sphere_azimuth = -D::platform_spread_deg * deg;
  const double tip_x = D::base_radius * std::cos(motor_azimuth) + D::crank_length * std::sin(motor_azimuth);
  const double tip_y = D::base_radius * std::sin(motor_azimuth) - D::crank_length * std::cos(motor_azimuth);
  const double run_x = D::platform_radius * std::cos(sphere_azimuth) - tip_x;
  const double run_y = D::platform_radius * std::sin(sphere_azimuth) - tip_y;
  const double home_z = std::sqrt(D::rod_length * D::rod_length - run_x * run_x - run_y * run_y);
  g.home = Pose<Scalar>::from_xyz_rpy(Scalar(0), Scalar(0), Scalar(home_z), Scalar(0), Scalar(0), Scalar(0));
  g.characteristic_length = Scalar(D::platform_radius);
  // One branch fits the limits at home, so this is the home assembly.
  Vec6<Scalar> branches;
  if (rus6_home_branches(g, branches) == Status::Ok) g.home_branch = branches;
  return g;
}

}  // namespace kincal
