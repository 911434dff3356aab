#include "kincal/identify/effect_calibration.hpp"

#include <Eigen/QR>
#include <Eigen/SVD>
#include <cmath>
#include <map>
#include <optional>

#include "base_fit.hpp"
#include "kincal/identify/effects.hpp"
#include "kincal/identify/estimators.hpp"
#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

double rms_um(const VectorXd& v) { return v.size() > 0 ? std::sqrt(v.squaredNorm() / double(v.size())) * 1000.0 : 0.0; }

// Residual and base design of one role, stacked.
void stack(const detail::BaseModel& base, bool test, MatrixXd& H, VectorXd& y) {
  Index rows = 0;
  for (const detail::NodeData& n : base.nodes)
    if (n.test == test) rows += n.r.size();
  H.resize(rows, base.parameters);
  y.resize(rows);
  Index r = 0;
  for (const detail::NodeData& n : base.nodes) {
    if (n.test != test) continue;
    H.middleRows(r, n.r.size()) = n.H;
    y.segment(r, n.r.size()) = n.r;
    r += n.r.size();
  }
}

// [H G]: the base design and the columns of the effect parameters not held.
MatrixXd joint_design(const Robot& robot, const std::vector<const Effect*>& list,
                      const std::map<std::string, std::vector<bool>>& held, const detail::BaseModel& base,
                      const MatrixXd& H) {
  std::vector<MatrixXd> G;
  Index cols = H.cols();
  for (const Effect* e : list) {
    G.push_back(detail::effect_columns(robot, *e, base, false));
    for (bool h : held.at(e->name())) cols += h ? 0 : 1;
  }
  MatrixXd X(H.rows(), cols);
  X.leftCols(H.cols()) = H;
  Index c = H.cols();
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::vector<bool>& h = held.at(list[i]->name());
    for (Index j = 0; j < G[i].cols(); ++j)
      if (!h[std::size_t(j)]) X.col(c++) = G[i].col(j);
  }
  return X;
}

// The free effect parameter with the largest p-value of its t test in the
// joint least-squares fit at the solution (t² ~ F(1, n − rank)); a parameter
// whose column is zero or lies in the span of the others (p = 1) first.
// With the hybrid's ridge base the test still uses the unpenalised design:
// it asks whether the data can tell the parameter from every base
// combination, not only from those the penalty allows.
std::optional<HeldParameter> least_significant(const Robot& robot, const std::vector<const Effect*>& list,
                                               const std::map<std::string, std::vector<bool>>& held,
                                               const EffectValues& values, const detail::BaseModel& base) {
  MatrixXd H;
  VectorXd y;
  stack(base, false, H, y);
  const MatrixXd X = joint_design(robot, list, held, base, H);
  const Index free = X.cols() - H.cols();
  if (free == 0 || X.rows() == 0) return std::nullopt;
  VectorXd scale(X.cols());
  for (Index j = 0; j < X.cols(); ++j) scale(j) = X.col(j).norm() > 0 ? X.col(j).norm() : 1.0;
  const Eigen::JacobiSVD<MatrixXd> svd(X * scale.cwiseInverse().asDiagonal(), Eigen::ComputeThinV);
  const VectorXd& sv = svd.singularValues();
  Index rank = 0;
  while (rank < sv.size() && sv(rank) > 1e-10 * sv(0)) ++rank;
  const double dof = double(X.rows() - rank);
  if (dof < 1) return std::nullopt;
  // The residual at the solution (y itself: the base is at its minimum for
  // these effect values, and the effect step has converged).
  const double sigma2 = y.squaredNorm() / dof;
  std::optional<HeldParameter> worst;
  Index c = H.cols();
  for (const Effect* e : list) {
    const std::vector<std::string> names = e->parameter_names(robot);
    const std::vector<bool>& h = held.at(e->name());
    for (std::size_t j = 0; j < names.size(); ++j) {
      if (h[j]) continue;
      HeldParameter p{e->name(), names[j], j, 0.0, 1.0, std::size_t(free)};
      // Variance of the scaled coefficient: Σ_k V_ck² / σ_k² over the rank;
      // a column with a part outside the rank (collinear) is not identified.
      const VectorXd v = svd.matrixV().row(c).transpose();
      const double outside = v.tail(v.size() - rank).squaredNorm();
      if (X.col(c).norm() > 0 && outside < 1e-12) {
        const double var = (v.head(rank).array().square() / sv.head(rank).array().square()).sum() * sigma2;
        p.t = values.values.at(e->name())(Index(j)) * scale(c) / std::sqrt(var);
        p.p_value = f_distribution_upper_tail(p.t * p.t, 1.0, dof);
      }
      if (!worst || p.p_value > worst->p_value) worst = p;
      ++c;
    }
  }
  return worst;
}

