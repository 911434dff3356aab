// Measurement planning (plan.hpp; docs/plan.md): candidates → design rows →
// greedy + exchange on the Bayesian D criterion → held-out poses → motion
// order, and the same numbers for a grid and a random design of the same size.
#include "kincal/identify/plan.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <optional>
#include <random>
#include <sstream>

#include "estimate/scaled_design.hpp"
#include "families/family.hpp"
#include "families/family_errors.hpp"
#include "kincal/identify/decompositions.hpp"
#include "kincal/identify/effects.hpp"
#include "kincal/identify/gauge.hpp"
#include "kincal/identify/hybrid_error_model.hpp"
#include "kincal/identify/identifiability.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/joint_limits.hpp"
#include "kincal/identify/measurement_model.hpp"
#include "kincal/identify/stewart_calibration.hpp"

namespace kincal::identify {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

// The orientation rows of a pose measurement count as the displacement a
// rotation causes kOrientationWeightMm from its axis (measurement_model.hpp),
// for the default angle noise and the prior's scale.
constexpr double kOrientationLeverMm = kOrientationWeightMm;
// A joint range wider than this is "no limit" (core's ±1e9 defaults).
constexpr double kUnbounded = 1e8;

std::string fixed(double v, int digits) {
  std::ostringstream os;
  os.setf(std::ios::fixed);
  os.precision(digits);
  os << v;
  return os.str();
}

// A pose the planner may choose.
struct Candidate {
  Vec6<double> xyzrpy = Vec6<double>::Zero();
  Vec6<double> q = Vec6<double>::Zero();
  Eigen::VectorXi dir;  // approach directions (backlash), else empty
  std::size_t line = 0;  // source line of a user candidate
  std::string id;
};

// ---------------------------------------------------------------- usable poses

class Workspace {
 public:
  Workspace(const Robot& robot, const PlanOptions& o)
      : family_(family_of(robot)), open_(without_limits(robot)), margin_(o.margin) {
    // The IK runs without the file's limits (joint_limits.hpp); they are
    // checked here, less the margin.
    Vec6<double> lo, hi;
    robot.joint_limits(lo, hi);
    for (int i = 0; i < 6; ++i) {
      const double range = hi(i) - lo(i);
      bounded_[i] = range < kUnbounded;
      lo_(i) = bounded_[i] ? lo(i) + margin_ * range : lo(i);
      hi_(i) = bounded_[i] ? hi(i) - margin_ * range : hi(i);
      range_(i) = bounded_[i] ? range : 0.0;
    }
    // The passive joints the description bounds (the hybrid's UP extension).
    for (PassiveLimit p : family_.kinematics().passive_limits(robot)) {
      if (!(p.hi - p.lo < kUnbounded)) continue;
      const double range = p.hi - p.lo;
      p.lo += margin_ * range;
      p.hi -= margin_ * range;
      passive_.push_back(p);
    }
    Vec6<double> q;
    std::string why;
    home_condition_ = std::numeric_limits<double>::infinity();  // no bound while measuring home itself
    double c = 0;
    if (!check(robot.home_pose(), q, &why, &c))
      throw InputError(robot.name, 0, 0,
                       "the home pose is not usable for planning (" + why + "); lower --margin or check the limits");
    home_condition_ = c;
    condition_limit_ = o.singularity_factor * c;
  }

  // Whether the machine can be measured at `xyzrpy`: IK inside the limits
  // with the margin, away from singularities. `why` (if given) says what failed.
  bool usable(const Vec6<double>& xyzrpy, Vec6<double>& q, std::string* why = nullptr) const {
    return check(Pose<double>::from_xyz_rpy(xyzrpy), q, why, nullptr);
  }
  // Per joint: the limit range (0 when the joint has none).
  const Vec6<double>& range() const { return range_; }

 private:
  bool check(const Pose<double>& pose, Vec6<double>& q, std::string* why, double* condition) const {
    // The IK without its Jacobian first: most sampled poses fail the limits,
    // and that needs only the joints.
    std::array<double, 4> passive{};  // the family's passive joints (passive_limits)
    Status s = family_.kinematics().inverse(open_, pose, q, nullptr, passive.data());
    if (s != Status::Ok) {
      if (why) *why = std::string("IK: ") + to_string(s);
      return false;
    }
    for (int i = 0; i < 6; ++i)
      if (q(i) < lo_(i) || q(i) > hi_(i)) {
        if (why) *why = "q" + std::to_string(i + 1) + " = " + fixed(q(i), 3) + " outside [" + fixed(lo_(i), 3) + ", " +
              fixed(hi_(i), 3) + "] (the limits less a margin of " + fixed(100 * margin_, 1) + " %)";
        return false;
      }
    for (std::size_t k = 0; k < passive_.size(); ++k) {
      const PassiveLimit& p = passive_[k];
      if (passive[k] >= p.lo && passive[k] <= p.hi) continue;
      if (why) *why = p.name + " = " + fixed(passive[k], 3) + " " + p.unit + " outside [" +
            fixed(p.lo, 3) + ", " + fixed(p.hi, 3) + "] (the limits less the margin)";
      return false;
    }
    Mat6<double> J;
    Vec6<double> q_again;
    const double L = family_.kinematics().characteristic_length(open_);
    s = family_.kinematics().inverse(open_, pose, q_again, &J);
    if (s != Status::Ok) {
      if (why) *why = std::string("IK: ") + to_string(s);
      return false;
    }
    // J = ∂q/∂twist; angles in units of L so its condition number is unit-free.
    Mat6<double> Js = J;
    Js.rightCols<3>() /= L;
    const Eigen::JacobiSVD<Mat6<double>> svd(Js);
    const Vec6<double> sv = svd.singularValues();
    const double cond = sv(5) > 0 ? sv(0) / sv(5) : std::numeric_limits<double>::infinity();
    if (condition != nullptr) *condition = cond;
    if (!(cond <= condition_limit_)) {
      if (why) *why = "near a singularity (Jacobian condition number " + fixed(cond, 1) + ", more than " +
            fixed(condition_limit_ / home_condition_, 1) + " x the home pose's)";
      return false;
    }
    return true;
  }

