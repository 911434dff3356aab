// The measurement noise from the residual of a fit, without the residual's
// own level (docs/diagnosis.md "How kincal knows the noise"; issue #31).
//
// An unmodelled effect raises the residual, so its RMS cannot stand for the
// noise. Differences between neighbouring nodes cancel a misfit only as far
// as the misfit is the same at both: a plain difference of two neighbours
// keeps the misfit's gradient times their distance, which on the hybrid
// (wrist angles that differ a lot between workspace neighbours) made a 2 µm
// instrument look like 22.8 µm. Here each node's residual is compared with
// the local-linear interpolation of its nearest neighbours in JOINT space
// (the commands normalised by each joint's stroke): a misfit that is a smooth
// function of the joints cancels to first order, only its curvature over the
// neighbourhood is left (multivariate difference-based variance estimation,
// Munk et al. 2005; in one dimension the pseudo-residuals of Gasser, Sroka &
// Jennen-Steinmetz 1986).
//
// Whether the estimate can be trusted is decided by the data: the same
// estimate over a neighbourhood twice as large must agree with it (a misfit
// whose curvature leaks in grows with the neighbourhood; noise does not).
//
// The same neighbours give a σ-free test of structure: under noise alone a
// node's residual is no closer to its neighbours' interpolation than to that
// of random nodes (a permutation test).
//
// A residual that also follows a recorded covariate the places leave out
// (the temperature of each row; issue #33: rods expanding on a 6-RUS at
// random temperatures) differs between joint-space neighbours by the
// covariate's difference, whatever the neighbourhood's size: the estimate
// took 24 µm of thermal misfit for a 2 µm instrument, and the
// wide-against-narrow test could not see it. So the interpolation is also
// exact for linear functions of the covariates (the neighbours are still
// chosen in joint space): a misfit linear in the temperature at each place
// cancels to first order too (4.2 µm there).
//
// The structure test asks the same of the final residual, σ-free: under
// noise alone a node's pseudo-residual (over joint-space neighbours only) is
// independent of how far its covariate is from its neighbours'
// interpolation of it; a positive rank correlation between the two
// (Spearman, one-sided) is structure that follows the covariate.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace kincal::identify {

// Per node: its place in joint space (any dimension; the diagnosis uses the
// commanded joints over each joint's stroke) and its residual coordinates of
// one kind (any units; one σ for all of them).
struct NoiseData {
  std::vector<Eigen::VectorXd> place;
  std::vector<Eigen::VectorXd> residual;
  // Mean leverage p / rows of the fit that left the residual (its variance is
  // σ²(1 − h)); 0 for raw data.
  double leverage = 0;
  // Per node, recorded covariates outside the places (any units: each is
  // taken over its range over the nodes), named in covariate_names; empty:
  // none.
  std::vector<Eigen::VectorXd> covariate;
  std::vector<std::string> covariate_names;
};

// The strongest dependence of the pseudo-residuals on a covariate's own
// pseudo-residual: Spearman's ρ and its one-sided p (normal approximation,
// ρ·√(n − 1)); p = 1 when there are no covariates.
struct CovariateDependence {
  std::string name;
  double rho = 0;
  double p = 1;
};

struct NoiseEstimate {
  double sigma = 0;        // from the local-linear pseudo-residuals of the nearest neighbours
  double sigma_wide = 0;   // the same over twice as many neighbours
  double sigma_pairs = 0;  // from the nearest neighbour alone (a plain difference), for comparison
  double spacing = 0;      // median distance to the neighbours used (joint-space units)
  // Share of a misfit quadratic over the places (beyond a linear fit) that
  // the neighbourhoods leave in the pseudo-residuals (the worst quadratic).
  double leak = 0;
  std::size_t neighbours = 0, neighbours_wide = 0;
  bool trusted = false;
  std::string why_not;  // when not trusted: one phrase
};

struct NoiseEstimateOptions {
  std::size_t min_nodes = 20;
  std::size_t neighbours = 12;  // the wide estimate uses twice as many
  // Trusted when sigma_wide / sigma stays below this: under noise alone the
  // ratio scatters by a few per cent (docs/diagnosis.md).
  double max_wide_ratio = 1.2;
};

NoiseEstimate estimate_noise_in_joint_space(const NoiseData& data, const NoiseEstimateOptions& options = {});

// Structure in the residual over joint-space neighbours: the mean squared
// local-linear pseudo-residual against the mean squared residual (≈ 1 under
// noise, < 1 where neighbours share a systematic part), and its permutation
// p-value (the residual vectors shuffled over the nodes; σ-free).
// With covariates, also their dependence (σ-free, as above).
struct StructureTest {
  double ratio = 1;
  double p = 1;
  CovariateDependence covariate;
};
StructureTest joint_space_structure(const NoiseData& data, std::size_t neighbours = 12, int permutations = 400,
                                    unsigned seed = 1);

}  // namespace kincal::identify
