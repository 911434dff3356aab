// Noise from local-linear pseudo-residuals over joint-space neighbours
// (kincal/identify/noise_estimate.hpp; docs/diagnosis.md "How kincal knows
// the noise").
#include "kincal/identify/noise_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <random>

#include <Eigen/Dense>

#include "estimate/scaled_design.hpp"

namespace kincal::identify {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

// Each node's K nearest neighbours and the weights of the local-linear
// interpolation of the node from them: Σ w = 1 and Σ w (u_j − u_i) = 0 in the
// directions the neighbours span (a grid at one orientation spans only 3 of
// the hybrid's 6 joint directions), of least Σ w² (the least noise carried
// into the pseudo-residual r_i − Σ w r_j, whose variance is σ²(1 + Σ w²)).
struct Neighbourhoods {
  std::vector<std::vector<std::size_t>> index;
  std::vector<VectorXd> weight;
  std::vector<double> inflation;  // 1 + Σ w²
  std::vector<double> distance;   // mean distance to the neighbours
  std::vector<std::size_t> nearest;
};

constexpr double kPenaltyPower = 2.0;
constexpr double kMaxLeak = 0.44;  // (1.2)² − 1
Neighbourhoods neighbourhoods(const std::vector<VectorXd>& place, std::size_t k,
                              const std::vector<VectorXd>* covariate = nullptr) {
  // Covariates over their range over the nodes (joint-space units: the
  // places are over the strokes), constrained like the places but not used
  // to choose the neighbours.
  VectorXd cov_scale;
  if (covariate != nullptr && !covariate->empty()) {
    VectorXd lo = covariate->front(), hi = covariate->front();
    for (const VectorXd& c : *covariate) lo = lo.cwiseMin(c), hi = hi.cwiseMax(c);
    cov_scale = (hi - lo).cwiseMax(1e-300).cwiseInverse();
  }
  const std::size_t n = place.size();
  Neighbourhoods out;
  out.index.resize(n), out.weight.resize(n), out.inflation.resize(n), out.distance.resize(n), out.nearest.resize(n);
  std::vector<std::pair<double, std::size_t>> d(n);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = 0; j < n; ++j) d[j] = {j == i ? HUGE_VAL : (place[j] - place[i]).squaredNorm(), j};
    const std::size_t kk = std::min(k, n - 1);
    std::partial_sort(d.begin(), d.begin() + std::ptrdiff_t(kk), d.end());
    MatrixXd D(place[i].size() + cov_scale.size(), Index(kk));
    double mean_d = 0;
    for (std::size_t m = 0; m < kk; ++m) {
      out.index[i].push_back(d[m].second);
      D.col(Index(m)).head(place[i].size()) = place[d[m].second] - place[i];
      if (cov_scale.size() > 0)
        D.col(Index(m)).tail(cov_scale.size()) =
            ((*covariate)[d[m].second] - (*covariate)[i]).cwiseProduct(cov_scale);
      mean_d += std::sqrt(d[m].first);
    }
    out.nearest[i] = d[0].second;
    out.distance[i] = mean_d / double(std::max<std::size_t>(1, kk));
    // The directions the neighbours span (singular values above a tenth of
    // the largest): constraining the others would only amplify the noise.
    const Eigen::JacobiSVD<MatrixXd> svd(D, Eigen::ComputeThinU);
    const VectorXd& s = svd.singularValues();
    Index r = 0;
    while (r < s.size() && s(r) > 0.1 * s(0)) ++r;
    MatrixXd A(1 + r, Index(kk));
    A.row(0).setOnes();
    if (r > 0) A.bottomRows(r) = svd.matrixU().leftCols(r).transpose() * D;
    VectorXd e0 = VectorXd::Zero(1 + r);
    e0(0) = 1;
    // Least Σ w_j² p_j with p_j growing with the neighbour's distance: the
    // nearer neighbours carry the interpolation, so less of a misfit's
    // curvature is left in the pseudo-residual (the weighting only trades
    // noise for bias: the standardisation below holds for any weights).
    VectorXd pinv(kk);
    const double d0 = std::max(1e-12, std::sqrt(d[0].first));
    for (std::size_t m = 0; m < kk; ++m) pinv(Index(m)) = 1.0 / std::pow(std::max(1.0, std::sqrt(d[m].first) / d0), kPenaltyPower);
    const MatrixXd AAt = A * pinv.asDiagonal() * A.transpose();
    const VectorXd w = pinv.asDiagonal() * (A.transpose() * AAt.completeOrthogonalDecomposition().solve(e0));
    out.weight[i] = w;
    out.inflation[i] = 1.0 + w.squaredNorm();
  }
  return out;
}