  const Family& family_;
  Robot open_;  // the robot with its limits opened
  double margin_;
  Vec6<double> lo_, hi_, range_;
  std::array<bool, 6> bounded_{};
  std::vector<PassiveLimit> passive_;  // bounded passive joints, less the margin
  double home_condition_ = 1, condition_limit_ = std::numeric_limits<double>::infinity();
};

// ---------------------------------------------------------------- design rows

// The identification Jacobian of one pose: measured coordinates (whitened by
// the noise) per unit parameter of the base model and the effects, and the
// tool point's displacement (mm) per unit parameter for predicting the
// held-out error.
class DesignRows {
 public:
  DesignRows(const Robot& robot, const PlanOptions& o, std::vector<std::string>& notes) : robot_(robot) {
    frame_ = effect_frame(robot);
    PlanMeasure m = o.measure;
    const Family& family = family_of(robot);
    // The family's own instrument: the full pose, or its targets (the hybrid's gauge).
    const std::optional<MeasurementModel> own = family.measurement().own_targets(robot);
    if (m == PlanMeasure::Default) m = own ? PlanMeasure::Targets : PlanMeasure::Pose;
    sigma_mm_ = o.noise_mm;
    sigma_rad_ = o.noise_rad > 0 ? o.noise_rad : o.noise_mm / kOrientationLeverMm;
    if (m == PlanMeasure::Pose) {
      if (own)
        notes.push_back(std::string("this plan's numbers are for a full-pose instrument: kincal identify reads the "
                                    "poses (mx..mrz) of a table without target columns, instead of ") +
                        family.measurement().own_measurement());
    } else if (!robot.targets.empty()) {
      model_ = MeasurementModel::targets(robot.targets);
      notes.push_back("this plan's numbers are for targets measured in the robot's base frame (a tracker aligned to "
                      "it); with identify --instrument-frame the tracker's registration is identified as well, and "
                      "the frames are then the weakest part (docs/identify.md \"Laser-tracker targets\")");
    } else if (own) {
      model_ = *own;
    } else {
      throw InputError(robot.name, 0, 0,
                       std::string("--measure targets needs the target positions on the ") + robot.target_body() +
                           ": add the key `targets` (1 to 3 points [x, y, z], mm, " + robot.target_body() +
                           " frame) to the robot description");
    }
    measure_ = model_.describe();
    errors_ = detail::family_errors(robot);
    names_ = errors_->names();
    units_ = errors_->units();
    kept_.resize(names_.size());
    std::iota(kept_.begin(), kept_.end(), Index(0));
  }

  // The base columns when the family's parameters outnumber what poses
  // determine (FamilyErrors::identifiable_columns: the hybrid's seed 000
  // Section 4.1 selection), from the whitened design rows `H` of some pool
  // poses over the current base columns (all before the first selection).
  // Returns the positions of the kept columns among the current ones; rows()
  // gives only those from then on.
  bool selects_columns() const { return errors_->selects_columns(); }
  std::vector<Index> select_columns(const MatrixXd& H) {
    const std::vector<Index> keep = errors_->identifiable_columns(H);
    std::vector<Index> kept;
    std::vector<std::string> names, units;
    for (Index j : keep) {
      kept.push_back(kept_[std::size_t(j)]);
      names.push_back(names_[std::size_t(j)]);
      units.push_back(units_[std::size_t(j)]);
    }
    names.insert(names.end(), names_.begin() + H.cols(), names_.end());
    units.insert(units.end(), units_.begin() + H.cols(), units_.end());
    kept_ = std::move(kept);
    names_ = std::move(names);
    units_ = std::move(units);
    return keep;
  }

  // Effect columns join the base's, named "effect.parameter".
  void add_effect(const Effect* e) {
    effects_.push_back(e);
    for (const std::string& p : e->parameter_names(robot_)) {
      names_.push_back(e->name() + "." + p);
      units_.push_back("");
    }
  }

  Index rows_per_pose() const { return model_.rows(); }
  Index base_parameters() const { return Index(kept_.size()); }
  Index parameters() const { return Index(names_.size()); }
  const std::vector<std::string>& names() const { return names_; }
  const std::vector<std::string>& units() const { return units_; }
  const std::string& measure() const { return measure_; }
  // Rows of the measured coordinates that are point displacements (mm).
  bool position_row(Index i) const { return !model_.measures_orientation() || i < 3; }

  // A (rows × parameters, whitened) and P (3 × parameters, mm per unit) of a
  // pose; false when its model cannot be evaluated.
  bool rows(const Candidate& c, const std::optional<EffectNode>& node, Eigen::Ref<MatrixXd> A,
            Eigen::Ref<MatrixXd> P) const {
    const Pose<double> pose = Pose<double>::from_xyz_rpy(c.xyzrpy);
    MatrixXd T(6, parameters());  // tool twist per unit parameter
    MatrixXd B;
    if (!errors_->nominal_twist_columns(pose, B)) return false;
    for (std::size_t j = 0; j < kept_.size(); ++j) T.col(Index(j)) = B.col(kept_[j]);
    Index col = base_parameters();
    for (const Effect* e : effects_) {
      const Index k = Index(e->parameter_names(robot_).size());
      if (!node) return false;
      MatrixXd t(6, k);
      e->twist_columns(robot_, frame_, *node, t);
      T.middleCols(col, k) = t;
      col += k;
    }
    if (!T.allFinite()) return false;
    model_.design_into(pose, T, whitening(), A);  // whitened H = M·T
    P = T.topRows(3);
    return true;
  }

  VectorXd whitening() const {
    VectorXd w = VectorXd::Constant(model_.rows(), 1.0 / sigma_mm_);
    if (model_.measures_orientation()) w.tail(3).setConstant(1.0 / sigma_rad_);
    return w;
  }
  // Multiplies whitened rows back to mm (angles × the lever) for the prior's scale.
  VectorXd displacement_scale() const {
    VectorXd s = VectorXd::Constant(model_.rows(), sigma_mm_);
    if (model_.measures_orientation()) s.tail(3).setConstant(sigma_rad_ * kOrientationLeverMm);
    return s;
  }

 private:
  const Robot& robot_;
  EffectParameters<double> frame_;
  MeasurementModel model_ = MeasurementModel::full_pose();  // what the instrument measures
  double sigma_mm_ = 0.005, sigma_rad_ = 0.005 / kOrientationLeverMm;
  std::string measure_;
  std::shared_ptr<const detail::FamilyErrors> errors_;
  std::vector<Index> kept_;  // the base columns among the family's parameters
  std::vector<const Effect*> effects_;
  std::vector<std::string> names_, units_;
};

// The effect nodes (static load, joint twists, directions) of candidates.
std::vector<std::optional<EffectNode>> nodes_of(const Robot& robot, const std::vector<Candidate>& cs, bool with_dir) {
  PoseTable t;
  t.has_dir = with_dir;
  t.rows.resize(cs.size());
  for (std::size_t k = 0; k < cs.size(); ++k) {
    t.rows[k].commanded = cs[k].xyzrpy;
    if (with_dir) t.rows[k].dir = cs[k].dir;
  }
  return effect_nodes(robot, t);
}

// ---------------------------------------------------------------- the criterion

// log det(I + Σ_sel Â_cᵀÂ_c) over a pool of poses, Â = whitened rows scaled
// so the prior is the identity, with each pose's gain and the inverse kept
// up to date by rank-r updates (Fedorov's exchange formulas for r rows).
class DOptimal {
 public:
  // r ≤ 9 measured coordinates per pose: the r × r algebra stays on the stack.
  using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 9, 9>;

