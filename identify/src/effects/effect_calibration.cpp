#include "kincal/identify/effect_calibration.hpp"
#include "kincal/identify/target_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <sstream>

#include "effects/base_fit.hpp"
#include "estimate/least_squares_step.hpp"
#include "estimate/scaled_design.hpp"
#include "families/family.hpp"
#include "kincal/identify/decompositions.hpp"
#include "kincal/identify/effects.hpp"
#include "kincal/identify/estimators.hpp"
#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

std::string number(double v) {
  std::ostringstream s;
  s.precision(3);
  s << v;
  return s.str();
}

double rms_um(const VectorXd& v) { return v.size() > 0 ? std::sqrt(v.squaredNorm() / double(v.size())) * 1000.0 : 0.0; }

using detail::stack;

// [H G]: the base design and the columns of the effect parameters not held.
// The effects' columns are taken at their current `values` (a formula
// effect may be nonlinear in its parameters).
MatrixXd joint_design(const Robot& robot, const std::vector<const Effect*>& list,
                      const std::map<std::string, std::vector<bool>>& held, const detail::BaseModel& base,
                      const MatrixXd& H, const EffectValues& values) {
  std::vector<MatrixXd> G;
  Index cols = H.cols();
  const EffectParameters<double> at = values.to_core(robot);
  for (const Effect* e : list) {
    G.push_back(detail::effect_columns(robot, *e, base, false, &at));
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
  const MatrixXd X = joint_design(robot, list, held, base, H, values);
  const Index free = X.cols() - H.cols();
  if (free == 0 || X.rows() == 0) return std::nullopt;
  const detail::ScaledDesign scaled(X, true);
  const Index rank = scaled.rank();
  const double dof = double(X.rows() - rank);
  if (dof < 1) return std::nullopt;
  // The residual at the solution (y itself: the base is at its minimum for
  // these effect values, and the effect step has converged).
  const double sigma2 = y.squaredNorm() / dof;
  // Each free effect parameter with its column's index in X.
  const auto each_free = [&](auto visit) {
    Index c = H.cols();
    for (const Effect* e : list) {
      const std::vector<std::string> names = e->parameter_names(robot);
      const std::vector<bool>& h = held.at(e->name());
      for (std::size_t j = 0; j < names.size(); ++j)
        if (!h[j]) visit(*e, names[j], j, c++);
    }
  };
  // First, a parameter whose column is (to kBaseCopyShare) in the span of
  // the base design: the least outside, held whatever its t.
  {
    const detail::ScaledLeastSquares base_span(H);
    std::optional<HeldParameter> copy;
    each_free([&](const Effect& e, const std::string& name, std::size_t j, Index c) {
      const VectorXd g = X.col(c);
      if (!(g.norm() > 0)) return;
      const double outside = (g - H * base_span.solve(g)).norm() / g.norm();
      if (outside < kBaseCopyShare && (!copy || outside < copy->outside_base))
        copy = HeldParameter{e.name(), name, j, 0.0, 1.0, std::size_t(free), outside};
    });
    if (copy) return copy;
  }
  std::optional<HeldParameter> worst;
  each_free([&](const Effect& e, const std::string& name, std::size_t j, Index c) {
    HeldParameter p{e.name(), name, j, 0.0, 1.0, std::size_t(free)};
    // Variance of the scaled coefficient: Σ_k V_ck² / σ_k² over the rank;
    // a column with a part outside the rank (collinear) is not identified.
    if (X.col(c).norm() > 0 && scaled.outside_rank(c) < 1e-12) {
      const double var = scaled.scaled_variance(c) * sigma2;
      p.t = values.values.at(e.name())(Index(j)) * scaled.scale()(c) / std::sqrt(var);
      p.p_value = f_distribution_upper_tail(p.t * p.t, 1.0, dof);
    }
    if (!worst || p.p_value > worst->p_value) worst = p;
  });
  return worst;
}

// The alternation of the header comment from `values` (warm start): fit
// the base on the effect-corrected data, one joint linear step on [H G] for
// the effects, repeat. Parameters with held[e][j] stay where they are (their
// columns are left out of the step). `statistics`: of the base fit returned
// (a pass before it needs only its linearisation).
detail::BaseModel alternate(const Robot& robot, const PoseTable& data, const std::vector<std::optional<EffectNode>>& nodes,
                            const std::vector<const Effect*>& list, const std::map<std::string, std::vector<bool>>& held,
                            const EffectCalibrationOptions& options, EffectValues& values, EffectCalibrationReport& rep,
                            detail::Statistics statistics) {
  detail::BaseModel base;
  EffectValues previous = values;
  bool halved = false;
  const std::size_t first = rep.rms_cal_um.size();
  for (int pass = 0; pass < options.max_passes; ++pass) {
    const PoseTable corrected = detail::effect_corrected_table(robot, data, nodes, values.to_core(robot));
    // The base is fitted to its least-squares minimum (what the linear [H G]
    // step assumes), here and for the final model. Without effects this fit
    // is the one returned.
    base = detail::fit_base(robot, corrected, nodes, EstimatorKind::Ols, true, 0.0,
                            list.empty() ? statistics : detail::Statistics::Skipped);
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
    const MatrixXd X = joint_design(robot, list, held, base, H, values);
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
                            EstimatorKind::Ols, true, 0.0, statistics);
  return base;
}

// The base's ridge k of a joint fit at its solution: the minimiser of
// GCV(k) = n·RSS(k) / (n − df(k))² (Golub, Heath & Wahba) of the problem
// linearised there, min ‖z − X·b‖² + k·‖b_base‖² with z = r + H·(χ − χ_coarse)
// (b_base = χ − χ_coarse after the step; the effects unpenalised), over
// k = 10^-12 (OLS to rounding) … 10^4 in steps of 10^0.2. Seed 000's own
// GCV sees the data before the effects are modelled: an effect the base
// lacks looks like signal, and it chose k ≈ 1e-7 (OLS) on every data set
// with an effect; here the effect is modelled and k ≈ 0.04–0.06 on all of
// them, the clean data's value. GCV(k) in closed form for every k from one
// factorisation (PartialRidgeGcv, estimators.hpp).
double joint_gcv_k(const MatrixXd& X, const VectorXd& z, Index p) {
  const PartialRidgeGcv gcv(X, z, p);
  double best = 0, best_gcv = std::numeric_limits<double>::infinity();
  for (int e = -60; e <= 20; ++e) {
    const double k = std::pow(10.0, e / 5.0);
    const double g = gcv(k);
    if (g < best_gcv) {
      best_gcv = g;
      best = k;
    }
  }
  return best;
}

// A stepped base (the hybrid's) and the effects in one Gauss–Newton (issue
// #14; effects/base_fit.hpp's SteppedBaseFit): at each
// iterate the measurements are corrected for the effects at their current
// values, the base is evaluated there (residual, design H, the joint maps)
// and χ and the free effect parameters take one step together on [H G],
// with the base's ridge rows √k·(χ − χ_coarse) when the base is "ridge"
// (effects unpenalised). The alternation (fit the base to its minimum, then
// one step for the effects) ran the hybrid's coarse + fine pipeline in every
// pass and crept along the nearly collinear base/effect directions (the
// hybrid's compliance is 99.9 % confounded with the base); the joint step
// moves along them at once. A step that raises the objective (RSS + penalty)
// or loses a node is undone and damped (detail::damped_gauss_newton).
detail::BaseModel joint_fit(const Robot& robot, const PoseTable& data, const std::vector<std::optional<EffectNode>>& nodes,
                            const std::vector<const Effect*>& list, const std::map<std::string, std::vector<bool>>& held,
                            const EffectCalibrationOptions& options, detail::SteppedBaseFit& fit,
                            bool from_own_estimate, bool from_current, EffectValues& values,
                            EffectCalibrationReport& rep) {
  const Index p = fit.parameters();
  auto corrected = [&] { return detail::effect_corrected_table(robot, data, nodes, values.to_core(robot)); };
  fit.start(corrected(), from_own_estimate, from_current);
  fit.keep();
  EffectValues accepted_values = values;
  detail::BaseModel base;
  PoseTable table;  // the data corrected at the values last evaluated
  // The joint maps enter only the columns of joint-space effects (a thermal
  // effect's are the tool twist itself): formed where a step needs them.
  const bool joint_maps =
      std::any_of(list.begin(), list.end(), [](const Effect* e) { return e->acts_on_joints(); });
  // Gauss–Newton, with Levenberg–Marquardt's damping after a step that does
  // not lower the objective (detail::damped_gauss_newton). A trial is judged
  // by its objective alone; the design rows are formed only at the iterates
  // the descent linearises.
  const detail::DescentCount count = detail::damped_gauss_newton(
      4 * options.max_passes,
      [&] {
        table = corrected();
        std::size_t modelled = 0;
        const double objective = fit.trial_objective(table, modelled);
        return detail::Evaluation{objective, modelled};
      },
      [&] {
        fit.keep();
        accepted_values = values;
      },
      [&] {
        fit.go_back();
        values = accepted_values;
      },
      [&](MatrixXd& X, VectorXd& y) {
        base = fit.evaluate(table, joint_maps);
        MatrixXd H;
        stack(base, false, H, y);
        rep.rms_cal_um.push_back(rms_um(y));
        X = joint_design(robot, list, held, base, H, values);
        detail::append_penalty_rows(fit, X, y);
      },
      [&](const VectorXd& delta) {
        fit.step(delta.head(p));
        Index c = p;
        for (const Effect* e : list) {
          VectorXd& v = values.values[e->name()];
          const std::vector<bool>& h = held.at(e->name());
          for (Index j = 0; j < v.size(); ++j)
            if (!h[std::size_t(j)]) v(j) += delta(c++);
        }
      });
  rep.passes += count.linearisations;
  // The base at the accepted iterate, with the joint maps a caller's effect
  // columns need.
  detail::complete_at_solution(fit, corrected(), count.ends_linearised, joint_maps, base);
  fit.finish(base, data.file, rep.passes);
  return base;
}

}  // namespace

