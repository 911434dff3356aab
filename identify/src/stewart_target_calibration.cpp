#include "kincal/identify/stewart_target_calibration.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <string>

#include "kincal/identify/identifiability.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/joint_limits.hpp"
#include "kincal/identify/outliers.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/target_measurement.hpp"
#include "least_squares_step.hpp"

namespace kincal::identify {

namespace {

constexpr int kJointErrors = kStewartParameterCount;  // 42: per leg dXB dYB dZB dl dXP dYP dZP
// A rotation's share in a weak combination, and the registration's in the
// rank test: 1 rad ≙ 1 m, the size of the machines this is for.
constexpr double kRadianMm = 1000.0;

bool usable(const PoseRow& r) { return r.status.empty() || r.status == "ok"; }

// The joint commands of a row: its q1..q6, or the nominal IK of its commanded
// pose (the error-free commands that drove the machine, seed 001 §5.2).
Status row_commands(const Robot& nominal, const PoseRow& row, Vec6<double>& q) {
  if (row.q) {
    q = row.q->head<6>();
    return Status::Ok;
  }
  return nominal.inverse(Pose<double>::from_xyz_rpy(row.commanded), q);
}

struct TargetNode {
  std::size_t line;
  std::string id;
  Vec6<double> q;
  TargetPoints measured;
  Pose<double> pose;  // the model's pose at q: FK start of the next evaluation
};

void require_targets(const Robot& nominal, const PoseTable& data) {
  if (!nominal.is_stewart()) throw InputError("target measurement is implemented for the 6-UPS (stewart-6ups) so far");
  if (nominal.targets.empty())
    throw InputError(data.file, 1, 0,
                     "the table has target columns t1x..; the robot description needs the targets' nominal positions "
                     "on the platform: add the key `targets` (docs/formats.md)");
  if (int(nominal.targets.size()) != data.target_columns())
    throw InputError(data.file, 1, 0,
                     "the table measures " + std::to_string(data.target_columns()) + " target(s), the robot description's "
                         "`targets` name " + std::to_string(nominal.targets.size()));
}

std::vector<TargetNode> target_nodes(const Robot& open, const PoseTable& data, int free_parameters) {
  std::vector<TargetNode> nodes;
  for (const PoseRow& r : data.rows) {
    if (r.role != Role::Cal || !r.targets || !usable(r)) continue;
    TargetNode n{r.line, r.id, Vec6<double>::Zero(), r.targets->leftCols(data.target_columns()),
                 Pose<double>::from_xyz_rpy(r.commanded)};
    if (const Status s = row_commands(open, r, n.q); s != Status::Ok)
      throw InputError(data.file, r.line, 0,
                       "row '" + r.id + "': nominal IK of the commanded pose failed (" + to_string(s) +
                           "); give the joint commands q1..q6 or drop the row");
    nodes.push_back(std::move(n));
  }
  const std::size_t rows_per_node = 3 * std::size_t(data.target_columns());
  const std::size_t needed = std::size_t(free_parameters) / rows_per_node + 3;
  if (nodes.size() < needed)
    throw InputError(data.file, 0, 0,
                     "only " + std::to_string(nodes.size()) + " calibration nodes with target positions; " +
                         std::to_string(free_parameters) + " free parameters measured by " +
                         std::to_string(rows_per_node) + " coordinates per node need at least " +
                         std::to_string(needed) + " (and poses that also turn the platform)");
  return nodes;
}

// The rigid fit of the targets at the nodes' poses onto the measured ones.
Pose<double> registration_of(const std::vector<TargetNode>& nodes, const std::vector<Vec3<double>>& targets) {
  const Eigen::Index k = Eigen::Index(targets.size());
  TargetPoints from(3, k * Eigen::Index(nodes.size())), to(3, k * Eigen::Index(nodes.size()));
  for (std::size_t j = 0; j < nodes.size(); ++j) {
    from.middleCols(k * Eigen::Index(j), k) = predicted_targets({}, nodes[j].pose, targets);
    to.middleCols(k * Eigen::Index(j), k) = nodes[j].measured;
  }
  return rigid_fit(from, to);
}

// The nodes with the nominal machine's poses at their commands.
void nominal_poses(const Robot& open, const PoseTable& data, std::vector<TargetNode>& nodes) {
  for (TargetNode& node : nodes)
    if (const Status s = stewart_fk(open.stewart(), node.q, node.pose, node.pose).status; s != Status::Ok)
      throw InputError(data.file, node.line, 0,
                       "row '" + node.id + "': FK of the nominal machine failed (" + to_string(s) +
                           ") from the commanded pose; check the robot description and the row");
}

// Column layout of the full parameter vector x: the 42 joint errors, then
// the registration twist (instrument frame only), then 3 per target.
struct Layout {
  int targets = 0;
  bool registration = false;
  int registration_at() const { return kJointErrors; }
  int targets_at() const { return kJointErrors + (registration ? 6 : 0); }
  int size() const { return targets_at() + 3 * targets; }
};

// The design rows of one pose over the full x (3k × layout.size()): the
// joint errors through the measurement map (H = M·B, seed 000 Eq. (10) with
// the targets' M), then the instrument's own columns.
Eigen::MatrixXd full_design_rows(const StewartGeometry<double>& g, const Pose<double>& registration,
                                 const std::vector<Vec3<double>>& targets, const Pose<double>& pose,
                                 const Layout& layout) {
  const Eigen::Index rows = 3 * layout.targets;
  Eigen::MatrixXd X(rows, layout.size());
  X.leftCols(kJointErrors) = target_map(registration, pose, targets) * stewart_error_jacobian(g, pose);
  const Eigen::MatrixXd inst = instrument_columns(registration, pose, targets);
  if (layout.registration) X.middleCols(layout.registration_at(), 6) = inst.leftCols<6>();
  X.middleCols(layout.targets_at(), 3 * layout.targets) = inst.rightCols(3 * layout.targets);
  return X;
}

// The convention's null space N (x = N·φ keeps every convention row zero).
Eigen::MatrixXd convention_basis(const StewartGeometry<double>& g, const Layout& layout) {
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(layout.registration ? 12 : 6, layout.size());
  const Eigen::Matrix<double, 6, Eigen::Dynamic> platform = rigid_motion_rows(g.platform);
  const Eigen::Matrix<double, 6, Eigen::Dynamic> base = rigid_motion_rows(g.base);
  for (int i = 0; i < 6; ++i) {
    C.block<6, 3>(0, 7 * i + 4) = platform.middleCols<3>(3 * i);
    if (layout.registration) C.block<6, 3>(6, 7 * i) = base.middleCols<3>(3 * i);
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(C, Eigen::ComputeFullV);
  return svd.matrixV().rightCols(layout.size() - C.rows());
}

std::vector<std::string> full_names(const Robot& nominal, const Layout& layout) {
  std::vector<std::string> names = parameter_names(nominal);
  names.resize(kJointErrors);
  if (layout.registration)
    for (const char* c : {"reg_x", "reg_y", "reg_z", "reg_rx", "reg_ry", "reg_rz"}) names.push_back(c);
  for (int k = 1; k <= layout.targets; ++k)
    for (const char* c : {"x", "y", "z"}) names.push_back("t" + std::to_string(k) + c);
  return names;
}

// Rotational components of x (the registration's rotation) in mm at 1 m.
Eigen::VectorXd unit_weights(const Layout& layout) {
  Eigen::VectorXd w = Eigen::VectorXd::Ones(layout.size());
  if (layout.registration) w.segment<3>(layout.registration_at() + 3).setConstant(kRadianMm);
  return w;
}

std::vector<WeakCombination> weakest_combinations(const Eigen::MatrixXd& covariance, const Eigen::VectorXd& weights,
                                                  const std::vector<std::string>& names, int count) {
  const Eigen::MatrixXd W = weights.asDiagonal() * covariance * weights.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(W);
  std::vector<WeakCombination> out;
  for (int c = 0; c < count && c < int(W.rows()); ++c) {
    const Eigen::Index j = W.rows() - 1 - c;  // eigenvalues ascend
    WeakCombination w;
    w.standard_deviation_mm = std::sqrt(std::max(0.0, eig.eigenvalues()(j)));
    const Eigen::VectorXd v = eig.eigenvectors().col(j);
    for (Eigen::Index i = 0; i < v.size(); ++i)
      if (std::abs(v(i)) >= 0.1) w.terms.push_back({names[std::size_t(i)], v(i)});
    std::sort(w.terms.begin(), w.terms.end(),
              [](const auto& a, const auto& b) { return std::abs(a.second) > std::abs(b.second); });
    if (!w.terms.empty() && w.terms.front().second < 0)
      for (auto& t : w.terms) t.second = -t.second;
    out.push_back(std::move(w));
  }
  return out;
}

std::string describe(const WeakCombination& w) {
  std::string s;
  for (std::size_t i = 0; i < w.terms.size() && i < 6; ++i) {
    char term[64];
    std::snprintf(term, sizeof term, "%s%.2f*%s", i == 0 ? "" : " + ", w.terms[i].second, w.terms[i].first.c_str());
    s += term;
  }
  return s;
}

}  // namespace

StewartTargetCalibration calibrate_stewart_targets(const Robot& nominal, const PoseTable& data,
                                                   const StewartTargetOptions& options) {
  require_targets(nominal, data);
  const Robot open = without_limits(nominal);  // measured rows: the machine was there (joint_limits.hpp)
  const Layout layout{data.target_columns(), data.in_instrument_frame};
  const Eigen::MatrixXd N = convention_basis(nominal.stewart(), layout);
  const int p = int(N.cols());
  std::vector<TargetNode> nodes = target_nodes(open, data, p);
  const Eigen::Index rows = 3 * layout.targets;
  const Eigen::Index n = rows * Eigen::Index(nodes.size());
  const std::vector<std::string> names = full_names(nominal, layout);

  // The nominal machine's poses, then (in the instrument frame) the
  // registration that best lays the nominal targets onto the measured ones.
  StewartTargetCalibration out;
  out.instrument_frame = data.in_instrument_frame;
  out.nodes = nodes.size();
  out.free_parameters = p;
  out.convention_basis = N;
  out.theta = Eigen::VectorXd::Zero(kJointErrors);
  out.targets = nominal.targets;
  nominal_poses(open, data, nodes);
  if (data.in_instrument_frame) out.registration = registration_of(nodes, out.targets);

  // The descent (least_squares_step.hpp) on φ, x = N·φ.
  struct State {
    Eigen::VectorXd theta;
    Pose<double> registration;
    std::vector<Vec3<double>> targets;
    std::vector<Pose<double>> poses;
  };
  State accepted{out.theta, out.registration, out.targets, {}};
  for (const TargetNode& node : nodes) accepted.poses.push_back(node.pose);
  State current = accepted;
  Eigen::VectorXd residual(n);
  StewartGeometry<double> g;
  auto evaluate = [&]() -> detail::Evaluation {
    g = stewart_with_errors(open.stewart(), current.theta);
    std::size_t reached = 0;
    double rss = 0;
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      Pose<double> pose;
      if (stewart_fk(g, nodes[k].q, current.poses[k], pose).status != Status::Ok) continue;
      current.poses[k] = pose;
      const TargetPoints r = nodes[k].measured - predicted_targets(current.registration, pose, current.targets);
      residual.segment(rows * Eigen::Index(k), rows) = r.reshaped();
      rss += r.squaredNorm();
      ++reached;
    }
    // A node the machine cannot reach is worse than any residual.
    return {reached == nodes.size() ? rss : std::numeric_limits<double>::infinity(), reached};
  };
  Eigen::MatrixXd X(n, layout.size());
  auto linearise = [&](Eigen::MatrixXd& design, Eigen::VectorXd& y) {
    for (std::size_t k = 0; k < nodes.size(); ++k)
      X.middleRows(rows * Eigen::Index(k), rows) =
          full_design_rows(g, current.registration, current.targets, current.poses[k], layout);
    design = X * N;
    y = residual;
  };
  auto apply = [&](const Eigen::VectorXd& dphi) {
    const Eigen::VectorXd dx = N * dphi;
    current.theta += dx.head(kJointErrors);
    if (layout.registration)
      current.registration = moved_registration(current.registration, dx.segment<6>(layout.registration_at()));
    for (int k = 0; k < layout.targets; ++k) current.targets[std::size_t(k)] += dx.segment<3>(layout.targets_at() + 3 * k);
  };
  int iteration = 0;
  auto record = [&]() {
    StewartIteration rec;
    rec.iteration = iteration++;
    rec.rms_position_mm = std::sqrt(residual.squaredNorm() / double(n));
    rec.step_norm = (current.theta - accepted.theta).norm();
    out.history.push_back(rec);
  };
  const detail::DescentCount count = detail::damped_gauss_newton(
      options.max_iterations, evaluate, [&] { accepted = current; record(); }, [&] { current = accepted; },
      linearise, apply);
  if (count.linearisations == 0)
    throw InputError(data.file, 0, 0,
                     "the nominal machine does not reach every calibration node from its commands; check the robot "
                     "description");
  // The model at the accepted state: its design and residual, for the
  // statistics below.
  evaluate();
  Eigen::MatrixXd A;
  Eigen::VectorXd y;
  linearise(A, y);
  out.theta = current.theta;
  out.registration = current.registration;
  out.targets = current.targets;

