// Identifiability of the regression model Δp = H·Δχ + ε (seed 000 Eq. (10)):
// numerical rank, the two reconstructions of seed 000 Section 4.1 (spectral
// "first way", column selection "second way"), observability indices, and a
// collinearity report (VIF, Belsley condition indices and variance-decomposition
// proportions, null-space combinations of a rank-deficient design).
//
// Columns of H carry different units (mm and rad parameters), so every rank or
// conditioning judgement here is made on the column-scaled design H·D⁻¹ with
// D = diag(‖h_j‖) (unit column norms; an all-zero column keeps scale 1) unless
// ColumnScaling::None is asked for. Results are reported in the original units.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

#include "kincal/identify/rank_tolerance.hpp"

namespace kincal::identify {

enum class ColumnScaling { None, UnitNorm };

// ‖h_j‖ per column (1 for an all-zero column) — the D of H·D⁻¹.
Eigen::VectorXd column_scales(const Eigen::MatrixXd& H, ColumnScaling scaling = ColumnScaling::UnitNorm);

struct RankReport {
  Eigen::Index rows = 0, cols = 0, rank = 0;
  double rcond = 0;       // relative tolerance used (effective_rcond)
  double tolerance = 0;   // absolute: rcond · s_max
  ColumnScaling scaling = ColumnScaling::UnitNorm;
  Eigen::VectorXd column_scale;     // D
  Eigen::VectorXd singular_values;  // of H·D⁻¹, descending, min(n, m) of them
  double condition_number = 0;      // s_max / s_min over all columns (inf when rank-deficient)
};

// Numerical rank: #{ s_j > rcond · s_max } of the (scaled) design,
// rcond < 0 → kRankThreshold (rank_tolerance.hpp).
// Computed from the triangular factor (triangular_factor): the same numbers
// as an SVD of the tall design, at a fraction of the work.
RankReport rank_by_svd(const Eigen::MatrixXd& H, double rcond = kDefaultRcond,
                       ColumnScaling scaling = ColumnScaling::UnitNorm);

// R of H = Q·R (Householder QR; the m × m upper triangle) for a tall H
// (n > m); H itself otherwise. Q is orthonormal, so R has H's column norms,
// singular values and right singular vectors.
Eigen::MatrixXd triangular_factor(const Eigen::MatrixXd& H);

// rank_by_svd of a design H with `rows` rows from the triangular factor R of
// its QR decomposition, for a caller that already has it (PreparedDesign
// factors each design once).
RankReport rank_of_factor(const Eigen::MatrixXd& R, Eigen::Index rows, double rcond = kDefaultRcond,
                          ColumnScaling scaling = ColumnScaling::UnitNorm);

// ---- seed 000 Section 4.1, the "second way" --------------------------------

struct ColumnSelection {
  std::vector<Eigen::Index> kept;      // ξ columns first, then the η columns that raised the rank, in order
  std::vector<Eigen::Index> dropped;   // η columns that did not
  std::vector<std::string> kept_names, dropped_names;
  std::vector<double> distance;        // per η column tested (in eta order): distance of its unit column from the span so far
  Eigen::Index rank = 0;               // = kept.size()
  double tolerance = 0;                // a unit column is independent when its distance > tolerance
};

// Start from H_ξ (the `xi` columns, which must be independent — the actuated
// joints at a nonsingular configuration; otherwise InputError) and add each η
// column only if rank([H h_η,j]) = rank(H) + 1 (Step 2). The rank test is the
// distance of the unit-norm column from the span of the kept ones
// (Gram–Schmidt with re-orthogonalisation), independent when
// distance > tolerance. tolerance < 0 selects kRankThreshold·√m: the
// default rcond times √m, the largest s_max unit-norm columns can have.
ColumnSelection reconstruct_by_column_selection(const Eigen::MatrixXd& H, const std::vector<Eigen::Index>& xi,
                                                const std::vector<Eigen::Index>& eta,
                                                const std::vector<std::string>& names = {},
                                                double tolerance = -1.0);

// ---- seed 000 Section 4.1, the "first way" ---------------------------------

struct SpectralReduction {
  Eigen::MatrixXd phi1;             // m × m1: Δχ = Φ₁·Δα (original units; = D⁻¹V₁ when scaled)
  Eigen::MatrixXd z1;               // n × m1: Z₁ = H·Φ₁, full column rank
  Eigen::VectorXd singular_values;  // the m1 non-zero ones (of the scaled H)
  Eigen::Index rank = 0;            // m1
  RankReport rank_report;
  Eigen::VectorXd to_parameters(const Eigen::VectorXd& alpha) const { return phi1 * alpha; }
};

// Φ₁ from the right singular vectors with non-zero singular values (the
// eigenvectors of HᵀH with non-zero eigenvalues, computed by the SVD, not by
// forming HᵀH). With ColumnScaling::None Φ₁ is exactly the paper's.
SpectralReduction spectral_reduction(const Eigen::MatrixXd& H, double rcond = kDefaultRcond,
                                     ColumnScaling scaling = ColumnScaling::UnitNorm);

// ---- observability indices ---------------------------------------------------

// Numbered as in Sun & Hollerbach (2008) and Joubair & Bonev (2013), on the
// singular values s_1 ≥ … ≥ s_m of the (column-scaled) identification Jacobian:
//   O1 = (s_1⋯s_m)^{1/m} / √n   Borm & Menq
//   O2 = s_m / s_1               Driels & Pathre (inverse condition number)
//   O3 = s_m                     Nahvi et al. (minimum singular value)
//   O4 = s_m² / s_1              Nahvi & Hollerbach (noise amplification index)
//   O5 = 1 / Σ 1/s_j             Sun & Hollerbach
struct ObservabilityIndices {
  double o1 = 0, o2 = 0, o3 = 0, o4 = 0, o5 = 0;
};
ObservabilityIndices observability_indices(const Eigen::VectorXd& singular_values, Eigen::Index rows);
ObservabilityIndices observability_indices(const Eigen::MatrixXd& H, ColumnScaling scaling = ColumnScaling::UnitNorm);

// ---- null space -------------------------------------------------------------

// One direction v with H·v = 0 (to the rank tolerance): moving the parameters
// along v changes no measurement, so only combinations orthogonal to it are
// identifiable. Coefficients are in the parameters' own units, the leading
// one (the first column of the combination) is 1; terms below 1e-9 of the
// largest (in scaled units) are left out.
struct NullCombination {
  std::vector<Eigen::Index> columns;
  std::vector<double> coefficients;
  std::string text;  // e.g. "+1·dZB1 −1·dl1"
};

// A basis of the null space of the scaled design, brought to reduced row
// echelon form so each combination has a distinct leading parameter and as
// few terms as the basis allows.
std::vector<NullCombination> null_space_combinations(const Eigen::MatrixXd& H,
                                                     const std::vector<std::string>& names = {},
                                                     double rcond = kDefaultRcond);

// Columns whose unit vector has a component in the null space (‖row_j(N)‖ >
// 1e-7 of the scaled null basis N): the parameters that are not identifiable.
std::vector<Eigen::Index> unidentifiable_columns(const Eigen::MatrixXd& H, double rcond = kDefaultRcond);

// ---- what measurement would make it identifiable ----------------------------

// The physics of a null-space combination v (H·v = 0 on the measured poses):
// the design rows of the same measurements at poses moved along one degree
// of freedom show whether v stays invisible. If moving the orientation makes
// H·v ≠ 0 but moving the position does not, v is a combination only a change
// of orientation separates (e.g. a base hinge offset and the platform hinge
// offset that, at one orientation, shifts the leg end by the same vector), so
// the hint is "add poses with different orientations"; if only a change of
// height reveals it, "add poses at another height (another layer)".

// One measurement's design rows at a pose (x, y, z mm; rx, ry, rz rad, as in
// the measurement CSV), in the design's units and column order. An empty
// matrix means the pose cannot be evaluated (it is skipped).
using PoseDesignRows = std::function<Eigen::MatrixXd(const Eigen::Matrix<double, 6, 1>& pose)>;

struct HintOptions {
  // The probe's moves. An exact null combination is revealed by any nonzero
  // step or by none; a near-null one (a rank tolerance above rounding, e.g.
  // the hybrid's dropped columns) shows up in proportion to the step, so the
  // steps are a clear tilt and shift rather than infinitesimal. On seed 000's
  // pure-translation design (72 near-null combinations) a tilt of 0.05 rad
  // lifts 57 of them above 2 × their baseline, 0.2 rad all 72, while moves
  // of x, y, z or rx lift 2 (docs/estimators.md).
  double translation_step = 50.0;  // mm, along x, y, z
  double rotation_step = 0.2;      // rad (≈ 11°), about x, y, z
  // A combination v counts as revealed by a probe when ‖H_probe·v‖ / ‖D·v‖
  // (D the column norms of the design at the measured poses, so the measure
  // is unit-free and ≤ √m) exceeds `visible` and `ratio` × its value at the
  // measured poses (~1e-15 for an exact null combination; about the small
  // singular value for a near-null one).
  double visible = 1e-6;
  double ratio = 2.0;
  std::size_t max_names = 12;  // parameters listed per group before "(+n more)"
  // List only each combination's leading parameter (its first column) in the
  // text, e.g. when the combinations express dropped columns through many kept ones.
  bool leading_only = false;
};

enum class PoseDof { X = 0, Y, Z, Rx, Ry, Rz };
const char* to_string(PoseDof dof);  // "x", "y", "z", "rx", "ry", "rz"

struct CombinationHint {
  NullCombination combination;
  std::vector<PoseDof> revealed_by;  // single degrees of freedom whose change makes it visible
  bool revealed_jointly = false;     // none alone, but moving all six together does
  std::string measurement;           // e.g. "add poses with different orientations (rx, ry, rz)"
};

struct IdentifiabilityHint {
  std::vector<CombinationHint> combinations;  // one per null-space combination, in order
  std::vector<std::string> parameters;        // every parameter in some combination (column order)
  std::string text;  // one line: per group of combinations, their parameters and the measurement that separates them
};

// The hint for a rank-deficient design: `null_space` (null_space_combinations
// of the design), the parameter names (column order), the measured poses and
// the design rows at a pose. Each combination is probed by moving all poses by
// HintOptions' steps along each degree of freedom; combinations revealed by
// the same degrees of freedom are grouped into one phrase, listing their
// parameters, joined by "; ", e.g.
//   "dXB1, dXP1, dXB2, dXP2: add poses with different orientations (ry, rz); dZB1, dZP1: add tilted poses (rx, ry)".
// Empty text when null_space is empty.
IdentifiabilityHint identifiability_hint(const std::vector<NullCombination>& null_space,
                                         const std::vector<std::string>& names,
                                         const std::vector<Eigen::Matrix<double, 6, 1>>& poses,
                                         const PoseDesignRows& rows, const HintOptions& options = {});

// ---- collinearity ----------------------------------------------------------

struct CollinearityOptions {
  double rcond = kDefaultRcond;
  double condition_index_threshold = 30;  // Belsley: > 30 is a strong near-dependency
  double proportion_threshold = 0.5;      // variance-decomposition proportion flagging a parameter
  // Optional "what would help" per parameter (e.g. by family from its name:
  // "measure the orientation", "add a layer at another height"). Called for
  // every unidentifiable or confounded parameter; an empty string adds nothing.
  std::function<std::string(const std::string& parameter)> hint;
};

struct ConfoundedGroup {
  Eigen::Index component = 0;          // index of the singular value
  double condition_index = 0;          // s_max / s_k
  std::vector<Eigen::Index> columns;   // parameters with proportion > threshold on it (≥ 2)
  std::vector<double> proportions;
};

struct ParameterNote {
  Eigen::Index column = 0;
  std::string name;
  std::string text;  // "X is confounded with Y, Z (...)" or "X is not identifiable: ..."
  std::string hint;  // from CollinearityOptions::hint
};

struct CollinearityReport {
  RankReport rank;                       // of the unit-column-norm design
  std::vector<std::string> names;
  // Uncentred VIF_j = 1/(1 − R_j²) = [(X̃ᵀX̃)⁺]_jj = Σ_k V_jk²/s_k² on the
  // unit-norm columns X̃ (k over the identified components); +inf for an
  // unidentifiable column.
  Eigen::VectorXd vif;
  Eigen::VectorXd condition_indices;      // s_max / s_k, k < rank
  Eigen::MatrixXd variance_proportions;   // m × rank, π_jk = (V_jk²/s_k²) / Σ_k V_jk²/s_k² (rows sum to 1)
  std::vector<ConfoundedGroup> confounded;
  std::vector<NullCombination> null_space;
  std::vector<Eigen::Index> unidentifiable;
  std::vector<ParameterNote> notes;       // one line per affected parameter
};

CollinearityReport collinearity_report(const Eigen::MatrixXd& H, const std::vector<std::string>& names = {},
                                       const CollinearityOptions& options = {});

// Human-readable: rank, condition number, observability indices, notes.
void print_collinearity_report(const CollinearityReport& report, std::ostream& out);

}  // namespace kincal::identify