// Squared norm of the pseudo-residual of node i over its inflation (σ²(1 − h)·χ²_k under noise).
double standardised_pseudo(const Neighbourhoods& nb, const std::vector<VectorXd>& r, std::size_t i,
                           const std::vector<std::size_t>* perm = nullptr) {
  auto at = [&](std::size_t j) -> const VectorXd& { return r[perm ? (*perm)[j] : j]; };
  VectorXd e = at(i);
  for (std::size_t m = 0; m < nb.index[i].size(); ++m) e -= nb.weight[i](Index(m)) * at(nb.index[i][m]);
  return e.squaredNorm() / nb.inflation[i];
}

double median_of(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// Median of χ²_k, k (1 − 2 / (9k))³ (Wilson–Hilferty).
double chi2_median(double k) { return k * std::pow(1.0 - 2.0 / (9.0 * k), 3); }

// How much of a misfit smooth over the strokes the neighbourhoods leave in
// the pseudo-residuals: for every quadratic u_a·u_b of the places (what a
// global linear fit, which the base model roughly is, leaves), the energy of
// its pseudo-residuals against its own energy beyond a linear fit; the
// largest over a, b.
double quadratic_leak(const Neighbourhoods& nb, const std::vector<VectorXd>& place) {
  const std::size_t n = place.size();
  const Index dim = place.front().size();
  MatrixXd L(Index(n), dim + 1);
  for (std::size_t i = 0; i < n; ++i) L(Index(i), 0) = 1, L.row(Index(i)).tail(dim) = place[i].transpose();
  const detail::ScaledPivotedQr qr(L);
  double worst = 0;
  for (Index a = 0; a < dim; ++a)
    for (Index b = a; b < dim; ++b) {
      VectorXd f = VectorXd::Zero(Index(n));
      for (std::size_t i = 0; i < n; ++i) f(Index(i)) = place[i](a) * place[i](b);
      const VectorXd beyond = f - qr.fitted(f);
      const double energy = beyond.squaredNorm();
      if (!(energy > 1e-12 * (1 + f.squaredNorm()))) continue;
      std::vector<VectorXd> fv(n);
      for (std::size_t i = 0; i < n; ++i) fv[i] = VectorXd::Constant(1, beyond(Index(i)));
      double leak = 0;
      for (std::size_t i = 0; i < n; ++i) leak += standardised_pseudo(nb, fv, i);
      worst = std::max(worst, leak / energy);
    }
  return worst;
}

// Ranks of v, ties at their mean rank.
std::vector<double> ranks(const std::vector<double>& v) {
  std::vector<std::size_t> order(v.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return v[a] < v[b]; });
  std::vector<double> rank(v.size());
  for (std::size_t i = 0; i < order.size();) {
    std::size_t j = i;
    while (j + 1 < order.size() && v[order[j + 1]] == v[order[i]]) ++j;
    for (std::size_t m = i; m <= j; ++m) rank[order[m]] = 0.5 * double(i + j);
    i = j + 1;
  }
  return rank;
}

