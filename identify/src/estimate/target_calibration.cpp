#include "kincal/identify/target_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>

#include "kincal/identify/decompositions.hpp"
#include "kincal/identify/identifiability.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/joint_limits.hpp"
#include "kincal/identify/measurement_model.hpp"
#include "kincal/identify/outliers.hpp"
#include "kincal/identify/target_measurement.hpp"
#include "estimate/least_squares_step.hpp"
#include "estimate/scaled_design.hpp"
#include "families/family.hpp"
#include "families/family_errors.hpp"

namespace kincal::identify {

namespace {

using detail::NodeGuess;
using detail::FamilyErrors;
using detail::TargetLayout;

// A rotation's share in a weak combination: 1 rad ≙ 1 m, the size of the
// machines this is for.
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
  TargetPoints measured;        // targets
  Pose<double> measured_pose;   // full poses
  NodeGuess guess;  // guess.pose: the model's pose at q, last found
};

// What a node measures: the targets (3 rows each) or the full pose (6 rows,
// rotations weighted: measurement_model.hpp's kOrientationWeightMm).
struct Reading {
  bool pose = false;
  int targets = 0;
  Eigen::Index rows() const { return pose ? 6 : 3 * targets; }
};

Reading reading_of(const PoseTable& data) {
  return reads_full_poses(data) ? Reading{true, 0} : Reading{false, data.target_columns()};
}

const Vec6<double>& pose_weights() {
  static const Vec6<double> w =
      (Vec6<double>() << 1, 1, 1, kOrientationWeightMm, kOrientationWeightMm, kOrientationWeightMm).finished();
  return w;
}

// measured − model: the targets' positions, or the weighted pose error twist.
Eigen::VectorXd node_residual(const Reading& reading, const TargetNode& node, const Pose<double>& registration,
                              const Pose<double>& pose, const std::vector<Vec3<double>>& targets) {
  if (reading.pose) return pose_weights().asDiagonal() * pose_error(node.measured_pose, pose);
  return (node.measured - predicted_targets(registration, pose, targets)).reshaped();
}

void require_targets(const Robot& nominal, const PoseTable& data) {
  if (reads_full_poses(data)) return;  // the pose is the measurement: no targets
  if (nominal.targets.empty())
    throw InputError(data.file, 1, 0,
                     "the table has target columns t1x..; the robot description needs the targets' nominal positions "
                     "on the " + std::string(nominal.target_body()) +
                         ": add the key `targets` (docs/formats.md)");
  if (int(nominal.targets.size()) != data.target_columns())
    throw InputError(data.file, 1, 0,
                     "the table measures " + std::to_string(data.target_columns()) + " target(s), the robot description's "
                         "`targets` name " + std::to_string(nominal.targets.size()));
}

// Enough nodes for the free parameters, with some left for the noise.
void require_enough_nodes(std::size_t nodes, int free_parameters, const Robot& robot, const PoseTable& data) {
  const Reading reading = reading_of(data);
  const std::size_t rows_per_node = std::size_t(reading.rows());
  const std::size_t needed = std::size_t(free_parameters) / rows_per_node + 3;
  if (nodes < needed)
    throw InputError(data.file, 0, 0,
                     "only " + std::to_string(nodes) + " calibration nodes with " +
                         (reading.pose ? "measured poses; " : "target positions; ") +
                         std::to_string(free_parameters) + " free parameters measured by " +
                         std::to_string(rows_per_node) + " coordinates per node need at least " +
                         std::to_string(needed) + " (and poses that also turn the " +
                         robot.target_body() + ")");
}

std::vector<TargetNode> target_nodes(const Robot& open, const FamilyErrors& family, const PoseTable& data) {
  const Reading reading = reading_of(data);
  std::vector<TargetNode> nodes;
  for (const PoseRow& r : data.rows) {
    if (r.role != Role::Cal || !has_fit_measurement(r, reading.pose) || !usable(r)) continue;
    const Pose<double> commanded = Pose<double>::from_xyz_rpy(r.commanded);
    TargetNode n{r.line,
                 r.id,
                 Vec6<double>::Zero(),
                 reading.pose ? TargetPoints(3, 0) : TargetPoints(r.targets->leftCols(reading.targets)),
                 reading.pose ? Pose<double>::from_xyz_rpy(*r.measured) : Pose<double>{},
                 family.start(commanded)};
    if (const Status s = row_commands(open, r, n.q); s != Status::Ok)
      throw InputError(data.file, r.line, 0,
                       "row '" + r.id + "': nominal IK of the commanded pose failed (" + to_string(s) +
                           "); give the joint commands q1..q6 or drop the row");
    nodes.push_back(std::move(n));
  }
  return nodes;
}

// The nodes' poses on the nominal machine.
void nominal_poses(const FamilyErrors& family, const PoseTable& data, std::vector<TargetNode>& nodes) {
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(family.size());
  Pose<double> pose;
  for (TargetNode& node : nodes)
    if (!family.pose(zero, node.q, node.guess, pose))
      throw InputError(data.file, node.line, 0,
                       "row '" + node.id + "': FK of the nominal machine failed from the commanded pose; check the "
                       "robot description and the row");
}

// The rigid fit of the targets at the nodes' poses onto the measured ones.
Pose<double> registration_of(const std::vector<TargetNode>& nodes, const std::vector<Vec3<double>>& targets) {
  const Eigen::Index k = Eigen::Index(targets.size());
  TargetPoints from(3, k * Eigen::Index(nodes.size())), to(3, k * Eigen::Index(nodes.size()));
  for (std::size_t j = 0; j < nodes.size(); ++j) {
    from.middleCols(k * Eigen::Index(j), k) = predicted_targets({}, nodes[j].guess.pose, targets);
    to.middleCols(k * Eigen::Index(j), k) = nodes[j].measured;
  }
  return rigid_fit(from, to);
}

// The design rows of one pose over the full x (3k × layout.size()): the
// family's errors through the measurement map (H = M·B, seed 000 Eq. (10)
// with the targets' M), then the instrument's own columns. A full pose: the
// family's errors alone, M = diag(I, kOrientationWeightMm·I).
Eigen::MatrixXd full_design_rows(const FamilyErrors& family, const Eigen::VectorXd& errors,
                                 const Pose<double>& registration, const std::vector<Vec3<double>>& targets,
                                 const Pose<double>& pose, const TargetLayout& layout, const Reading& reading) {
  if (reading.pose) return pose_weights().asDiagonal() * family.twist_columns(errors, pose);
  const Eigen::Index rows = 3 * layout.targets;
  Eigen::MatrixXd X(rows, layout.size());
  X.leftCols(layout.family) = MeasurementModel::targets(targets, registration).design(pose, family.twist_columns(errors, pose));
  const Eigen::MatrixXd inst = instrument_columns(registration, pose, targets);
  if (layout.registration) X.middleCols(layout.registration_at(), 6) = inst.leftCols<6>();
  X.middleCols(layout.targets_at(), 3 * layout.targets) = inst.rightCols(3 * layout.targets);
  return X;
}

// The convention's null space N (x = N·φ keeps every convention row zero).
Eigen::MatrixXd null_space(const Eigen::MatrixXd& C, Eigen::Index columns) {
  if (C.rows() == 0) return Eigen::MatrixXd::Identity(columns, columns);
  // Rows that each hold one column at zero (the hybrid's selection): the
  // other columns themselves, so φ is those parameters, unmixed.
  if (((C.array() != 0).rowwise().count() == 1).all()) {
    const Eigen::VectorXd held = C.cwiseAbs().colwise().sum().transpose();
    Eigen::MatrixXd N = Eigen::MatrixXd::Zero(columns, columns - (held.array() > 0).count());
    for (Eigen::Index j = 0, c = 0; j < columns; ++j)
      if (held(j) == 0) N(j, c++) = 1.0;
    return N;
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(C, Eigen::ComputeFullV);
  svd.setThreshold(kRankThreshold);
  return svd.matrixV().rightCols(columns - svd.rank());
}

std::vector<std::string> full_names(const FamilyErrors& family, const TargetLayout& layout) {
  std::vector<std::string> names = family.names();
  if (layout.registration)
    for (const char* c : {"reg_x", "reg_y", "reg_z", "reg_rx", "reg_ry", "reg_rz"}) names.push_back(c);
  for (int k = 1; k <= layout.targets; ++k)
    for (const char* c : {"x", "y", "z"}) names.push_back("t" + std::to_string(k) + c);
  return names;
}

// Rotational components of x (the registration's rotation) in mm at 1 m.
Eigen::VectorXd unit_weights(const TargetLayout& layout) {
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

bool uses_target_model(const Robot& robot, const PoseTable& data) {
  if (!data.has_targets && !data.has_measured) return false;  // nothing to fit: the callers' checks say so
  return family_of(robot).pipeline_reading(robot, data) == nullptr;
}

bool reads_full_poses(const PoseTable& data) { return !data.has_targets && data.has_measured; }

TargetCalibration calibrate_targets(const Robot& nominal, const PoseTable& data, const TargetCalibrationOptions& options) {
  require_targets(nominal, data);
  const Robot open = without_limits(nominal);  // measured rows: the machine was there (joint_limits.hpp)
  const std::unique_ptr<FamilyErrors> family = detail::family_errors(open);
  const Reading reading = reading_of(data);
  const TargetLayout layout{family->size(), reading.targets, data.in_instrument_frame};
  const Eigen::Index rows = reading.rows();

  TargetCalibration out;
  out.full_pose = reading.pose;
  out.instrument_frame = data.in_instrument_frame;
  if (!reading.pose) out.targets = nominal.targets;
  out.names = family->names();
  out.convention = family->convention();
  // The nominal machine's poses, then (in the instrument frame) the
  // registration that best lays the nominal targets onto the measured ones.
  // The node count is checked against the parameters before the convention
  // (which needs the nodes' design: the instrument's columns at least) and
  // again after it.
  std::vector<TargetNode> nodes = target_nodes(open, *family, data);
  require_enough_nodes(nodes.size(), 6 * int(layout.registration) + 3 * layout.targets, nominal, data);
  nominal_poses(*family, data, nodes);
  if (out.instrument_frame) out.registration = registration_of(nodes, out.targets);
  const Eigen::Index n = rows * Eigen::Index(nodes.size());
  Eigen::VectorXd errors = Eigen::VectorXd::Zero(layout.family);
  Eigen::MatrixXd X(n, layout.size());
  for (std::size_t k = 0; k < nodes.size(); ++k)
    X.middleRows(rows * Eigen::Index(k), rows) =
        full_design_rows(*family, errors, out.registration, out.targets, nodes[k].guess.pose, layout, reading);
  Eigen::MatrixXd C = family->convention_rows(layout, X, std::numeric_limits<double>::infinity());
  Eigen::MatrixXd N;
  int p = 0;
  auto set_convention = [&]() {
    N = null_space(C, layout.size());
    p = int(N.cols());
    out.free_parameters = p;
    out.convention_basis = N;
    out.fitted.assign(std::size_t(layout.family), false);
    for (Eigen::Index j = 0; j < layout.family; ++j) out.fitted[std::size_t(j)] = N.row(j).norm() > 1e-12;
    require_enough_nodes(nodes.size(), p, nominal, data);
  };
  set_convention();
  const std::vector<std::string> names = full_names(*family, layout);

  // The descent (least_squares_step.hpp) on φ, x = N·φ.
  struct State {
    Eigen::VectorXd errors;
    Pose<double> registration;
    std::vector<Vec3<double>> targets;
    std::vector<NodeGuess> guesses;  // guesses[k].pose: node k's pose at `errors`
  };
  State accepted{errors, out.registration, out.targets, {}};
  for (const TargetNode& node : nodes) accepted.guesses.push_back(node.guess);
  State current = accepted;
  Eigen::VectorXd residual(n);
  auto evaluate = [&]() -> detail::Evaluation {
    std::size_t reached = 0;
    double rss = 0;
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      Pose<double> pose;
      if (!family->pose(current.errors, nodes[k].q, current.guesses[k], pose)) continue;
      const Eigen::VectorXd r = node_residual(reading, nodes[k], current.registration, pose, current.targets);
      residual.segment(rows * Eigen::Index(k), rows) = r;
      rss += r.squaredNorm();
      ++reached;
    }
    // A node the machine cannot reach is worse than any residual.
    return {reached == nodes.size() ? rss : std::numeric_limits<double>::infinity(), reached};
  };
  auto linearise = [&](Eigen::MatrixXd& design, Eigen::VectorXd& y) {
    for (std::size_t k = 0; k < nodes.size(); ++k)
      X.middleRows(rows * Eigen::Index(k), rows) =
          full_design_rows(*family, current.errors, current.registration, current.targets, current.guesses[k].pose,
                           layout, reading);
    // No convention rows (full poses): N is the identity, and the product a
    // 600 × 66 × 66 one per step of a 6-RUS fit for X itself.
    if (C.rows() == 0)
      design = X;
    else
      design = X * N;
    y = residual;
  };
  auto apply = [&](const Eigen::VectorXd& dphi) {
    const Eigen::VectorXd dx = N * dphi;
    current.errors += dx.head(layout.family);
    if (layout.registration)
      current.registration = moved_registration(current.registration, dx.segment<6>(layout.registration_at()));
    for (int k = 0; k < layout.targets; ++k) current.targets[std::size_t(k)] += dx.segment<3>(layout.targets_at() + 3 * k);
  };
  int iteration = 0;
  auto record = [&]() {
    TargetIteration rec;
    rec.iteration = iteration++;
    rec.rms_position_mm = std::sqrt(residual.squaredNorm() / double(n));
    rec.step_norm = (current.errors - accepted.errors).norm();
    out.history.push_back(rec);
  };
  auto descend = [&]() {
    const detail::DescentCount count = detail::damped_gauss_newton(
        options.max_iterations, evaluate, [&] { accepted = current; record(); }, [&] { current = accepted; },
        linearise, apply);
    if (count.linearisations == 0)
      throw InputError(data.file, 0, 0,
                       "the nominal machine does not reach every calibration node from its commands; check the "
                       "robot description");
  };
  descend();
  // The model at the accepted state: its design and residual, for the
  // statistics below.
  evaluate();
  Eigen::MatrixXd A;
  Eigen::VectorXd y;
  linearise(A, y);
  // The convention again, now that the residual is known (family_errors.hpp):
  // where it holds fewer parameters, the fit continues from here with them.
  {
    Eigen::MatrixXd C_fitted = family->convention_rows(layout, X, std::sqrt(residual.squaredNorm() / double(n)));
    if (C_fitted.rows() != C.rows() || C_fitted != C) {
      C = std::move(C_fitted);
      set_convention();
      descend();
      evaluate();
      linearise(A, y);
    }
  }
  out.errors = current.errors;
  out.registration = current.registration;
  out.targets = current.targets;

  // Rank, conditioning, covariance: the SVD of the column-scaled design,
  // the rank by the rule of the descent's own steps (scaled_design.hpp).
  // Without the statistics the singular values alone decide the rank; V,
  // half of the SVD's cost, is computed only where the check fails, to name
  // the combination.
  const detail::ScaledDesign scaled(A, options.statistics);
  const Eigen::VectorXd& s = scaled.singular_values();
  out.condition_number = scaled.condition_number();
  out.rank = int(scaled.rank());
  out.nodes = nodes.size();
  out.sigma_mm = std::sqrt(y.squaredNorm() / double(std::max<Eigen::Index>(1, n - p)));
  auto directions = [&]() -> Eigen::MatrixXd { return N * scaled.directions(); };  // x per singular direction
  if (out.rank < p) {
    const Eigen::MatrixXd NV = directions();
    const WeakCombination w = weakest_combinations(NV.col(p - 1) * NV.col(p - 1).transpose(), unit_weights(layout),
                                                   names, 1).front();
    throw InputError(data.file, 0, 0,
                     "the calibration poses do not determine the model from " +
                         (reading.pose ? std::string("full poses") : std::to_string(layout.targets) + " target(s)") +
                         " (rank " + std::to_string(out.rank) + " of " + std::to_string(p) +
                         "); not determined: " + describe(w) + ". Poses that also turn the " +
                         nominal.target_body() + ", or more targets, separate them");
  }
  if (!options.statistics) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    out.standard_error = Eigen::VectorXd::Constant(layout.family, nan);
    out.registration_standard_error.setConstant(nan);
    out.target_standard_error.assign(std::size_t(layout.targets), Vec3<double>::Constant(nan));
    return out;
  }
  const Eigen::MatrixXd NV = directions();
  const Eigen::MatrixXd covariance =
      out.sigma_mm * out.sigma_mm * NV * s.array().square().inverse().matrix().asDiagonal() * NV.transpose();
  const Eigen::VectorXd se = covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  out.standard_error = se.head(layout.family);
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
  const std::unique_ptr<FamilyErrors> family = detail::family_errors(open);
  std::vector<TargetNode> nodes = target_nodes(open, *family, data);
  nominal_poses(*family, data, nodes);
  return registration_of(nodes, nominal.targets);
}

std::vector<std::optional<TargetRowModel>> target_rows(const Robot& nominal, const TargetCalibration& c,
                                                       const std::vector<TargetRowInput>& rows) {
  const std::unique_ptr<FamilyErrors> family = detail::family_errors(nominal);
  const TargetLayout layout{family->size(), int(c.targets.size()), c.instrument_frame};
  const Reading reading{c.full_pose, layout.targets};
  std::vector<std::optional<TargetRowModel>> out;
  for (const TargetRowInput& row : rows) {
    NodeGuess guess = family->start(row.commanded);
    TargetRowModel m;
    if (!family->pose(c.errors, row.q, guess, m.pose)) {
      out.emplace_back();
      continue;
    }
    if (reading.pose) {
      m.residual = pose_weights().asDiagonal() * pose_error(row.measured_pose, m.pose);
      m.M = pose_weights().asDiagonal();
      m.pose_rows = true;
    } else {
      const MeasurementModel tracker = MeasurementModel::targets(c.targets, c.registration);
      m.residual = row.measured.leftCols(layout.targets).reshaped() - tracker.predict(m.pose);
      m.M = tracker.map(m.pose);
    }
    m.H = full_design_rows(*family, c.errors, c.registration, c.targets, m.pose, layout, reading) * c.convention_basis;
    out.emplace_back(std::move(m));
  }
  return out;
}

TargetOutlierSearch target_outlier_search(const Robot& nominal, const PoseTable& data, const TargetCalibration& all,
                                          const TargetCalibrationOptions& options) {
  SequentialOutlierOptions so;
  so.min_nodes = std::max<Eigen::Index>(8, Eigen::Index(all.free_parameters) / reading_of(data).rows() + 3);
  ScreenedFit<TargetCalibration> s = screen_and_refit(
      data, all, [](const TargetCalibration& c) -> const LinearProblem& { return c.final_problem; },
      [](const TargetCalibration& c) -> const std::vector<NodeTest>& { return c.node_tests; },
      [&](const PoseTable& rest) { return calibrate_targets(nominal, rest, options); }, so);
  return outlier_search_of(std::move(s));
}

PoseErrorReport target_residuals(const Robot& nominal_in, const Eigen::VectorXd& errors,
                                 const Pose<double>& registration, const std::vector<Vec3<double>>& targets,
                                 const PoseTable& data) {
  const Robot nominal = without_limits(nominal_in);
  const std::unique_ptr<FamilyErrors> family = detail::family_errors(nominal);
  const Reading reading = reading_of(data);
  std::vector<PoseErrorRow> rows;
  std::vector<UnevaluatedRow> unevaluated;
  std::size_t skipped = 0;
  for (const PoseRow& r : data.rows) {
    if (!has_fit_measurement(r, reading.pose) || !usable(r)) {
      ++skipped;
      continue;
    }
    Vec6<double> q;
    Pose<double> pose;
    if (const Status s = row_commands(nominal, r, q); s != Status::Ok) {
      unevaluated.push_back({r.id, r.line, "nominal IK of the commanded pose failed (" + std::string(to_string(s)) + ")"});
      continue;
    }
    NodeGuess guess = family->start(Pose<double>::from_xyz_rpy(r.commanded));
    if (!family->pose(errors, q, guess, pose)) {
      unevaluated.push_back({r.id, r.line, "FK of the model failed"});
      continue;
    }
    if (reading.pose) {  // one row per pose, its whole error
      PoseErrorRow row;
      row.id = r.id;
      row.group = data.has_layer && r.layer ? "layer " + std::to_string(*r.layer) : "";
      row.role = r.role;
      row.error = pose_error(Pose<double>::from_xyz_rpy(*r.measured), pose);
      rows.push_back(std::move(row));
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
  report.target_points = !reading.pose;
  return report;
}

CalibrationModel target_model(const Robot& nominal, const TargetCalibration& c, const std::string& data_file) {
  CalibrationModel model;
  model.nominal = nominal;
  model.estimator = "ols";
  model.settings["iterations"] = double(c.history.size());
  model.settings["targets"] = double(c.targets.size());
  model.settings["instrument_frame"] = c.instrument_frame ? 1.0 : 0.0;
  if (c.full_pose) model.settings["orientation_weight_mm"] = kOrientationWeightMm;
  model.data_file = data_file;
  for (std::size_t j = 0; j < c.names.size(); ++j)
    model.parameters.push_back({c.names[j], c.errors(Eigen::Index(j)), c.standard_error(Eigen::Index(j)), c.fitted[j]});
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
