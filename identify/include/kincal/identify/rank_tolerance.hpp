// The relative rank tolerance every rank and conditioning judgement of a
// design uses (estimators.hpp, identifiability.hpp, and every solve inside
// identify/): one definition all include, so that none includes another.
#pragma once

namespace kincal::identify {

// The one rank rule of identify/'s solves and of the statistics read from
// them: on the column-scaled design S = X·D⁻¹ (unit column norms, so mm, rad
// and an effect's units weigh alike), a direction counts when its singular
// value — or, in a rank-revealing QR, its pivot — exceeds kRankThreshold
// times the largest. Why 1e-10 and not rounding's max(n, p)·ε (the LAPACK /
// NumPy matrix_rank convention, this library's default until #33): a
// design's columns are not exact to ε — they come through iterated forward
// kinematics (converged to ~1e-9 mm), automatic or finite differences and
// the linearisation itself — so a direction below 1e-10 of the largest is
// the design's own error, not the machine; and its coefficient's standard
// error would exceed 1e10 times the noise's, which no data set of a machine
// determines. The solve and the rank, test degrees of freedom and covariance
// reported for it then agree on which directions were fitted.
inline constexpr double kRankThreshold = 1e-10;

// A caller's relative rank tolerance (a singular value of the column-scaled
// design counts as zero when s_j ≤ rcond · s_max); a negative value, the
// default, selects kRankThreshold.
inline constexpr double kDefaultRcond = -1.0;
inline constexpr double effective_rcond(double rcond) { return rcond >= 0 ? rcond : kRankThreshold; }

}  // namespace kincal::identify