double spearman_rho(const std::vector<double>& a, const std::vector<double>& b) {
  const std::vector<double> ra = ranks(a), rb = ranks(b);
  const Eigen::Map<const VectorXd> x(ra.data(), Index(ra.size())), y(rb.data(), Index(rb.size()));
  const VectorXd cx = x.array() - x.mean(), cy = y.array() - y.mean();
  const double den = cx.norm() * cy.norm();
  return den > 0 ? cx.dot(cy) / den : 0.0;
}

// The pseudo-residuals `s` (standardised, per node) against each covariate's
// own standardised pseudo-residual over the same neighbourhoods: under noise
// alone independent, so a positive rank correlation says the residual moves
// with the covariate between neighbours (the strongest, Bonferroni p).
CovariateDependence covariate_dependence(const Neighbourhoods& nb, const NoiseData& data,
                                         const std::vector<double>& s) {
  CovariateDependence best;
  const std::size_t n = s.size();
  if (data.covariate.size() != n || n < 3) return best;
  const Index count = data.covariate.front().size();
  for (Index c = 0; c < count; ++c) {
    std::vector<double> away(n);
    for (std::size_t i = 0; i < n; ++i) {
      double e = data.covariate[i](c);
      for (std::size_t m = 0; m < nb.index[i].size(); ++m) e -= nb.weight[i](Index(m)) * data.covariate[nb.index[i][m]](c);
      away[i] = e * e / nb.inflation[i];
    }
    const double rho = spearman_rho(s, away);
    const double p = std::min(1.0, double(count) * 0.5 * std::erfc(rho * std::sqrt(double(n - 1)) / std::sqrt(2.0)));
    if (c == 0 || p < best.p) {
      best.name = std::size_t(c) < data.covariate_names.size() ? data.covariate_names[std::size_t(c)]
                                                                 : "covariate " + std::to_string(c + 1);
      best.rho = rho;
      best.p = p;
    }
  }
  return best;
}

std::vector<double> standardised_pseudos(const Neighbourhoods& nb, const std::vector<VectorXd>& r,
                                         const std::vector<std::size_t>* perm = nullptr) {
  std::vector<double> s(r.size());
  for (std::size_t i = 0; i < r.size(); ++i) s[i] = standardised_pseudo(nb, r, i, perm);
  return s;
}

}  // namespace