  DOptimal(const MatrixXd& A, Index r) : A_(A), r_(r), n_(A.rows() / r), p_(A.cols()) { reset({}); }
  // Pose c's rows.
  Eigen::Block<const MatrixXd> block(Index c) const { return Eigen::Block<const MatrixXd>(A_, c * r_, 0, r_, p_); }

  void reset(const std::vector<Index>& chosen) {
    MatrixXd K = MatrixXd::Identity(p_, p_);
    for (Index c : chosen) K.noalias() += block(c).transpose() * block(c);
    const Eigen::LLT<MatrixXd> llt(K);
    Kinv_ = llt.solve(MatrixXd::Identity(p_, p_));
    log_det_ = 2 * llt.matrixLLT().diagonal().array().log().sum();
    S_.resize(n_ * r_, r_);
    const MatrixXd AK = A_ * Kinv_;
    for (Index c = 0; c < n_; ++c)
      S_.middleRows(c * r_, r_).noalias() = AK.middleRows(c * r_, r_).lazyProduct(block(c).transpose());
    refresh_gains();
  }
  double log_det() const { return log_det_; }
  // Gain in log det of adding pose c (the loss of removing it, for a chosen c,
  // is −log det(I − S_c)).
  double gain(Index c) const { return gain_(c); }
  void add(Index c) { update(c, +1); }
  void remove(Index c) { update(c, -1); }

  // The state before a tentative change, to go back to without a second update.
  struct Saved {
    MatrixXd Kinv, S;
    VectorXd gain;
    double log_det = 0;
  };
  void save(Saved& s) const { s = Saved{Kinv_, S_, gain_, log_det_}; }
  void restore(Saved& s) {
    Kinv_.swap(s.Kinv);
    S_.swap(s.S);
    gain_.swap(s.gain);
    log_det_ = s.log_det;
  }

 private:
  static double log_det_of(const Small& m) {
    const Eigen::LLT<Small> llt(m);
    if (llt.info() != Eigen::Success) return -std::numeric_limits<double>::infinity();
    return 2 * llt.matrixLLT().diagonal().array().log().sum();
  }
  void refresh_gains() {
    gain_.resize(n_);
    for (Index c = 0; c < n_; ++c) gain_(c) = log_det_of(Small::Identity(r_, r_) + S_.middleRows(c * r_, r_));
  }
  // K ± Â_cᵀÂ_c: K⁻¹ ∓ V·(I ± S_c)⁻¹·Vᵀ with V = K⁻¹Â_cᵀ; every S_d changes
  // by ∓ G_d·(I ± S_c)⁻¹·G_dᵀ with G_d = Â_d·V.
  void update(Index c, int sign) {
    const MatrixXd V = Kinv_ * block(c).transpose();  // p × r
    const Small middle = Small::Identity(r_, r_) + double(sign) * S_.middleRows(c * r_, r_);
    log_det_ += double(sign) * log_det_of(middle);
    const Small F = middle.llt().solve(Small::Identity(r_, r_));
    Kinv_.noalias() -= double(sign) * (V * F) * V.transpose();
    const MatrixXd G = A_ * V;  // (n·r) × r
    const MatrixXd GF = double(sign) * G * F;
    // r × r per pose: a coefficient-wise product, not a GEMM call per pose.
    for (Index d = 0; d < n_; ++d) {
      S_.middleRows(d * r_, r_).noalias() -= GF.middleRows(d * r_, r_).lazyProduct(G.middleRows(d * r_, r_).transpose());
      gain_(d) = log_det_of(Small::Identity(r_, r_) + S_.middleRows(d * r_, r_));
    }
  }

  const MatrixXd& A_;
  Index r_, n_, p_;
  MatrixXd Kinv_, S_;
  VectorXd gain_;
  double log_det_ = 0;
};

// The greedy start, lazily (Minoux's accelerated greedy): log det(K + Σ AᵀA)
// is submodular in the set of poses, so a pose's gain only falls as poses
// are added, and a gain computed earlier bounds it from above. Only the
// poses whose bound reaches the top are re-evaluated (p²·r each), instead
// of every pose at every step: the same choice as the plain greedy, at a
// fraction of its cost.
std::vector<Index> lazy_greedy(const MatrixXd& A, Index r, std::size_t count) {
  using Small = DOptimal::Small;
  const Index n = A.rows() / r, p = A.cols();
  MatrixXd Kinv = MatrixXd::Identity(p, p);
  auto gain = [&](Index c) {
    const auto Ac = A.middleRows(c * r, r);
    const Small S = Small::Identity(r, r) + Ac * (Kinv * Ac.transpose());
    const Eigen::LLT<Small> llt(S);
    return 2 * llt.matrixLLT().diagonal().array().log().sum();
  };
  std::vector<std::pair<double, Index>> heap;  // (bound, pose), a max-heap
  heap.reserve(std::size_t(n));
  for (Index c = 0; c < n; ++c) heap.emplace_back(gain(c), c);
  std::make_heap(heap.begin(), heap.end());
  std::vector<Index> chosen;
  while (chosen.size() < count && !heap.empty()) {
    std::pop_heap(heap.begin(), heap.end());
    const Index c = heap.back().second;
    heap.pop_back();
    const double fresh = gain(c);
    if (!heap.empty() && fresh < heap.front().first) {  // another pose may gain more: back in with its new bound
      heap.emplace_back(fresh, c);
      std::push_heap(heap.begin(), heap.end());
      continue;
    }
    const auto Ac = A.middleRows(c * r, r);
    const MatrixXd V = Kinv * Ac.transpose();
    const Small F = (Small::Identity(r, r) + Ac * V).llt().solve(Small::Identity(r, r));
    Kinv.noalias() -= (V * F) * V.transpose();
    chosen.push_back(c);
  }
  return chosen;
}

// ---------------------------------------------------------------- motion order

// Largest joint move as a fraction of that joint's range (the move's time on
// a machine whose joints move at once).
double move_cost(const Vec6<double>& a, const Vec6<double>& b, const Vec6<double>& range) {
  double m = 0;
  for (int i = 0; i < 6; ++i) m = std::max(m, std::abs(a(i) - b(i)) / range(i));
  return m;
}

// Nearest neighbour from the home joints, then 2-opt until no reversal
// shortens the open path.
std::vector<std::size_t> motion_order(const std::vector<Vec6<double>>& q, const Vec6<double>& home,
                                      const Vec6<double>& range, double& length) {
  const std::size_t n = q.size();
  std::vector<std::size_t> order;
  std::vector<bool> used(n, false);
  Vec6<double> at = home;
  for (std::size_t k = 0; k < n; ++k) {
    std::size_t best = n;
    double best_cost = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < n; ++j)
      if (!used[j] && move_cost(at, q[j], range) < best_cost) {
        best_cost = move_cost(at, q[j], range);
        best = j;
      }
    used[best] = true;
    order.push_back(best);
    at = q[best];
  }
  auto point = [&](std::size_t i) -> const Vec6<double>& { return i == 0 ? home : q[order[i - 1]]; };
  // Positions 0..n in the path: 0 is home, i ≥ 1 is order[i − 1].
  for (int pass = 0; pass < 50; ++pass) {
    bool improved = false;
    for (std::size_t i = 0; i + 1 < n; ++i)
      for (std::size_t j = i + 2; j <= n; ++j) {
        // Reverse path positions i+1..j.
        const double before = move_cost(point(i), point(i + 1), range) +
                              (j < n ? move_cost(point(j), point(j + 1), range) : 0.0);
        const double after = move_cost(point(i), point(j), range) +
                             (j < n ? move_cost(point(i + 1), point(j + 1), range) : 0.0);
        if (after < before - 1e-12) {
          std::reverse(order.begin() + std::ptrdiff_t(i), order.begin() + std::ptrdiff_t(j));
          improved = true;
        }
      }
    if (!improved) break;
  }
  length = 0;
  for (std::size_t i = 0; i < n; ++i) length += move_cost(point(i), point(i + 1), range);
  return order;
}