CalibrationModel calibrate_with_effects(const Robot& robot, const PoseTable& data, const std::vector<std::string>& effects,
                                        const EffectCalibrationOptions& options, EffectCalibrationReport* report) {
  return detail::calibrate_with_effects(robot, data, effects, options, report, nullptr);
}

CalibrationModel detail::calibrate_with_effects(const Robot& robot, const PoseTable& data,
                                                const std::vector<std::string>& effects,
                                                const EffectCalibrationOptions& options,
                                                EffectCalibrationReport* report, BaseModel* base_out,
                                                SteppedBaseFit* from, Statistics statistics) {
  std::vector<const Effect*> list;
  for (const std::string& name : effects) {
    const Effect* e = find_effect(robot, name);
    if (e == nullptr) throw InputError("--effects: unknown effect '" + name + "' (known: " + effect_names(robot) + ")");
    const std::string missing = e->missing_inputs(data);
    if (!missing.empty()) throw InputError(data.file, 0, 0, "effect '" + name + "' cannot be identified: " + missing);
    list.push_back(e);
  }
  // A pipeline that steps its base with the effects offers a ridge toward
  // its centre; one that alternates fits its own base by OLS, and so does
  // the target fit (the data's reader decides, not the family).
  const FamilyPipeline* pipeline = family_of(robot).pipeline_reading(robot, data);
  const bool steps_base = pipeline != nullptr && pipeline->steps_base_with_effects();
  if (options.estimator && *options.estimator != EstimatorKind::Ols &&
      !(*options.estimator == EstimatorKind::Ridge && steps_base))
    throw InputError("--estimator " + std::string(to_string(*options.estimator)) +
                     " with --effects: the base is fitted by " +
                     (steps_base ? std::string("ols (default) or ridge")
                                 : "ols (" + std::string(pipeline ? pipeline->base_fit()
                                                                  : "the target fit's Gauss-Newton") +
                                       ")"));
  if (!(options.ridge_k >= 0)) throw InputError("--ridge-k must be a number >= 0 (0: by GCV)");
  const std::vector<std::optional<EffectNode>> nodes = effect_nodes(robot, data);
  EffectValues values;
  std::map<std::string, std::vector<bool>> held;
  for (const Effect* e : list) {
    const std::size_t k = e->parameter_names(robot).size();
    values.values[e->name()] = e->start_values(robot);
    held[e->name()].assign(k, false);
  }

  EffectCalibrationReport rep;
  // A family that steps its base with the effects (the hybrid): one joint
  // Gauss–Newton of base and effects (joint_fit); its
  // base is chosen by joint_gcv_k at the OLS solution unless the options fix
  // it (ols: k = 0; ridge with --ridge-k: that k), then fitted again with
  // that k from there. Each elimination round fits OLS again and chooses k
  // again: warm starts with k kept were measured worse (compliance 3.41
  // against 2.57 µm held-out, backlash 2.34 against 2.24: GCV chose k = 0 at
  // the first solution of the compliance data and never looked again). A
  // round starts from the better of seed 000's estimate on the raw data, the
  // coarse machine and the previous round's solution (its held parameter at
  // 0): from seed 000's start alone, the damped steps of a later round could
  // stop short of the minimum (UPS-actuator scale, noise seed 5: RSS 20 %
  // above the previous round's with one parameter of t = −0.8 fewer, and the
  // base 8 mm out). Any other (the 6-UPS), and target data: the alternation,
  // whose base fit (seed 001's iterated LS, the target fit) converges in a
  // few rounds and is not shrunk.
  std::unique_ptr<detail::SteppedBaseFit> owned;
  detail::SteppedBaseFit* stepped = nullptr;
  const bool choose_k = options.estimator != EstimatorKind::Ols && !(options.ridge_k > 0);
  auto fit = [&]() {
    if (!steps_base) {  // target data: the target fit, whatever the family
      detail::BaseModel b = alternate(robot, data, nodes, list, held, options, values, rep, statistics);
      rep.base = pipeline == nullptr ? b.description : std::string(pipeline->base_fit()) + " (OLS)";
      return b;
    }
    const bool first = stepped == nullptr;
    if (first && from != nullptr && !choose_k && !(options.ridge_k > 0)) {  // OLS: as `from` was made
      stepped = from;
    } else if (first) {
      owned = pipeline->stepped_base_fit(robot, data, nodes,
                                         options.ridge_k > 0 ? EstimatorKind::Ridge : EstimatorKind::Ols, options.ridge_k);
      stepped = owned.get();
    } else {
      stepped->set_penalty(options.ridge_k);
    }
    detail::BaseModel b = joint_fit(robot, data, nodes, list, held, options, *stepped, true, !first, values, rep);
    if (!choose_k) {
      rep.base = options.ridge_k > 0 ? "ridge toward " + std::string(stepped->centre()) + ", k = " +
                                           number(options.ridge_k) + " as given"
                                     : "OLS (as asked)";
      return b;
    }
    // The ridge's centre: the family's (seed 000's coarse machine) on the
    // data as the base sees it (corrected for the effects at the OLS
    // solution). The raw data's coarse encoder offsets carry an effect's
    // mean (UPS-actuator scale: s·q̄ on each leg), and shrinking toward them
    // pulled s toward 0 (noise seed 11: s1 = 4.94e-4 for 5e-4, compensated
    // 1.77 µm; recentred 5.05e-4, 1.53 µm).
    if (!list.empty()) stepped->recentre(detail::effect_corrected_table(robot, data, nodes, values.to_core(robot)));
    MatrixXd H;
    VectorXd y;
    stack(b, false, H, y);
    const double k = joint_gcv_k(joint_design(robot, list, held, b, H, values), y + H * stepped->away(), H.cols());
    stepped->set_penalty(k);
    rep.base = "ridge toward " + std::string(stepped->centre()) + ", k = " + number(k) + " chosen by GCV on base" +
               (list.empty() ? "" : " + effects") + " at the solution (k from 1e-12, OLS, to 1e4)";
    return joint_fit(robot, data, nodes, list, held, options, *stepped, false, true, values, rep);
  };
  detail::BaseModel base = fit();
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
    // Held at its start (0 but for a formula's `start`).
    values.values[weakest->effect](Index(weakest->index)) =
        find_effect(robot, weakest->effect)->start_values(robot)(Index(weakest->index));
    rep.held.push_back(*weakest);
    base = fit();
  }
  MatrixXd H;
  VectorXd y;
  stack(base, false, H, y);
  rep.rms_cal_um_final = rms_um(y);
  rep.final_problem.H = joint_design(robot, list, held, base, H, values);
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
  if (base_out != nullptr) *base_out = std::move(base);
  return model;
}

}  // namespace kincal::identify