NoiseEstimate estimate_noise_in_joint_space(const NoiseData& data, const NoiseEstimateOptions& options) {
  NoiseEstimate out;
  const std::size_t n = data.place.size();
  if (n < options.min_nodes || n < 2 * options.neighbours + 1 || data.residual.size() != n) {
    out.why_not = "too few nodes (" + std::to_string(n) + ") to estimate it";
    return out;
  }
  const double k = double(data.residual.front().size());
  const double scale = 1.0 / (chi2_median(k) * std::max(1e-6, 1.0 - data.leverage));
  auto sigma_over = [&](const Neighbourhoods& nb, double& spacing) {
    spacing = median_of(nb.distance);
    return std::sqrt(median_of(standardised_pseudos(nb, data.residual)) * scale);
  };
  const std::vector<VectorXd>* cov = data.covariate.size() == n ? &data.covariate : nullptr;
  const Neighbourhoods narrow = neighbourhoods(data.place, options.neighbours, cov);
  out.neighbours = options.neighbours;
  out.sigma = sigma_over(narrow, out.spacing);
  {
    // The plain difference with the nearest neighbour (what the workspace
    // estimate did, here in joint space): ½‖r_i − r_j‖².
    std::vector<double> s(n);
    for (std::size_t i = 0; i < n; ++i) s[i] = 0.5 * (data.residual[i] - data.residual[narrow.nearest[i]]).squaredNorm();
    out.sigma_pairs = std::sqrt(median_of(s) * scale);
  }
  double spacing_wide = 0;
  out.neighbours_wide = 2 * options.neighbours;
  out.sigma_wide = sigma_over(neighbourhoods(data.place, out.neighbours_wide, cov), spacing_wide);
  if (!(out.sigma > 0)) {
    out.why_not = "the residual is zero at neighbouring nodes";
    return out;
  }
  const double ratio = out.sigma_wide / out.sigma;
  if (ratio > options.max_wide_ratio) {
    char b[200];
    std::snprintf(b, sizeof b,
                  "the residual differs between neighbouring nodes by more than noise: %.3g from the %zu nearest "
                  "nodes in joint space, %.3g from the %zu nearest",
                  out.sigma, out.neighbours, out.sigma_wide, out.neighbours_wide);
    out.why_not = b;
    return out;
  }
  // Neighbours too far apart: a misfit smooth over the strokes, of the size
  // the residual has beyond the estimate, would leave more than the estimate
  // can carry (σ² up by 44 %, σ by 20 %) in the pseudo-residuals.
  // The residual beyond a linear function of the places (which the
  // pseudo-residuals cancel exactly), per coordinate.
  // (and of the covariates, which they cancel too).
  const Index dim = data.place.front().size(), covariates = cov != nullptr ? cov->front().size() : 0;
  MatrixXd L = MatrixXd::Zero(Index(n), dim + covariates + 1), R = MatrixXd::Zero(Index(n), Index(k));
  for (std::size_t i = 0; i < n; ++i) {
    L(Index(i), 0) = 1, L.row(Index(i)).segment(1, dim) = data.place[i].transpose();
    if (covariates > 0) L.row(Index(i)).tail(covariates) = (*cov)[i].transpose();
    R.row(Index(i)) = data.residual[i].transpose();
  }
  const detail::ScaledPivotedQr linear(L);
  const double mean_square = (R - linear.fitted(R)).squaredNorm() /
                             (double(std::max<Index>(1, Index(n) - linear.rank())) * k *
                              std::max(1e-6, 1.0 - data.leverage));
  const double misfit = std::max(0.0, mean_square - out.sigma * out.sigma);
  out.leak = quadratic_leak(narrow, data.place);
  if (out.leak * misfit > kMaxLeak * out.sigma * out.sigma) {
    char b[240];
    std::snprintf(b, sizeof b,
                  "the neighbouring nodes are too far apart in joint space to cancel the residual's structure "
                  "(RMS %.3g against the estimate %.3g; a misfit smooth over the strokes could inflate it by %.0f %%)",
                  std::sqrt(mean_square), out.sigma, 100 * (std::sqrt(1 + out.leak * misfit / (out.sigma * out.sigma)) - 1));
    out.why_not = b;
    return out;
  }
  out.trusted = true;
  return out;
}

StructureTest joint_space_structure(const NoiseData& data, std::size_t neighbours, int permutations, unsigned seed) {
  StructureTest out;
  const std::size_t n = data.place.size();
  if (n < 2 * neighbours + 1 || data.residual.size() != n) return out;
  const Neighbourhoods nb = neighbourhoods(data.place, neighbours);
  double total = 0;
  for (const VectorXd& r : data.residual) total += r.squaredNorm();
  if (!(total > 0)) return out;
  auto statistic = [&](const std::vector<std::size_t>* perm) {
    double s = 0;
    for (std::size_t i = 0; i < n; ++i) s += standardised_pseudo(nb, data.residual, i, perm);
    return s / total;
  };
  out.ratio = statistic(nullptr);
  out.covariate = covariate_dependence(nb, data, standardised_pseudos(nb, data.residual));
  std::mt19937 rng(seed);
  std::vector<std::size_t> perm(n);
  std::iota(perm.begin(), perm.end(), 0);
  int as_small = 0;
  for (int p = 0; p < permutations; ++p) {
    std::shuffle(perm.begin(), perm.end(), rng);
    if (statistic(&perm) <= out.ratio) ++as_small;
  }
  out.p = double(1 + as_small) / double(1 + permutations);
  return out;
}

}  // namespace kincal::identify