// ---------------------------------------------------------------- the plan's steps

// Approach directions of one pose, ±1 per joint at random (backlash).
Eigen::VectorXi random_directions(std::mt19937_64& rng) {
  Eigen::VectorXi d(6);
  for (int i = 0; i < 6; ++i) d(i) = (rng() & 1u) ? 1 : -1;
  return d;
}

// The effects the criterion includes. thermal and an effect needing inputs
// no pose can choose are left out, with a note saying why (a plan cannot
// create a temperature span); backlash adds how to approach each pose.
struct PlannedEffects {
  std::vector<const Effect*> effects;
  bool backlash = false;
};
PlannedEffects planned_effects(const Robot& robot, const PlanOptions& o, MeasurementPlan& plan) {
  PlannedEffects out;
  for (const std::string& name : o.effects) {
    const Effect* e = find_effect(robot, name);
    if (e == nullptr) throw InputError("", 0, 0, "unknown effect '" + name + "' (known: " + effect_names(robot) + ")");
    if (name == "thermal") {
      plan.notes.push_back(
          "thermal is not in the criterion: its parameter is seen only through the structure's temperature "
          "change while measuring, which no choice of poses creates; measure the plan over a temperature span "
          "(for example once cold and again warm, 5 C or more apart) with a temp column");
      continue;
    }
    PoseTable probe;
    probe.rows.resize(2);
    probe.has_dir = true;
    const std::string missing = e->missing_inputs(probe);
    if (!missing.empty()) {
      plan.notes.push_back(name + " is not in the criterion: it needs what a plan cannot choose (" + missing + ")");
      continue;
    }
    out.effects.push_back(e);
    plan.effects.push_back(name);
    out.backlash = out.backlash || name == "backlash";
  }
  if (out.backlash)
    plan.notes.push_back("backlash: each pose has approach directions dir1..dir6; approach it so that joint i's "
                         "last move was in direction dir_i (for example from a point 1 mm back along each joint)");
  return out;
}

// How far each degree of freedom reaches alone from home, both ways
// (bisection on usability): the box candidates are drawn from, the hand
// grid is laid over and held-out poses are spread in.
struct Reach {
  Vec6<double> lo, hi;
};
Reach axis_reach(const Robot& robot, const Workspace& workspace, const Vec6<double>& home) {
  Reach reach;
  const double size = family_of(robot).kinematics().reach(robot);
  for (int d = 0; d < 6; ++d)
    for (int sign : {-1, 1}) {
      double good = 0, bad = d < 3 ? 2 * size : 1.5;
      Vec6<double> q;
      for (int it = 0; it < 30; ++it) {
        const double mid = 0.5 * (good + bad);
        Vec6<double> x = home;
        x(d) += sign * mid;
        (workspace.usable(x, q) ? good : bad) = mid;
      }
      (sign < 0 ? reach.lo : reach.hi)(d) = sign * good;
    }
  return reach;
}

// The candidates: the user's (each refused one named once, the first), or a
// uniform sample of the reach box, kept where usable. plan.candidates counts
// what was offered or drawn.
std::vector<Candidate> candidate_pool(const PlanOptions& o, const Workspace& workspace, const Vec6<double>& home,
                                      const Reach& reach, bool backlash, std::mt19937_64& rng, MeasurementPlan& plan,
                                      std::string& first_rejected) {
  std::vector<Candidate> pool;
  if (!o.candidates.rows.empty()) {
    plan.candidates = o.candidates.rows.size();
    for (const PoseRow& row : o.candidates.rows) {
      Candidate c;
      c.xyzrpy = row.commanded;
      c.line = row.line;
      c.id = row.id;
      std::string why;
      if (!workspace.usable(c.xyzrpy, c.q, &why)) {
        if (first_rejected.empty())
          first_rejected = o.candidates.file + ":" + std::to_string(row.line) + ": row '" + row.id + "': " + why;
        continue;
      }
      if (backlash) c.dir = row.dir ? Eigen::VectorXi(*row.dir) : random_directions(rng);
      pool.push_back(std::move(c));
    }
  } else {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const std::size_t max_draws = 200 * std::max<std::size_t>(o.sample_count, 1);
    std::size_t draws = 0;
    while (pool.size() < o.sample_count && draws < max_draws) {
      ++draws;
      Candidate c;
      for (int d = 0; d < 6; ++d) c.xyzrpy(d) = home(d) + reach.lo(d) + u(rng) * (reach.hi(d) - reach.lo(d));
      if (!workspace.usable(c.xyzrpy, c.q)) continue;
      if (backlash) c.dir = random_directions(rng);
      pool.push_back(std::move(c));
    }
    plan.candidates = draws;
  }
  return pool;
}

