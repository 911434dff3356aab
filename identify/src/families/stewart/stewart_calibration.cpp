#include "kincal/identify/joint_limits.hpp"
#include "kincal/identify/stewart_calibration.hpp"
#include "kincal/identify/outliers.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include "kincal/identify/estimators.hpp"
#include "kincal/identify/identifiability.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/measurement_model.hpp"
#include "kincal/identify/parameters.hpp"

namespace kincal::identify {

int stewart_parameter_count(const Robot& robot) {
  return robot.stewart_description().models_leg_offsets ? kStewartLegOffsetParameterCount : kStewartParameterCount;
}

StewartErrorJacobian stewart_error_jacobian(const StewartGeometry<double>& g, const Pose<double>& pose, bool leg_offsets) {
  const Eigen::Matrix<double, 3, 6> arms = pose.R * g.platform;
  const Eigen::Matrix<double, 3, 6> legs = stewart_leg_vectors(g, pose);
  const Vec6<double> lengths = legs.colwise().norm().transpose();
  // J·twist = δ(leg length); the actual machine keeps |L_i'| = q_i + l_i', so a
  // parameter error c_i = dl_i + u_i·dB_i − u_i·(R·dP_i) needs J·twist = c.
  const Eigen::PartialPivLU<Mat6<double>> lu(stewart_jacobian(arms, legs, lengths));
  StewartErrorJacobian E(6, leg_offsets ? kStewartLegOffsetParameterCount : kStewartParameterCount);
  for (int i = 0; i < 6; ++i) {
    const Vec6<double> column = lu.solve(Vec6<double>::Unit(i));  // J⁻¹·e_i
    const Vec3<double> u = legs.col(i) / lengths(i);
    const Vec3<double> Rtu = pose.R.transpose() * u;
    for (int a = 0; a < 3; ++a) {
      E.col(7 * i + a) = column * u(a);        // dB_i
      E.col(7 * i + 4 + a) = -column * Rtu(a);  // dP_i (platform frame)
    }
    // dl_i; the leg's own length l_i = √(|L_i|² − s_i) (stewart.hpp) over |L_i|
    const double leg = g.leg_offset_sq(i) == 0 ? lengths(i) : std::sqrt(lengths(i) * lengths(i) - g.leg_offset_sq(i));
    E.col(7 * i + 3) = column * (leg / lengths(i));
    if (leg_offsets) E.col(kStewartParameterCount + i) = column / (2 * lengths(i));  // dsq_i
  }
  return E;
}

StewartGeometry<double> stewart_with_errors(const StewartGeometry<double>& nominal, const Eigen::VectorXd& theta) {
  StewartGeometry<double> g = nominal;
  for (int i = 0; i < 6; ++i) {
    g.base.col(i) += theta.segment<3>(7 * i);
    g.length_offset(i) += theta(7 * i + 3);
    g.platform.col(i) += theta.segment<3>(7 * i + 4);
    if (theta.size() > kStewartParameterCount) g.leg_offset_sq(i) += theta(kStewartParameterCount + i);
  }
  return g;
}

namespace {

struct Node {
  std::size_t line;
  std::string id;
  Vec6<double> q;
  Pose<double> measured;
};

std::vector<Node> calibration_nodes(const Robot& nominal, const PoseTable& data) {
  if (!data.has_measured)
    throw InputError(data.file, 1, 0, "needs the measured pose columns mx,my,mz,mrx,mry,mrz to calibrate a 6-UPS");
  std::vector<Node> nodes;
  for (const PoseRow& r : data.rows) {
    if (r.role != Role::Cal || !r.measured) continue;
    Node n{r.line, r.id, Vec6<double>::Zero(), Pose<double>::from_xyz_rpy(*r.measured)};
    if (r.q) {
      n.q = r.q->head<6>();
    } else {
      const Status s = nominal.inverse(Pose<double>::from_xyz_rpy(r.commanded), n.q);
      if (s != Status::Ok)
        throw InputError(data.file, r.line, 0,
                         "row '" + r.id + "': nominal IK of the commanded pose failed (" + to_string(s) +
                             "); give the joint commands q1..q6 or drop the row");
    }
    nodes.push_back(n);
  }
  // 7 nodes give 42 equations for 42 parameters: an exact fit, with nothing
  // left to estimate the noise, the standard errors or an outlier (it failed
  // further on, though the message said 7 were enough).
  if (nodes.size() < 8)
    throw InputError(data.file, 0, 0,
                     "only " + std::to_string(nodes.size()) +
                         " calibration nodes with a measured pose; the 42-parameter model needs at least 8 "
                         "(6 equations each, seed 001 Section 3, and some left over for the noise) and a "
                         "well-spread set of poses");
  return nodes;
}

// Rows of one node are weighted: rotations × kOrientationWeightMm
// (measurement_model.hpp) so both halves are in mm at the platform (a rad and
// a mm are not commensurable otherwise).

// The damped step (calibrate_stewart): a trial machine whose weighted RSS is
// more than this many times the last one's is a step too far; the step is
// halved at most kMaxHalvings times (2^-30 of a step is below any error).
constexpr double kDivergence = 4.0;
constexpr int kMaxHalvings = 30;

}  // namespace

namespace {

// A rank-deficient design: name the parameters, the null-space combinations,
// and the poses that would separate them (identifiability_hint probes the
// error Jacobian at the measured poses moved along each degree of freedom).
[[noreturn]] void throw_rank_deficient(const PoseTable& data, const std::vector<Eigen::Matrix<double, 6, 1>>& poses,
                                       const StewartGeometry<double>& g, const Eigen::MatrixXd& H,
                                       const std::vector<std::string>& names, Eigen::Index rank) {
  std::string which;
  for (const Eigen::Index j : unidentifiable_columns(H)) which += (which.empty() ? "" : ", ") + names[std::size_t(j)];
  const bool leg_offsets = H.cols() > kStewartParameterCount;
  const PoseDesignRows rows = [&g, leg_offsets](const Eigen::Matrix<double, 6, 1>& pose) -> Eigen::MatrixXd {
    Eigen::MatrixXd E = stewart_error_jacobian(g, Pose<double>::from_xyz_rpy(pose), leg_offsets);
    E.bottomRows<3>() *= kOrientationWeightMm;
    if (!E.allFinite()) return {};
    return E;
  };
  const IdentifiabilityHint hint = identifiability_hint(null_space_combinations(H, names), names, poses, rows);
  throw InputError(data.file, 0, 0,
                   "the calibration poses do not determine all " + std::to_string(names.size()) + " parameters (rank " + std::to_string(rank) +
                       "); not identifiable: " + which + ". To separate them: " + hint.text);
}

}  // namespace

StewartCalibration calibrate_stewart(const Robot& nominal, const PoseTable& data, const StewartCalibrationOptions& options) {
  if (!nominal.is_stewart()) throw InputError("the seed 001 calibration is for 6-UPS (stewart-6ups) robots");
  if (options.estimator.kind == EstimatorKind::Liu)
    throw InputError("the 6-UPS calibration (seed 001) offers the estimators ols, ridge and pcr; liu is seed 000's "
                     "estimator for the hybrid's fine stage");
  // Measured rows are modelled without the file's limits (joint_limits.hpp):
  // the machine was there. MODEL.json keeps the robot as given (stewart_model).
  const Robot open = without_limits(nominal);
  const std::vector<Node> nodes = calibration_nodes(open, data);
  const int m = stewart_parameter_count(nominal);
  const bool leg_offsets = nominal.stewart_description().models_leg_offsets;
  const Eigen::Index n = Eigen::Index(6 * nodes.size());
  const std::vector<std::string> names = parameter_names(nominal);

  StewartCalibration out;
  out.nodes = nodes.size();
  out.estimator = options.estimator;
  out.theta = Eigen::VectorXd::Zero(m);
  Eigen::MatrixXd H(n, m);
  Eigen::VectorXd y(n);
  std::vector<Eigen::Matrix<double, 6, 1>> at(nodes.size());  // where E was evaluated (for a rank-deficiency hint)
  // Steps 3–4 / 7–8: poses of the machine believed at θ, and the residual
  // pose errors dQ = QM − QC with their design E. The FK of each node starts
  // where the machine was measured. Returns the index of the first node whose
  // FK fails (nodes.size() when none does).
  std::string why;  // the status of a node whose FK failed
  auto linearise = [&](const StewartGeometry<double>& g, StewartIteration& rec) {
    double sum_p2 = 0;
    rec.max_dq_int = 0;
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      Pose<double> predicted;
      const FkReport<double> r = stewart_fk(g, nodes[k].q, nodes[k].measured, predicted);
      if (r.status != Status::Ok) {
        why = to_string(r.status);
        return k;
      }
      const Twist<double> dq = pose_error(nodes[k].measured, predicted);
      const Eigen::Index row = Eigen::Index(6 * k);
      H.middleRows<6>(row) = stewart_error_jacobian(g, predicted, leg_offsets);
      at[k] = predicted.to_xyz_rpy();
      y.segment<6>(row) = dq;
      H.middleRows<3>(row + 3) *= kOrientationWeightMm;
      y.segment<3>(row + 3) *= kOrientationWeightMm;
      rec.max_dq_int = std::max(rec.max_dq_int, dq.head<3>().norm() + dq.tail<3>().norm());
      sum_p2 += dq.head<3>().squaredNorm();
    }
    rec.rms_position_mm = std::sqrt(sum_p2 / double(nodes.size()));
    return nodes.size();
  };
  LinearProblem last_problem;
  std::optional<PreparedDesign> last_design;
  Eigen::VectorXd accepted = out.theta;  // θ of the last machine every node's FK reached
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(m);
  double accepted_rss = 0;
  for (int it = 0;; ++it) {
    // Damped step (issue #11 item 2): θ = accepted + t·δ with t = 1 (seed
    // 001's full correction) unless the machine at that θ leaves a node
    // without an FK solution or the weighted residual grows more than
    // kDivergence-fold — a step into a region the linearisation at the last
    // machine does not describe, as from millimetre errors before a
    // machine's first calibration. Then t is halved (backtracking along the
    // Gauss–Newton direction) until the step is acceptable.
    StewartIteration rec;
    rec.iteration = it;
    double t = 1;
    StewartGeometry<double> g;
    for (int halving = 0;; ++halving) {
      out.theta = accepted + t * delta;
      g = stewart_with_errors(open.stewart(), out.theta);
      const std::size_t failed = linearise(g, rec);
      const bool ok = failed == nodes.size();
      if (ok && (it == 0 || !options.damped || y.squaredNorm() <= kDivergence * accepted_rss)) break;
      if (it == 0 || !options.damped)  // the nominal machine itself: nothing to damp
        throw InputError(data.file, nodes[failed].line, 0,
                         "row '" + nodes[failed].id + "': FK of the " + (it == 0 ? "nominal" : "corrected") +
                             " machine failed (" + why + ") from the measured pose; check the robot description "
                             "and the row");
      if (halving == kMaxHalvings)
        throw InputError(data.file, ok ? 0 : nodes[failed].line, 0,
                         std::string("the identification found no step from iteration ") + std::to_string(it) +
                             " that keeps every node's FK converging" +
                             (ok ? "" : " (row '" + nodes[failed].id + "': " + why + ")") +
                             "; the machine is far from its description: check the robot file's geometry");
      t *= 0.5;
    }
    accepted = out.theta;
    accepted_rss = y.squaredNorm();
    if (it > 0) {  // the step taken from the last iteration's machine
      out.history.back().step_norm *= t;
      out.history.back().step_fraction = t;
    }
    // Step 5: the linear estimate (identify/estimators: SVD, rank judged on
    // the column-scaled design; never normal equations). Linearised at θ, the
    // measured pose error relative to the nominal machine is dQ + E·θ ≈ E·θ_true,
    // so the estimator is applied to that total: OLS gives θ + Δθ_OLS, seed
    // 001's correction, exactly; ridge and PCR shrink (resp. truncate) θ
    // itself. Applied to the step Δθ instead they would only damp the
    // iteration, which would still converge to the OLS solution.
    LinearProblem problem;
    problem.H = H;
    problem.y = y + H * out.theta;
    problem.names = names;
    problem.row_node.resize(std::size_t(n));
    for (Eigen::Index r = 0; r < n; ++r) problem.row_node[std::size_t(r)] = r / 6;
    // One factorisation of H per iteration: rank, estimate and, after the
    // last iteration, the outlier statistics. An OLS iteration steps by the
    // QR's solution alone; the SVD of R (the estimate's standard errors, the
    // other estimators) is formed at the iteration that ends the loop (#13:
    // it was 4 of the 10 M instructions of each iteration).
    const bool ols = options.estimator.kind == EstimatorKind::Ols;
    PreparedDesign::Options po;
    po.require_full_rank = false;
    po.defer_svd = ols;
    PreparedDesign design(problem, po);
    if (design.rank() < m) throw_rank_deficient(data, at, g, H, names, design.rank());
    bool estimated = design.svd_complete();
    if (estimated) out.fit = estimate(design, problem, options.estimator);
    Eigen::VectorXd x = estimated ? out.fit.x : design.ols_solution(problem.y);
    delta = x - out.theta;
    // Step 6 / 10: correct and repeat until the correction is negligible
    // (a negligible one is taken whole, as seed 001 does).
    const bool last = delta.norm() <= options.step_tolerance * (1 + x.norm()) || it + 1 >= options.max_iterations;
    if (last && !estimated) {
      design.complete_svd();
      out.fit = estimate(design, problem, options.estimator);
      x = out.fit.x;
      delta = x - out.theta;
      estimated = true;
    }
    if (estimated) {
      out.sigma_mm = std::sqrt(out.fit.sigma2_unbiased);
      out.standard_error = out.fit.standard_error;
    }
    out.rank = int(design.rank());
    out.condition_number = design.scaled_condition_number();
    problem.y = y;  // the outlier test below is on the residuals at the solution
    last_problem = std::move(problem);
    last_design = std::move(design);
    rec.step_norm = delta.norm();
    out.history.push_back(rec);
    if (last) {
      out.theta = x;
      break;
    }
  }
  // Nodes inconsistent with the others (a mis-seated reflector, a mistyped
  // row): deleted-node F test at the solution, Bonferroni over the nodes.
  // Reported, never silently excluded.
  const OutlierReport outliers = detect_outliers(*last_design, last_problem);
  add_node_tests(outliers, nodes, out.node_tests, out.outliers);
  out.outlier_p_threshold = outliers.p_threshold;
  out.outlier_report = outliers;
  out.final_problem = std::move(last_problem);
  return out;
}