  // Rank, conditioning, covariance: the SVD of the column-scaled design.
  const Eigen::VectorXd scale = A.colwise().norm().cwiseMax(1e-300).transpose();
  const Eigen::BDCSVD<Eigen::MatrixXd> svd(A * scale.cwiseInverse().asDiagonal(), Eigen::ComputeThinV);
  const Eigen::VectorXd& s = svd.singularValues();
  out.condition_number = s(0) / s(s.size() - 1);
  out.rank = int((s.array() > effective_rcond(kDefaultRcond, n, p) * s(0)).count());
  const double rss = y.squaredNorm();
  out.sigma_mm = std::sqrt(rss / double(std::max<Eigen::Index>(1, n - p)));
  const Eigen::MatrixXd Vs = scale.cwiseInverse().asDiagonal() * svd.matrixV();
  const Eigen::MatrixXd NV = N * Vs;  // x per unit of each singular direction
  if (out.rank < p) {
    const WeakCombination w = weakest_combinations(NV.col(p - 1) * NV.col(p - 1).transpose(), unit_weights(layout),
                                                   names, 1).front();
    throw InputError(data.file, 0, 0,
                     "the calibration poses do not determine the model from " + std::to_string(layout.targets) +
                         " target(s) (rank " + std::to_string(out.rank) + " of " + std::to_string(p) +
                         "); not determined: " + describe(w) + ". Poses that also turn the platform, or more targets, "
                         "separate them");
  }
  const Eigen::MatrixXd covariance =
      out.sigma_mm * out.sigma_mm * NV * s.array().square().inverse().matrix().asDiagonal() * NV.transpose();
  const Eigen::VectorXd se = covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  out.standard_error = se.head(kJointErrors);
  if (layout.registration) out.registration_standard_error = se.segment<6>(layout.registration_at());
  for (int k = 0; k < layout.targets; ++k) out.target_standard_error.push_back(se.segment<3>(layout.targets_at() + 3 * k));
  out.weakest = weakest_combinations(covariance, unit_weights(layout), names, 3);