// The alternation of the header comment from `values` (warm start): fit
// the base on the effect-corrected data, one joint linear step on [H G] for
// the effects, repeat. Parameters with held[e][j] stay where they are (their
// columns are left out of the step).
detail::BaseModel alternate(const Robot& robot, const PoseTable& data, const std::vector<std::optional<EffectNode>>& nodes,
                            const std::vector<const Effect*>& list, const std::map<std::string, std::vector<bool>>& held,
                            const EffectCalibrationOptions& options, EffectValues& values, EffectCalibrationReport& rep,
                            double& ridge_k) {
  const std::string base_estimator = options.estimator == "ridge" ? "ridge" : "ols";
  detail::BaseModel base;
  EffectValues previous = values;
  bool halved = false;
  const std::size_t first = rep.rms_cal_um.size();
  for (int pass = 0; pass < options.max_passes; ++pass) {
    const PoseTable corrected = detail::effect_corrected_table(robot, data, nodes, values.to_core(robot));
    // The base is fitted to its least-squares minimum (what the linear [H G]
    // step assumes; for the hybrid seed 000's estimate finished by
    // Gauss–Newton), here and for the final model.
    base = detail::fit_base(robot, corrected, nodes, base_estimator, true, ridge_k);
    ridge_k = base.ridge_k;
    MatrixXd H;
    VectorXd y;
    stack(base, false, H, y);
    rep.rms_cal_um.push_back(rms_um(y));
    if (list.empty()) break;
    // Alternation is not guaranteed to descend: a pass that raises the cal
    // residual is undone (halving the last update once before giving up).
    if (rep.rms_cal_um.size() > first + 1 && rep.rms_cal_um.back() > rep.rms_cal_um[rep.rms_cal_um.size() - 2] * 1.0001) {
      for (auto& [name, v] : values.values) v = previous.values.at(name) + 0.5 * (v - previous.values.at(name));
      if (halved) {
        values = previous;
        break;
      }
      halved = true;
      rep.rms_cal_um.back() = rep.rms_cal_um[rep.rms_cal_um.size() - 2];
      continue;
    }
    previous = values;
    halved = false;
    // One linear step on [H G] (G: the effects' free columns), column-scaled,
    // by a rank-revealing orthogonal decomposition; only the effect part is
    // kept, the base is refitted nonlinearly in the next pass.
    MatrixXd X = joint_design(robot, list, held, base, H);
    if (ridge_k > 0) {
      // The base's penalty rows √k·(χ − χ_coarse): the step minimises the
      // same objective as the base fit (effects unpenalised).
      const Index p = base.parameters, n = X.rows();
      X.conservativeResize(n + p, Eigen::NoChange);
      X.bottomRows(p).setZero();
      X.bottomLeftCorner(p, p) = std::sqrt(ridge_k) * MatrixXd::Identity(p, p);
      y.conservativeResize(n + p);
      y.tail(p) = -std::sqrt(ridge_k) * base.column_away;
    }
    const VectorXd delta = detail::scaled_least_squares(X, y);
    // Convergence on the effect's contribution to the residual (scaled update).
    VectorXd scaled_effect_step = delta.tail(X.cols() - H.cols());
    for (Index j = 0; j < scaled_effect_step.size(); ++j) scaled_effect_step(j) *= X.col(H.cols() + j).norm();
    Index c = H.cols();
    for (const Effect* e : list) {
      VectorXd& v = values.values[e->name()];
      const std::vector<bool>& h = held.at(e->name());
      for (Index j = 0; j < v.size(); ++j)
        if (!h[std::size_t(j)]) v(j) += delta(c++);
    }
    rep.passes += 1;
    if (scaled_effect_step.norm() <= options.tolerance * std::max(1e-9, y.norm())) break;
  }
  // The base model that goes with the final effect values (the last fit in
  // the loop may belong to an update that was undone or not yet applied).
  if (!list.empty())
    base = detail::fit_base(robot, detail::effect_corrected_table(robot, data, nodes, values.to_core(robot)), nodes,
                            base_estimator, true, ridge_k);
  return base;
}

}  // namespace

