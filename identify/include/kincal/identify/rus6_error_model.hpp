// The 6-RUS error model (GUIDE "A third family"; core/rus6.hpp): 11
// parameters per leg, 66 in all, each a physical error of one part, none
// redundant with another (the redundancies are held by the choice below):
//
//   dsx_i, dsy_i, dsz_i  the shaft point s_i (where the crank's plane meets
//                        the shaft line: the crank circle's centre), base
//                        frame, mm;
//   dtilt_y_i, dtilt_z_i the shaft's tilt: the motor frame (z_i, y_i, a_i)
//                        turned about y_i, then about the turned z_i, rad
//                        (a turn about a_i itself is dtheta_i);
//   dtheta_i             the crank's zero = the encoder offset (θ = q +
//                        joint_offset), rad: turning the crank-zero
//                        direction about the shaft is the same error, so it
//                        is held in this one parameter;
//   dcrank_i, drod_i     the crank and rod lengths, mm;
//   dpx_i, dpy_i, dpz_i  the rod's platform sphere, platform frame, mm.
//
// Per leg these are the crank circle (centre 3, normal 2, phase 1, radius 1),
// the rod (1) and its sphere (3): what one closure |R·p + t − C(θ)| = ℓ can
// see. With full poses in the base frame all 66 are identifiable; with
// tracker targets the platform spheres' net rigid motion (and, in the
// tracker's frame, the shaft points') is fixed by a convention (the target
// fit's convention rows).
//
// Error twists (pose error per unit parameter, commands held). Leg i's
// closure f_i = |r_i| − ℓ_i, r_i = R·p_i + t − C_i(θ_i), moves with a
// platform twist ξ (v at the platform origin, ω; base axes) by K_i·ξ, K_i =
// [u_iᵀ, ((R·p_i) × u_i)ᵀ] (core/rus6.hpp), and with a parameter δ by
// g_i(δ); holding f = 0 gives ξ = −K⁻¹·e_i·g_i, with (u_i = r_i/|r_i|,
// C_i − s_i the crank)
//   shaft point   g = −u_iᵀ                      (C moves with s)
//   tilt about w  g = −u_i · (w × (C_i − s_i))   (w = y_i⁰, then the turned z_i)
//   crank zero    g = −u_i · (a_i × (C_i − s_i)) = −λ_i
//   crank length  g = −u_i · (C_i − s_i)/c_i
//   rod length    g = −1
//   sphere        g = u_iᵀ·R                     (platform frame)
#pragma once

#include <Eigen/Core>

#include "kincal/core/pose.hpp"
#include "kincal/core/rus6.hpp"

namespace kincal::identify {

inline constexpr int kRus6ParametersPerLeg = 11;
inline constexpr int kRus6ParameterCount = 6 * kRus6ParametersPerLeg;

// nominal + x (x in the order above, leg by leg).
Rus6Geometry<double> rus6_with_errors(const Rus6Geometry<double>& nominal, const Eigen::VectorXd& x);

// The pose error twists per parameter (6 × 66) of the machine nominal + x at
// `pose` (its θ from that machine's IK: the pose must be one it reaches).
// false where the IK fails or the pose is singular.
bool rus6_error_twists(const Rus6Geometry<double>& nominal, const Eigen::VectorXd& x, const Pose<double>& pose,
                       Eigen::Matrix<double, 6, Eigen::Dynamic>& T);

}  // namespace kincal::identify