StewartOutlierSearch stewart_outlier_search(const Robot& nominal, const PoseTable& data,
                                            const StewartCalibration& all, const StewartCalibrationOptions& options) {
  SequentialOutlierOptions so;
  so.min_nodes = nominal.outlier_min_nodes();
  ScreenedFit<StewartCalibration> s = screen_and_refit(
      data, all, [](const StewartCalibration& c) -> const LinearProblem& { return c.final_problem; },
      [](const StewartCalibration& c) -> const std::vector<NodeTest>& { return c.node_tests; },
      [&](const PoseTable& rest) { return calibrate_stewart(nominal, rest, options); }, so);
  return outlier_search_of(std::move(s));
}

PoseErrorReport stewart_residuals(const Robot& nominal_robot, const Robot& calibrated, const PoseTable& data) {
  // Residuals of measured rows: no joint limits (joint_limits.hpp).
  const Robot nominal = without_limits(nominal_robot), robot = without_limits(calibrated);
  PoseTable predicted = data;  // "commanded" := the model's prediction, so pose_errors gives measured − predicted
  std::vector<UnevaluatedRow> unevaluated;
  for (PoseRow& r : predicted.rows) {
    if (!r.measured) continue;
    Vec6<double> q;
    if (r.q) {
      q = r.q->head<6>();
    } else if (const Status s = nominal.inverse(Pose<double>::from_xyz_rpy(r.commanded), q); s != Status::Ok) {
      unevaluated.push_back({r.id, r.line, "nominal IK of the commanded pose failed (" + std::string(to_string(s)) + ")"});
      r.measured.reset();
      continue;
    }
    Pose<double> pose;
    if (const Status s = stewart_fk(robot.stewart(), q, Pose<double>::from_xyz_rpy(*r.measured), pose).status;
        s != Status::Ok) {
      unevaluated.push_back({r.id, r.line, "FK of the model failed (" + std::string(to_string(s)) + ")"});
      r.measured.reset();
      continue;
    }
    r.commanded = pose.to_xyz_rpy();
  }
  PoseErrorReport report = pose_errors(predicted);
  report.skipped -= unevaluated.size();
  report.unevaluated = std::move(unevaluated);
  return report;
}

CalibrationModel stewart_model(const Robot& nominal, const StewartCalibration& c, const std::string& data_file) {
  CalibrationModel model;
  model.nominal = nominal;
  model.estimator = to_string(c.estimator.kind);
  model.settings = estimator_settings(c.fit, c.estimator);
  model.settings["iterations"] = double(c.history.size());
  model.settings["orientation_weight_mm"] = kOrientationWeightMm;
  model.data_file = data_file;
  const std::vector<std::string> names = parameter_names(nominal);
  for (int j = 0; j < stewart_parameter_count(nominal); ++j)
    model.parameters.push_back({names[std::size_t(j)], c.theta(j), c.standard_error(j), true});
  return model;
}

}  // namespace kincal::identify