CalibrationModel calibrate_with_effects(const Robot& robot, const PoseTable& data, const std::vector<std::string>& effects,
                                        const EffectCalibrationOptions& options, EffectCalibrationReport* report) {
  std::vector<const Effect*> list;
  for (const std::string& name : effects) {
    const Effect* e = find_effect(name);
    if (e == nullptr) throw InputError("--effects: unknown effect '" + name + "' (known: " + effect_names() + ")");
    const std::string missing = e->missing_inputs(data);
    if (!missing.empty()) throw InputError(data.file, 0, 0, "effect '" + name + "' cannot be identified: " + missing);
    list.push_back(e);
  }
  if (!options.estimator.empty() && options.estimator != "ols" &&
      !(options.estimator == "ridge" && robot.is_hybrid()))
    throw InputError("--estimator " + options.estimator + " with --effects: the base is fitted by " +
                     (robot.is_hybrid() ? "ols (default) or ridge" : "ols (seed 001's iterated least squares)"));
  if (!(options.ridge_k >= 0)) throw InputError("--ridge-k must be a number >= 0 (0: by GCV)");
  const std::vector<std::optional<EffectNode>> nodes = effect_nodes(robot, data);
  EffectValues values;
  std::map<std::string, std::vector<bool>> held;
  for (const Effect* e : list) {
    const std::size_t k = e->parameter_names(robot).size();
    values.values[e->name()] = VectorXd::Zero(Index(k));
    held[e->name()].assign(k, false);
  }

  EffectCalibrationReport rep;
  // Hybrid ridge base: k as given, else chosen by GCV in the first base fit,
  // then kept (every pass minimises the same objective).
  double ridge_k = options.ridge_k;
  detail::BaseModel base = alternate(robot, data, nodes, list, held, options, values, rep, ridge_k);
  // Backward elimination: an effect parameter the data cannot tell from the
  // base and the other effect parameters (|t| not significant, Bonferroni
  // over the free ones) is held at 0 and the fit repeated. Left free, such a
  // parameter wanders with the noise along a nearly collinear combination
  // and drags the base with it (the hybrid's UPS-actuator scale moved an
  // encoder offset 6 mm on the wrist-scale data, beyond the table's bound).
  while (options.alpha > 0 && !list.empty()) {
    const std::optional<HeldParameter> weakest = least_significant(robot, list, held, values, base);
    if (!weakest || weakest->p_value * double(weakest->free_parameters) < options.alpha) break;
    held[weakest->effect][weakest->index] = true;
    values.values[weakest->effect](Index(weakest->index)) = 0.0;
    rep.held.push_back(*weakest);
    base = alternate(robot, data, nodes, list, held, options, values, rep, ridge_k);
  }
  MatrixXd H;
  VectorXd y;
  stack(base, false, H, y);
  rep.rms_cal_um_final = rms_um(y);
  rep.final_problem.H = joint_design(robot, list, held, base, H);
  rep.final_problem.y = y;
  for (const detail::NodeData& n : base.nodes) {
    if (n.test) continue;
    const PoseRow& row = data.rows[n.row];
    for (Index k = 0; k < n.r.size(); ++k) rep.final_problem.row_node.push_back(Index(rep.nodes.size()));
    rep.nodes.push_back({row.id, row.line, 0.0, 1.0, true, false});
  }
  stack(base, true, H, y);
  rep.rms_test_um_final = rms_um(y);
  if (report != nullptr) *report = rep;
  CalibrationModel model = base.model;
  model.effects = values;
  model.data_file = data.file;
  return model;
}

}  // namespace kincal::identify