// The prior: parameter j moves the measured points by prior_mm RMS over
// the pool. Scaling each column by its prior standard deviation τ_j makes
// the prior precision the identity.
VectorXd prior_scale(const DesignRows& design, const MatrixXd& A, std::size_t pool_size, double prior_mm) {
  const Index r = design.rows_per_pose(), p = design.parameters();
  VectorXd tau(p);
  const VectorXd back = design.displacement_scale();
  Index position_rows = 0;
  for (Index i = 0; i < r; ++i) position_rows += design.position_row(i) ? 1 : 0;
  for (Index j = 0; j < p; ++j) {
    double ss = 0;
    for (Index c = 0; c < Index(pool_size); ++c)
      for (Index i = 0; i < r; ++i)
        if (design.position_row(i)) ss += std::pow(A(c * r + i, j) * back(i), 2);
    const double rms = std::sqrt(ss / (double(pool_size) * double(position_rows) / 3.0));
    tau(j) = rms > 0 ? prior_mm / rms : 1.0;
  }
  return tau;
}

// Held-out poses: farthest-point spread over the unchosen pool (marked in
// `in` as they are taken), in coordinates scaled by each degree of
// freedom's reach, so that the held-out error is judged over the workspace.
std::vector<Index> held_out_poses(const std::vector<Candidate>& pool, const Vec6<double>& home, const Reach& reach,
                                  std::size_t count, std::vector<bool>& in) {
  std::vector<Index> test;
  Vec6<double> scale = (reach.hi - reach.lo).cwiseMax(1e-9);
  auto coord = [&](Index c) -> Vec6<double> { return (pool[std::size_t(c)].xyzrpy - home).cwiseQuotient(scale); };
  std::vector<double> dist(pool.size(), std::numeric_limits<double>::infinity());
  Vec6<double> centre = Vec6<double>::Zero();
  for (const Candidate& c : pool) centre += (c.xyzrpy - home).cwiseQuotient(scale);
  centre /= double(pool.size());
  for (Index c = 0; c < Index(pool.size()); ++c) dist[std::size_t(c)] = (coord(c) - centre).norm();  // start far out
  for (std::size_t k = 0; k < count; ++k) {
    Index best = -1;
    double far = -std::numeric_limits<double>::infinity();
    for (Index c = 0; c < Index(pool.size()); ++c)
      if (!in[std::size_t(c)] && dist[std::size_t(c)] > far) {
        far = dist[std::size_t(c)];
        best = c;
      }
    in[std::size_t(best)] = true;
    test.push_back(best);
    for (Index c = 0; c < Index(pool.size()); ++c) {
      const double d = (coord(c) - coord(best)).norm();
      dist[std::size_t(c)] = k == 0 ? d : std::min(dist[std::size_t(c)], d);
    }
  }
  return test;
}

// The plan's poses (cal and test together) in motion order: nearest
// neighbour and 2-opt over the largest joint move per range (a joint with no
// limit: the candidates' span), from home; ids P001…/T001… unless the
// candidate had one.
void motion_ordered_poses(const Robot& robot, const Workspace& workspace, const std::vector<Candidate>& pool,
                          const std::vector<Index>& chosen, const std::vector<Index>& test, bool backlash,
                          MeasurementPlan& plan) {
  std::vector<Index> rows = chosen;
  rows.insert(rows.end(), test.begin(), test.end());
  std::vector<Vec6<double>> q;
  for (Index c : rows) q.push_back(pool[std::size_t(c)].q);
  Vec6<double> range = workspace.range();
  for (int i = 0; i < 6; ++i)
    if (!(range(i) > 0)) {  // no limit: the span of the candidates
      double lo = q.front()(i), hi = lo;
      for (const Candidate& c : pool) {
        lo = std::min(lo, c.q(i));
        hi = std::max(hi, c.q(i));
      }
      range(i) = std::max(hi - lo, 1e-9);
    }
  Vec6<double> q_home;
  if (robot.inverse(robot.home_pose(), q_home) != Status::Ok) q_home = q.front();
  const std::vector<std::size_t> order = motion_order(q, q_home, range, plan.path_length);
  plan.poses.has_role = true;
  plan.poses.has_dir = backlash;
  std::size_t cal = 0, held = 0;
  for (std::size_t k : order) {
    const Candidate& c = pool[std::size_t(rows[k])];
    PoseRow row;
    const bool is_test = k >= chosen.size();
    row.role = is_test ? Role::Test : Role::Cal;
    const std::string n = std::to_string(is_test ? ++held : ++cal);
    row.id = !c.id.empty() ? c.id : (is_test ? "T" : "P") + std::string(n.size() < 3 ? 3 - n.size() : 0, '0') + n;
    row.commanded = c.xyzrpy;
    if (backlash) row.dir = c.dir;
    plan.poses.rows.push_back(row);
  }
}


// The design rows of candidates `cs` (whitened A, r per pose; P, the
// position rows in mm per unit), dropping the candidates whose model cannot
// be evaluated.
void candidate_rows(const Robot& robot, const DesignRows& design, const std::vector<const Effect*>& effects,
                    bool backlash, std::vector<Candidate>& cs, MatrixXd& A, MatrixXd& P) {
  const Index p = design.parameters(), r = design.rows_per_pose();
  const std::vector<std::optional<EffectNode>> nodes =
      effects.empty() ? std::vector<std::optional<EffectNode>>(cs.size()) : nodes_of(robot, cs, backlash);
  A.resize(Index(cs.size()) * r, p);
  P.resize(Index(cs.size()) * 3, p);
  std::vector<Candidate> kept;
  Index n = 0;
  for (std::size_t k = 0; k < cs.size(); ++k) {
    if (!design.rows(cs[k], nodes[k], A.middleRows(n * r, r), P.middleRows(n * 3, 3))) continue;
    kept.push_back(cs[k]);
    ++n;
  }
  A.conservativeResize(n * r, p);
  P.conservativeResize(n * 3, p);
  cs = std::move(kept);
}

// Which of the family's source errors (the hybrid's 150) the workspace can
// identify, from 200 pool poses spread through it; the other columns leave
// A and P (and the design).
void keep_identifiable_columns(DesignRows& design, std::size_t pool_size, MatrixXd& A, MatrixXd& P) {
  if (!design.selects_columns() || pool_size == 0) return;
  const Index r = design.rows_per_pose(), base = design.base_parameters();
  const std::size_t n = std::min<std::size_t>(pool_size, 200);
  MatrixXd H(Index(n) * r, base);
  for (std::size_t k = 0; k < n; ++k) H.middleRows(Index(k) * r, r) = A.block(Index(k * pool_size / n) * r, 0, r, base);
  std::vector<Index> columns = design.select_columns(H);
  for (Index j = base; j < A.cols(); ++j) columns.push_back(j);
  A = MatrixXd(A(Eigen::all, columns));
  P = MatrixXd(P(Eigen::all, columns));
}

