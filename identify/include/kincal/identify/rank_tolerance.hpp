// The relative rank tolerance every rank and conditioning judgement of a
// design uses (estimators.hpp, identifiability.hpp): one definition both
// include, so that neither includes the other.
#pragma once

#include <Eigen/Core>

namespace kincal::identify {

// Relative rank tolerance: a singular value of the column-scaled design (unit
// column norms, see identifiability.hpp) counts as zero when
// s_j ≤ rcond · s_max. A negative value selects the default max(n, m) · ε
// (the LAPACK / NumPy matrix_rank convention).
inline constexpr double kDefaultRcond = -1.0;
double effective_rcond(double rcond, Eigen::Index rows, Eigen::Index cols);

}  // namespace kincal::identify
