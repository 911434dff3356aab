#include "kincal/identify/effect_calibration.hpp"

#include <Eigen/QR>
#include <cmath>

#include "base_fit.hpp"
#include "kincal/identify/effects.hpp"
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
  const std::vector<std::optional<EffectNode>> nodes = effect_nodes(robot, data);
  EffectValues values;
  for (const Effect* e : list) values.values[e->name()] = VectorXd::Zero(Index(e->parameter_names(robot).size()));

  EffectCalibrationReport rep;
  detail::BaseModel base;
  EffectValues previous = values;
  bool halved = false;
  for (int pass = 0; pass < options.max_passes; ++pass) {
    const PoseTable corrected = detail::effect_corrected_table(robot, data, nodes, values.to_core(robot));
    // The base is fitted to its least-squares minimum (what the linear [H G]
    // step assumes; for the hybrid seed 000's estimate finished by
    // Gauss–Newton), here and for the final model.
    base = detail::fit_base(robot, corrected, nodes, "ols", true);
    MatrixXd H;
    VectorXd y;
    stack(base, false, H, y);
    rep.rms_cal_um.push_back(rms_um(y));
    if (list.empty()) break;
    // Alternation is not guaranteed to descend: a pass that raises the cal
    // residual is undone (halving the last update once before giving up).
    if (pass > 0 && rep.rms_cal_um.back() > rep.rms_cal_um[rep.rms_cal_um.size() - 2] * 1.0001) {
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
    // One linear step on [H G] (G: the effects' columns), column-scaled, by a
    // rank-revealing orthogonal decomposition; only the effect part is kept,
    // the base is refitted nonlinearly in the next pass.
    Index cols = H.cols();
    std::vector<MatrixXd> G;
    for (const Effect* e : list) {
      G.push_back(detail::effect_columns(robot, *e, base, false));
      cols += G.back().cols();
    }
    MatrixXd X(H.rows(), cols);
    X.leftCols(H.cols()) = H;
    Index c = H.cols();
    for (const MatrixXd& g : G) X.middleCols(c, g.cols()) = g, c += g.cols();
    VectorXd scale(cols);
    for (Index j = 0; j < cols; ++j) scale(j) = X.col(j).norm() > 0 ? X.col(j).norm() : 1.0;
    Eigen::CompleteOrthogonalDecomposition<MatrixXd> cod;
    cod.setThreshold(1e-10);
    cod.compute(X * scale.cwiseInverse().asDiagonal());
    const VectorXd delta = scale.cwiseInverse().asDiagonal() * cod.solve(y);
    // Convergence on the effect's contribution to the residual (scaled update).
    const VectorXd scaled_effect_step = (scale.asDiagonal() * delta).tail(cols - H.cols());
    c = H.cols();
    for (std::size_t i = 0; i < list.size(); ++i) {
      values.values[list[i]->name()] += delta.segment(c, G[i].cols());
      c += G[i].cols();
    }
    rep.passes = pass + 1;
    if (scaled_effect_step.norm() <= options.tolerance * std::max(1e-9, y.norm())) break;
  }
  // The base model that goes with the final effect values (the last fit in
  // the loop may belong to an update that was undone or not yet applied).
  if (!list.empty())
    base = detail::fit_base(robot, detail::effect_corrected_table(robot, data, nodes, values.to_core(robot)), nodes,
                            "ols", true);
  MatrixXd H;
  VectorXd y;
  stack(base, false, H, y);
  rep.rms_cal_um_final = rms_um(y);
  stack(base, true, H, y);
  rep.rms_test_um_final = rms_um(y);
  if (report != nullptr) *report = rep;
  CalibrationModel model = base.model;
  model.effects = values;
  model.data_file = data.file;
  return model;
}

}  // namespace kincal::identify
