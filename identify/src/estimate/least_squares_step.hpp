// The least-squares step of every Gauss–Newton iteration on the host side
// (private to identify/): the base fits, the joint fit of base and effects,
// the hybrid fine stage's re-linearisation.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cstddef>
#include <limits>
#include <optional>

#include "kincal/identify/decompositions.hpp"

namespace kincal::identify::detail {

// Least squares on the column-scaled design by a rank-revealing complete
// orthogonal decomposition (columns in mm and rad, or per unit of an effect
// input, differ by orders of magnitude; never the normal equations): a zero
// column or one in the span of the others gets the minimum-norm share (0).
// The rank by kRankThreshold on the decomposition's pivots (scaled_design.hpp,
// the one rule). One factorisation, any number of solves.
class ScaledLeastSquares {
 public:
  explicit ScaledLeastSquares(const Eigen::MatrixXd& X);
  Eigen::VectorXd solve(const Eigen::VectorXd& y) const;
  Eigen::Index rank() const { return cod_.rank(); }
  // The mean leverage of rows Xt (not among X's): the variance of x_tᵀ·δ̂
  // over σ² (δ̂ = solve(y), y of noise σ) averaged over the rows — what the
  // estimate's spread adds to a held-out residual's variance, σ²(1 + h).
  double mean_leverage(const Eigen::MatrixXd& Xt) const;
  // Held-out rows Xt and their residual rt = y_t − Xt·δ̂: rtᵀ·(I + Xt·C·Xtᵀ)⁻¹·rt,
  // C·σ² the estimate's covariance — the residual's squared norm in the
  // metric of its own covariance over σ², χ²(rows) under a complete model
  // with noise σ (Chow's predictive test; with mean_leverage's (1 + h) alone
  // a few far-extrapolated rows make the sum's tail heavier than χ²'s).
  double prediction_chi2(const Eigen::MatrixXd& Xt, const Eigen::VectorXd& rt) const;

 private:
  // T⁻ᵀ·(Z·Pᵀ·S_tᵀ)₁..ᵣ for the column-scaled held-out rows S_t: its
  // columns' squared norms are the rows' leverages, and Bᵀ·B = S_t·S⁺·S⁺ᵀ·S_tᵀ.
  Eigen::MatrixXd held_out_factor(const Eigen::MatrixXd& Xt) const;
  Eigen::VectorXd scale_;
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod_;
};

// The same least squares for a fixed design X0 extended by a few columns G at
// a time, min ‖y − [X0, G]·δ‖ (the diagnosis's candidate effects against the
// current model, issue #13: "adding columns to a QR"). X0·D0⁻¹ = Q·R0 once, by
// a blocked Householder QR without pivoting; per G only Qᵀ·G·D_G⁻¹ = [G1; G2]
// and a QR of G2 = Q2·R2, and the rank-revealing decomposition of the small
// compressed design [[R0, G1], [0, R2]] (p0 + k square). An orthogonal
// transform of the column-scaled [X0, G]: its column norms, so the pivots,
// the rank and the minimum-norm solution are ScaledLeastSquares([X0, G])'s,
// rounding aside. Designs less than twice as tall as wide go that way.
class AppendedColumnsLeastSquares {
 public:
  explicit AppendedColumnsLeastSquares(const Eigen::MatrixXd& X0);
  // The minimum-norm δ (X0's coefficients first) and the rank of [X0, G];
  // in `shares` (if given) shares_in_span(G), from the same Qᵀ·G.
  Eigen::VectorXd solve(const Eigen::MatrixXd& G, const Eigen::VectorXd& y, Eigen::Index& rank,
                        Eigen::VectorXd* shares = nullptr) const;
  // Per column g of G: ‖P·g‖² / ‖g‖² (0 for g = 0), P the orthogonal
  // projector on the span of X0 at ScaledLeastSquares(X0)'s rank — the share
  // of g the design already explains (the diagnosis's "confounded"). From
  // the same QR: the span of X0 is Q·range(R0), and range(R0) is read off a
  // rank-revealing decomposition of the p0-square R0 (its pivots are those
  // of X0·D0⁻¹: an orthogonal transform keeps the column norms).
  Eigen::VectorXd shares_in_span(const Eigen::MatrixXd& G) const;