// The chosen poses: the lazy greedy start, then exchange passes on a
// shortlist (the criterion log det(I + Σ AᵀA) on the prior-scaled rows As;
// plan.exchange_passes, plan.exchanges counted).
template <class Progress>
std::vector<Index> choose_poses(const MatrixXd& As, Index r, const PlanOptions& o, std::size_t pool_size,
                                MeasurementPlan& plan, const Progress& progress) {
  const Index p = As.cols();
  progress("choosing " + std::to_string(o.count) + " poses (greedy)");
  std::vector<Index> chosen = lazy_greedy(As, r, o.count);
  std::vector<bool> in(pool_size, false);
  for (Index c : chosen) in[std::size_t(c)] = true;
  // Exchange on a shortlist: the chosen poses and the unchosen ones that
  // would add most to them (a pose that adds little to the design is not
  // what an exchange brings in), then the shortlist drawn again from the
  // whole pool at the new design, until a round swaps nothing. Each pass
  // costs the shortlist's size, not the pool's, in rank-r updates.
  const std::size_t shortlist_size = std::min(pool_size, std::max<std::size_t>(400, 10 * o.count));
  for (int round = 0; round < 10 && plan.exchange_passes < o.max_exchange_passes; ++round) {
    std::vector<Index> shortlist = chosen;
    {
      DOptimal full(As, r);
      full.reset(chosen);
      std::vector<Index> rest;
      for (Index c = 0; c < Index(pool_size); ++c)
        if (!in[std::size_t(c)]) rest.push_back(c);
      const std::size_t extra = std::min(rest.size(), shortlist_size - std::min(shortlist_size, chosen.size()));
      std::partial_sort(rest.begin(), rest.begin() + std::ptrdiff_t(extra), rest.end(),
                        [&](Index a, Index b) { return full.gain(a) > full.gain(b); });
      shortlist.insert(shortlist.end(), rest.begin(), rest.begin() + std::ptrdiff_t(extra));
    }
    MatrixXd Ash(Index(shortlist.size()) * r, p);
    for (std::size_t k = 0; k < shortlist.size(); ++k) Ash.middleRows(Index(k) * r, r) = As.middleRows(shortlist[k] * r, r);
    // Positions in the shortlist: the chosen are its first chosen.size().
    std::vector<Index> pick(chosen.size());
    std::iota(pick.begin(), pick.end(), 0);
    std::vector<bool> taken(shortlist.size(), false);
    for (Index k : pick) taken[std::size_t(k)] = true;
    DOptimal crit(Ash, r);
    crit.reset(pick);
    DOptimal::Saved saved;
    int round_swaps = 0;
    for (; plan.exchange_passes < o.max_exchange_passes;) {
      int swaps = 0;
      const double before = crit.log_det();
      for (std::size_t k = 0; k < pick.size(); ++k) {
        const Index out = pick[k];
        crit.save(saved);
        crit.remove(out);
        taken[std::size_t(out)] = false;
        Index best = -1;
        for (Index c = 0; c < Index(shortlist.size()); ++c)
          if (!taken[std::size_t(c)] && (best < 0 || crit.gain(c) > crit.gain(best))) best = c;
        taken[std::size_t(best)] = true;
        if (best == out) {  // nothing better: back to the state before, no second update
          crit.restore(saved);
          continue;
        }
        crit.add(best);
        pick[k] = best;
        ++swaps;
      }
      crit.reset(pick);  // the rank-r updates' rounding, cleared once a pass
      ++plan.exchange_passes;
      plan.exchanges += swaps;
      round_swaps += swaps;
      progress("exchange pass " + std::to_string(plan.exchange_passes) + ": " + std::to_string(swaps) +
               " swaps, log det " + fixed(before, 3) + " -> " + fixed(crit.log_det(), 3));
      if (swaps == 0 || crit.log_det() - before < 1e-6 * std::abs(before)) break;
    }
    for (Index c : chosen) in[std::size_t(c)] = false;
    for (std::size_t k = 0; k < pick.size(); ++k) chosen[k] = shortlist[std::size_t(pick[k])];
    for (Index c : chosen) in[std::size_t(c)] = true;
    if (round_swaps == 0) break;
  }

  return chosen;
}

// The numbers of a design, its whitened rows A_d: rank and condition, the
// criterion with the prior, each parameter's predicted standard error, the
// predicted held-out error at the evaluation poses (Pes: their position rows,
// prior-scaled) and each effect's confounding with the base.
struct DesignAssessor {
  const Robot& robot;
  const DesignRows& design;
  const std::vector<const Effect*>& effects;
  const VectorXd& tau;
  const MatrixXd& Pes;
  std::size_t evaluation_poses;
  DesignAssessment operator()(const std::string& name, const MatrixXd& Ad) const {
    const Index r = design.rows_per_pose(), p = design.parameters(), base_p = design.base_parameters();
    DesignAssessment a;
    a.name = name;
    a.poses = std::size_t(Ad.rows() / r);
    a.parameters = p;
    const RankReport rank = rank_by_svd(Ad);
    a.rank = rank.rank;
    a.condition_number = rank.condition_number;
    const MatrixXd Ads = Ad * tau.asDiagonal();
    MatrixXd K = MatrixXd::Identity(p, p);
    K.noalias() += Ads.transpose() * Ads;
    const Eigen::LLT<MatrixXd> llt(K);
    a.log_det = 2 * llt.matrixLLT().diagonal().array().log().sum();
    const MatrixXd Kinv = llt.solve(MatrixXd::Identity(p, p));
    for (Index j = 0; j < p; ++j) {
      PlanParameter pp;
      pp.name = design.names()[std::size_t(j)];
      pp.unit = design.units()[std::size_t(j)];
      pp.standard_error = tau(j) * std::sqrt(Kinv(j, j));
      pp.prior = tau(j);
      pp.determined = std::sqrt(Kinv(j, j)) < 0.5;
      if (!pp.determined) ++a.undetermined;
      a.parameter_errors.push_back(pp);
    }
    // trace(Pe·Cov·Peᵀ) / poses, Cov = T·K⁻¹·T (in mm²).
    const double tr = (Pes * Kinv).cwiseProduct(Pes).sum();
    a.predicted_test_um = 1e3 * std::sqrt(tr / double(evaluation_poses));
    // Confounding: the share of each effect column's energy inside the base's span.
    if (p > base_p) {
      const detail::ScaledPivotedQr base(Ad.leftCols(base_p));
      Index col = base_p;
      for (const Effect* e : effects) {
        const Index k = Index(e->parameter_names(robot).size());
        double sum = 0;
        int counted = 0;
        for (Index j = col; j < col + k; ++j) {
          const double g2 = Ad.col(j).squaredNorm();
          if (!(g2 > 1e-18 * Ad.leftCols(base_p).squaredNorm())) continue;
          const VectorXd inside = base.fitted(Ad.col(j));
          sum += std::min(1.0, inside.squaredNorm() / g2);
          ++counted;
        }
        a.confounding.push_back({e->name(), counted > 0 ? sum / counted : 1.0});
        col += k;
      }
    }
    return a;
  }
};