  // Nodes inconsistent with the others: the deleted-node F test at the
  // solution (outliers.hpp), reported, never silently excluded.
  LinearProblem problem;
  problem.H = std::move(A);
  problem.y = std::move(y);
  for (Eigen::Index j = 0; j < p; ++j) problem.names.push_back("phi" + std::to_string(j));
  problem.row_node.resize(std::size_t(n));
  for (Eigen::Index r = 0; r < n; ++r) problem.row_node[std::size_t(r)] = r / rows;
  const OutlierReport outliers = detect_outliers(problem);
  add_node_tests(outliers, nodes, out.node_tests, out.outliers);
  out.outlier_p_threshold = outliers.p_threshold;
  out.outlier_report = outliers;
  out.final_problem = std::move(problem);
  return out;
}

Pose<double> nominal_registration(const Robot& nominal, const PoseTable& data) {
  require_targets(nominal, data);
  const Robot open = without_limits(nominal);
  std::vector<TargetNode> nodes = target_nodes(open, data, 0);
  nominal_poses(open, data, nodes);
  return registration_of(nodes, nominal.targets);
}

bool stewart_target_row(const Robot& nominal, const StewartTargetCalibration& c, const Vec6<double>& q,
                        const Pose<double>& guess, const Eigen::Matrix<double, 3, 3>& measured, TargetRowModel& out) {
  const Layout layout{int(c.targets.size()), c.instrument_frame};
  const StewartGeometry<double> g = stewart_with_errors(without_limits(nominal.stewart()), c.theta);
  if (stewart_fk(g, q, guess, out.pose).status != Status::Ok) return false;
  out.residual = (measured.leftCols(layout.targets) - predicted_targets(c.registration, out.pose, c.targets)).reshaped();
  out.M = target_map(c.registration, out.pose, c.targets);
  out.H = full_design_rows(g, c.registration, c.targets, out.pose, layout) * c.convention_basis;
  return true;
}

bool uses_target_model(const Robot& robot, const PoseTable& data) {
  return robot.is_stewart() && data.has_targets && (!data.has_measured || data.in_instrument_frame);
}

StewartTargetOutlierSearch stewart_target_outlier_search(const Robot& nominal, const PoseTable& data,
                                                         const StewartTargetCalibration& all,
                                                         const StewartTargetOptions& options) {
  SequentialOutlierOptions so;
  so.min_nodes = std::max<Eigen::Index>(8, Eigen::Index(all.free_parameters) / (3 * data.target_columns()) + 3);
  ScreenedFit<StewartTargetCalibration> s = screen_and_refit(
      data, all, [](const StewartTargetCalibration& c) -> const LinearProblem& { return c.final_problem; },
      [](const StewartTargetCalibration& c) -> const std::vector<NodeTest>& { return c.node_tests; },
      [&](const PoseTable& rest) { return calibrate_stewart_targets(nominal, rest, options); }, so);
  return outlier_search_of(std::move(s));
}

PoseErrorReport stewart_target_residuals(const Robot& nominal_in, const Robot& robot_in,
                                         const Pose<double>& registration, const std::vector<Vec3<double>>& targets,
                                         const PoseTable& data) {
  const Robot nominal = without_limits(nominal_in), robot = without_limits(robot_in);
  std::vector<PoseErrorRow> rows;
  std::vector<UnevaluatedRow> unevaluated;
  std::size_t skipped = 0;
  for (const PoseRow& r : data.rows) {
    if (!r.targets || !usable(r)) {
      ++skipped;
      continue;
    }
    Vec6<double> q;
    Pose<double> pose;
    if (const Status s = row_commands(nominal, r, q); s != Status::Ok) {
      unevaluated.push_back({r.id, r.line, "nominal IK of the commanded pose failed (" + std::string(to_string(s)) + ")"});
      continue;
    }
    if (const Status s = stewart_fk(robot.stewart(), q, Pose<double>::from_xyz_rpy(r.commanded), pose).status;
        s != Status::Ok) {
      unevaluated.push_back({r.id, r.line, "FK of the model failed (" + std::string(to_string(s)) + ")"});
      continue;
    }
    const TargetPoints predicted = predicted_targets(registration, pose, targets);
    for (Eigen::Index k = 0; k < predicted.cols(); ++k) {
      PoseErrorRow row;
      row.id = r.id + ":t" + std::to_string(k + 1);
      row.group = data.has_layer && r.layer ? "layer " + std::to_string(*r.layer) : "";
      row.role = r.role;
      row.error.setZero();
      row.error.head<3>() = r.targets->col(k) - predicted.col(k);
      rows.push_back(std::move(row));
    }
  }
  PoseErrorReport report = make_pose_error_report(std::move(rows), skipped);
  report.unevaluated = std::move(unevaluated);
  report.target_points = true;
  return report;
}

CalibrationModel stewart_target_model(const Robot& nominal, const StewartTargetCalibration& c,
                                      const std::string& data_file) {
  CalibrationModel model;
  model.nominal = nominal;
  model.estimator = "ols";
  model.settings["iterations"] = double(c.history.size());
  model.settings["targets"] = double(c.targets.size());
  model.settings["instrument_frame"] = c.instrument_frame ? 1.0 : 0.0;
  model.data_file = data_file;
  const std::vector<std::string> names = parameter_names(nominal);
  for (int j = 0; j < kJointErrors; ++j)
    model.parameters.push_back({names[std::size_t(j)], c.theta(j), c.standard_error(j), true});
  const Vec6<double> reg = c.registration.to_xyz_rpy();
  const char* reg_names[6] = {"reg_x", "reg_y", "reg_z", "reg_rx", "reg_ry", "reg_rz"};
  for (int j = 0; j < 6; ++j)
    model.instrument.push_back({reg_names[j], reg(j), c.registration_standard_error(j), c.instrument_frame});
  for (std::size_t k = 0; k < c.targets.size(); ++k)
    for (int a = 0; a < 3; ++a)
      model.instrument.push_back({"t" + std::to_string(k + 1) + "xyz"[a], c.targets[k](a), c.target_standard_error[k](a), true});
  return model;
}

}  // namespace kincal::identify