 private:
  Eigen::MatrixXd X0_;
  Eigen::VectorXd scale0_;
  Eigen::HouseholderQR<Eigen::MatrixXd> qr0_;
  // R0's rank-revealing QR (rows ≥ columns only); rank0_ < p0: X0 is
  // rank-deficient and the share is taken on its first rank0_ directions.
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> r0_;
  Eigen::Index rank0_ = 0;
  // The share of a column g = Q·[t; b] given t (its first p0 coordinates)
  // and ‖g‖².
  double share_of(const Eigen::VectorXd& QtG_top, double g2) const;
};

// ScaledLeastSquares(X).solve(y): the one solve of every Gauss–Newton step
// of the base and effect fits, and of the diagnosis's nested fits.
Eigen::VectorXd scaled_least_squares(const Eigen::MatrixXd& X, const Eigen::VectorXd& y);
// The same step with Levenberg–Marquardt's damping λ on the scaled columns
// (Marquardt's scaling: min ‖y − X·δ‖² + λ‖D·δ‖², D the column norms): a
// step that shrinks the poorly determined directions far more than the
// well-determined ones, where halving a Gauss–Newton step shrinks all alike.
// λ = 0 is the undamped step above.
Eigen::VectorXd scaled_least_squares(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, double damping);

// Every step of one linearisation of a damped descent (damped_gauss_newton):
// the undamped step and the damped ones after refusals, from one
// factorisation. On the column-scaled design S = X·D⁻¹ the normal matrix
// N = SᵀS by a symmetric rank update (level-3 products) and its Cholesky
// factor, each solve corrected by one step of iterative refinement
// (r = y − S·z, z += N⁻¹·(Sᵀr − λ·z)): the corrected semi-normal equations,
// as accurate as a QR of S while cond(S)²·ε < 1 (Björck, Numerical Methods
// for Least Squares Problems, §2.5). Taken where N's reciprocal condition
// estimate exceeds 1e-12, i.e. cond(S) below about 10⁶ — the hybrid's base
// designs have 1.7e5; otherwise the undamped step is
// scaled_least_squares(X, y)'s (rank-revealing, minimum norm). A damped
// N + λ·I is always that well conditioned (λ ≥ 1e-3 against unit columns).
// A Householder QR of the 882 × 48 design is ~7.5 M instructions, the normal
// matrix ~1 M: a descent of 8 solves paid 60 M for its steps (#13).
class DescentStep {
 public:
  DescentStep(const Eigen::MatrixXd& X, const Eigen::VectorXd& y);
  // The step δ for damping λ (0: undamped), in X's units.
  Eigen::VectorXd solve(double damping) const;
  // Whether the undamped step comes from the normal equations (else from
  // the rank-revealing decomposition of S).
  bool normal_equations() const { return normal_ok_; }

 private:
  Eigen::VectorXd refined(const Eigen::LLT<Eigen::MatrixXd>& llt, double damping) const;
  Eigen::VectorXd scale_;
  Eigen::MatrixXd S_;
  Eigen::VectorXd y_, Sty_;
  Eigen::MatrixXd N_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
  bool normal_ok_ = false;
};

// Levenberg–Marquardt's damping schedule around a Gauss–Newton iteration: 0
// (the plain step) while steps descend; after a step that does not, 1e-3 and
// then ×10 per refusal; ÷10 per accepted step, back to 0 below 1e-6.
struct Damping {
  double lambda = 0;
  static constexpr double kLargest = 1e8;  // beyond it no step descends: stop
  void accepted() { lambda = lambda / 10 < 1e-6 ? 0.0 : lambda / 10; }
  bool refused() {  // false: give up
    lambda = lambda == 0 ? 1e-3 : 10 * lambda;
    return lambda <= kLargest;
  }
};

// The descent every hybrid fit runs (the base fit, the joint fit of base and
// effects): Gauss–Newton, with Levenberg–Marquardt's damping after a step
// that does not lower the objective or loses a node the start modelled.
//   evaluate()       the model at the current iterate: {objective, nodes}
//   save(), restore() the accepted iterate
//   linearise(X, y)  the design and residual (penalty rows included) at the
//                    iterate just evaluated and accepted
//   apply(delta)     iterate += delta
// Stops when the undamped step would lower the objective by less than a
// millionth (below the noise of any data set by far), when a damped step
// gains less than a thousandth (the valley is flat along what the undamped
// step wanted: the hybrid's base chasing a thermal drift it lacks gained
// 1.4 % in 40 such steps), when no damping up to Damping::kLargest
// descends, or after `max_iterations` evaluations. Ends at the accepted
// iterate (restored). Returns how many linearisations it made and how many
// of their steps it took, and whether the iterate it ends at is the one it
// linearised last (then the caller's design rows of that linearisation
// belong to the solution and need not be formed again).
struct DescentCount {
  int linearisations = 0, steps = 0;
  bool ends_linearised = false;
};
struct Evaluation {
  double objective;
  std::size_t nodes;
};
template <class Evaluate, class Save, class Restore, class Linearise, class Apply>
DescentCount damped_gauss_newton(int max_iterations, Evaluate evaluate, Save save, Restore restore,
                                 Linearise linearise, Apply apply) {
  DescentCount count;
  Damping damping;
  double accepted_objective = std::numeric_limits<double>::infinity();
  Eigen::MatrixXd X;
  Eigen::VectorXd y;
  std::optional<DescentStep> step;  // the last linearisation's, for its damped retries
  std::size_t modelled = 0;  // nodes the start models: a step that loses one is no better
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    const Evaluation at = evaluate();
    if (iteration == 0) modelled = at.nodes;
    if (!(at.objective <= accepted_objective) || at.nodes < modelled) {  // not lower: undone, damped more
      restore();
      if (!step || !damping.refused()) break;
      apply(step->solve(damping.lambda));
      continue;
    }
    const bool crawling = damping.lambda > 0 && accepted_objective - at.objective < 1e-3 * accepted_objective;
    if (iteration > 0) damping.accepted();
    accepted_objective = at.objective;
    save();
    count.ends_linearised = false;
    if (crawling) break;
    linearise(X, y);
    count.ends_linearised = true;
    step.emplace(X, y);
    const Eigen::VectorXd delta = step->solve(damping.lambda);
    ++count.linearisations;
    if (damping.lambda == 0 && (X * delta).squaredNorm() <= 1e-6 * y.squaredNorm()) break;
    apply(delta);
    ++count.steps;
  }
  restore();
  return count;
}

}  // namespace kincal::identify::detail