// What a user lays out by hand, to compare with: positions on a lattice over
// the box the axes reach, at the home orientation (6-UPS: 3 layers, each pose
// tilted at random within ±5° as examples/seed001/grid_poses.csv; hybrid:
// one layer of pure translations as seed 000's), shrunk until every node is
// usable; its assessment and poses go into the plan (or a note that none
// was found).
void compare_with_hand_grid(const Robot& robot, const PlanOptions& o, const Workspace& workspace,
                            const Vec6<double>& home, const Reach& reach, bool backlash, const DesignRows& design,
                            const std::vector<const Effect*>& effects, const DesignAssessor& assess,
                            std::mt19937_64& rng, MeasurementPlan& plan) {
  const HandGrid habit = family_of(robot).measurement().hand_grid();
  const int layers = habit.layers;
  const std::size_t per_layer = (o.count + std::size_t(layers) - 1) / std::size_t(layers);
  const int nx = int(std::ceil(std::sqrt(double(per_layer))));
  const int ny = int((per_layer + std::size_t(nx) - 1) / std::size_t(nx));
  std::uniform_real_distribution<double> tilt(-5 * pi<double>() / 180, 5 * pi<double>() / 180);
  std::vector<Candidate> grid;
  double f = 0.9;
  for (int attempt = 0; attempt < 40 && grid.size() < o.count; ++attempt, f *= 0.9) {
    grid.clear();
    std::vector<Vec6<double>> lattice;
    auto at = [&](int i, int n, int d) {
      return n == 1 ? home(d) : home(d) + f * (reach.lo(d) + (reach.hi(d) - reach.lo(d)) * double(i) / double(n - 1));
    };
    for (int l = 0; l < layers; ++l)
      for (int iy = 0; iy < ny; ++iy)
        for (int ix = 0; ix < nx; ++ix) {
          Vec6<double> x = home;
          x(0) = at(ix, nx, 0);
          x(1) = at(iy, ny, 1);
          x(2) = at(l, layers, 2);
          lattice.push_back(x);
        }
    bool all_usable = true;
    for (std::size_t k = 0; k < o.count && all_usable; ++k) {
      Candidate c;
      c.xyzrpy = lattice[k * lattice.size() / o.count];
      if (habit.tilted)
        for (int d = 3; d < 6; ++d) c.xyzrpy(d) += tilt(rng);
      all_usable = workspace.usable(c.xyzrpy, c.q);
      if (backlash) c.dir = random_directions(rng);
      grid.push_back(c);
    }
    if (!all_usable) grid.clear();
  }
  if (grid.size() == o.count) {
    MatrixXd Ag, Pg;
    candidate_rows(robot, design, effects, backlash, grid, Ag, Pg);
    if (grid.size() == o.count) plan.grid_assessment = assess("grid", Ag);
    plan.grid.has_role = true;
    plan.grid.has_dir = backlash;
    for (std::size_t k = 0; k < grid.size(); ++k) {
      PoseRow row;
      row.id = "G" + std::to_string(k + 1);
      row.commanded = grid[k].xyzrpy;
      if (backlash) row.dir = grid[k].dir;
      plan.grid.rows.push_back(row);
    }
  } else {
    plan.notes.push_back("no grid of " + std::to_string(o.count) + " usable poses was found to compare with");
  }
}

// The options a plan cannot start without.
void check_options(const PlanOptions& o) {
  if (!(o.noise_mm > 0) || !std::isfinite(o.noise_mm)) throw InputError("", 0, 0, "the noise level must be positive");
  if (!(o.margin >= 0 && o.margin < 0.5)) throw InputError("", 0, 0, "the margin must lie in [0, 0.5)");
  if (!(o.prior_mm > 0)) throw InputError("", 0, 0, "the prior must be positive");
  // Each candidate keeps its design rows (a few KiB): a million is ~10 GiB.
  if (o.sample_count > 200000) throw InputError("", 0, 0, "at most 200000 sampled candidates (--samples)");
}

// Enough measured coordinates for the parameters, and enough usable
// candidates for the poses asked: otherwise a one-line error saying what to
// change (the first refused candidate named).
template <class Progress>
void require_enough_poses(const Robot& robot, const PlanOptions& o, Index p, Index r, std::size_t usable,
                          const std::string& first_rejected, MeasurementPlan& plan, const Progress& progress) {
  if (Index(o.count) * r < p) {
    const Index need = (p + r - 1) / r;
    throw InputError("", 0, 0,
                     std::to_string(o.count) + " poses give " + std::to_string(Index(o.count) * r) +
                         " measured coordinates for " + std::to_string(p) + " parameters; plan at least " +
                         std::to_string(need) + " poses (more than that to see the noise)");
  }
  progress(std::to_string(usable) + " usable candidate poses of " + std::to_string(plan.candidates));
  plan.usable_candidates = usable;
  if (usable < o.count + o.test_count)
    throw InputError(o.candidates.rows.empty() ? robot.name : o.candidates.file, 0, 0,
                     std::to_string(usable) + " of " + std::to_string(plan.candidates) +
                         " candidate poses are usable (reachable inside the limits with a margin of " +
                         fixed(100 * o.margin, 1) + " %, away from singularities), fewer than the " +
                         std::to_string(o.count + o.test_count) + " asked for" +
                         (first_rejected.empty() ? std::string() : "; first rejected: " + first_rejected));

}

// n indices spread evenly over 0..size − 1 (all of them when size ≤ n).
std::vector<Index> even_sample(std::size_t size, std::size_t n) {
  std::vector<Index> out;
  n = std::min(size, n);
  for (std::size_t k = 0; k < n; ++k) out.push_back(Index(k * size / n));
  return out;
}

// `count` pool poses drawn at random (the random design compared with).
std::vector<Index> random_poses(std::size_t pool_size, std::size_t count, std::mt19937_64& rng) {
  std::vector<Index> all(pool_size);
  std::iota(all.begin(), all.end(), 0);
  std::shuffle(all.begin(), all.end(), rng);
  all.resize(count);
  return all;
}

// The rows (r per pose) of poses `idx` of a stacked matrix.
MatrixXd pose_rows(const MatrixXd& stacked, const std::vector<Index>& idx, Index r) {
  MatrixXd out(Index(idx.size()) * r, stacked.cols());
  for (std::size_t k = 0; k < idx.size(); ++k) out.middleRows(Index(k) * r, r) = stacked.middleRows(idx[k] * r, r);
  return out;
}

// Combinations of parameters the planned poses leave unseen: why (one or two
// targets cannot show a rotation) and what would show them.
void note_unseen_combinations(const Robot& robot, const DesignRows& design, Index unseen_count,
                              std::vector<std::string>& notes) {
  const std::string unseen = std::to_string(unseen_count) + " combination" +
                             (unseen_count > 1 ? "s" : "") + " of the parameters";
  const std::size_t targets = robot.targets.size();
  if (design.measure().find("target position") != std::string::npos && targets < 3)
    notes.push_back(unseen + " no pose can show: " +
                         (targets == 1 ? std::string("one target's position does not measure the orientation")
                                       : std::string("two targets do not measure the rotation about their line")) +
                         "; they are left to the prior (in the predicted errors). " +
                         (targets == 1 ? std::string("Two more targets, not in line with it, measure them")
                                       : std::string("A third target off that line measures them")));
  else
    notes.push_back(unseen + " stay unseen by the planned poses; they are left to the prior (in the "
                                  "predicted errors). More poses, or candidates that move in more ways, may "
                                  "show them");
}

}  // namespace

// ---------------------------------------------------------------- the plan

// The plan as its steps: the effects in the criterion, the candidate poses,
// their design rows, the prior, the D-optimal choice, the evaluation poses,
// the planned design's numbers against random and hand-grid ones, and the
// poses in motion order. The steps draw from one random stream, in this
// order: the candidates and their approach directions, the random design,
// the grid's tilts and directions — so a seed gives the same plan.
MeasurementPlan plan_measurements(const Robot& robot, const PlanOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  auto progress = [&](const std::string& s) {
    if (o.progress) o.progress(s);
  };
  MeasurementPlan plan;
  check_options(o);
  const PlannedEffects planned = planned_effects(robot, o, plan);
  const std::vector<const Effect*>& effects = planned.effects;
  const bool backlash = planned.backlash;

  DesignRows design(robot, o, plan.notes);
  plan.rows_per_pose = std::size_t(design.rows_per_pose());
  plan.measure = design.measure();
  const Workspace workspace(robot, o);
  std::mt19937_64 rng(o.seed);

  const Vec6<double> home = robot.home_pose().to_xyz_rpy();
  const Reach reach = axis_reach(robot, workspace, home);
  std::string first_rejected;
  std::vector<Candidate> pool = candidate_pool(o, workspace, home, reach, backlash, rng, plan, first_rejected);

  for (const Effect* e : effects) design.add_effect(e);
  const Index r = design.rows_per_pose();

  MatrixXd A, P;
  candidate_rows(robot, design, effects, backlash, pool, A, P);
  keep_identifiable_columns(design, pool.size(), A, P);
  const Index p = design.parameters();

  plan.parameter_names = design.names();
  require_enough_poses(robot, o, p, r, pool.size(), first_rejected, plan, progress);

  // The prior: parameter j moves the measured points by prior_mm RMS over
  // the pool. Scaling each column by its prior standard deviation τ_j makes
  // the prior precision the identity.
  const VectorXd tau = prior_scale(design, A, pool.size(), o.prior_mm);
  const MatrixXd As = A * tau.asDiagonal();

  // The poses: D-optimal on the prior-scaled rows.
  const std::vector<Index> chosen = choose_poses(As, r, o, pool.size(), plan, progress);
  std::vector<bool> in(pool.size(), false);
  for (Index c : chosen) in[std::size_t(c)] = true;

  // Evaluation poses for the predicted held-out error: the held-out poses
  // chosen after the plan (--test), or an even sample of the pool.
  const std::vector<Index> test =
      o.test_count > 0 ? held_out_poses(pool, home, reach, o.test_count, in) : std::vector<Index>();
  const std::vector<Index> evaluation = o.test_count > 0 ? test : even_sample(pool.size(), 300);
  plan.evaluation_poses = evaluation.size();
  const MatrixXd Pes = pose_rows(P, evaluation, 3) * tau.asDiagonal();

  // The numbers of a design (its whitened rows A_d).
  const DesignAssessor assess{robot, design, effects, tau, Pes, evaluation.size()};
  plan.planned = assess("planned", pose_rows(A, chosen, r));
  if (plan.planned.rank < p) note_unseen_combinations(robot, design, p - plan.planned.rank, plan.notes);

  // Random: as many pool poses drawn at random (the same seed).
  if (o.compare) plan.random_assessment = assess("random", pose_rows(A, random_poses(pool.size(), o.count, rng), r));

  // Grid: what a user lays out by hand.
  if (o.compare) compare_with_hand_grid(robot, o, workspace, home, reach, backlash, design, effects, assess, rng, plan);

  // The plan's poses, cal and test together, in the order to measure them.
  motion_ordered_poses(robot, workspace, pool, chosen, test, backlash, plan);
  plan.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return plan;
}

void add_plan_hints(const Robot& robot, Diagnosis& d) {
  PlanOptions po;
  for (const EffectTest& t : d.ranking)
    if (t.testable && t.confounded > 0.9 && t.effect != "thermal") po.effects.push_back(t.effect);
  po.count = std::min<std::size_t>(d.rms.cal_nodes, 150);
  po.sample_count = 2 * po.count;
  po.max_exchange_passes = 0;
  po.compare = false;
  po.noise_mm = d.noise_um > 0 ? d.noise_um * 1e-3 : 0.005;
  if (po.effects.empty() || po.count == 0) return;
  try {
    const MeasurementPlan plan = plan_measurements(robot, po);
    std::string list;
    for (const std::string& e : plan.effects) list += (list.empty() ? "" : ",") + e;
    for (EffectTest& t : d.ranking)
      for (const PlanConfounding& c : plan.planned.confounding)
        if (c.effect == t.effect) {
          t.plan_confounded = c.share;
          t.plan_count = po.count;
          t.plan_effects = list;
        }
  } catch (const InputError&) {
    // No plan of this size for this machine (too few usable poses): no hint.
  }
}

}  // namespace kincal::identify
