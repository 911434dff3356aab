// The 6-RUS error model (identify/rus6_error_model.hpp): the parameter table
// (simulate --errors, MODEL.json), the machine with errors, the error twists,
// and the error parameters as the target fit and the planner see them
// (family_errors.hpp).
#include "kincal/identify/rus6_error_model.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <string>

#include "families/family_errors.hpp"
#include "families/rus6/rus6_family.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/target_measurement.hpp"

namespace kincal::identify {

namespace {

// Turns leg i's motor frame (a_i, z_i; y_i = a_i × z_i follows) by `angle`
// about the unit `axis` through its shaft point.
void turn_motor(Rus6Geometry<double>& g, int i, const Vec3<double>& axis, double angle) {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
  g.shaft_axes.col(i) = R * g.shaft_axes.col(i);
  g.crank_zero.col(i) = R * g.crank_zero.col(i);
}

Vec3<double> crank_y(const Rus6Geometry<double>& g, int i) {
  return Vec3<double>(g.shaft_axes.col(i)).cross(Vec3<double>(g.crank_zero.col(i)));
}

// The table (header comment), leg by leg. The tilts turn the CURRENT frame:
// applied in table order (apply_parameters keeps it), about y_i then about
// the turned z_i, which is rus6_with_errors's composition.
std::vector<ParameterSpec> rus6_table() {
  std::vector<ParameterSpec> t;
  const char* const axes[3] = {"x", "y", "z"};
  for (int i = 0; i < 6; ++i) {
    const std::string leg = std::to_string(i + 1);
    for (int a = 0; a < 3; ++a)
      t.push_back({std::string("ds") + axes[a] + leg, "mm",
                   "motor " + leg + " shaft point (crank circle centre) " + axes[a] + " (base frame)",
                   [i, a](Robot& r, double v) { r.rus6().shaft_points(a, i) += v; }});
    t.push_back({"dtilt_y" + leg, "rad", "motor " + leg + " shaft tilt about its crank frame's y (a x z)",
                 [i](Robot& r, double v) { turn_motor(r.rus6(), i, crank_y(r.rus6(), i), v); }});
    t.push_back({"dtilt_z" + leg, "rad", "motor " + leg + " shaft tilt about its crank-zero direction z",
                 [i](Robot& r, double v) {
                   turn_motor(r.rus6(), i, Vec3<double>(r.rus6().crank_zero.col(i)), v);
                 }});
    t.push_back({"dtheta" + leg, "rad", "motor " + leg + " crank zero = encoder offset (physical = command + this)",
                 [i](Robot& r, double v) { r.rus6().joint_offset(i) += v; }});
    t.push_back({"dcrank" + leg, "mm", "crank " + leg + " length",
                 [i](Robot& r, double v) { r.rus6().crank_length(i) += v; }});
    t.push_back({"drod" + leg, "mm", "rod " + leg + " length (sphere to sphere)",
                 [i](Robot& r, double v) { r.rus6().rod_length(i) += v; }});
    for (int a = 0; a < 3; ++a)
      t.push_back({std::string("dp") + axes[a] + leg, "mm",
                   "rod " + leg + " platform sphere " + axes[a] + " (platform frame)",
                   [i, a](Robot& r, double v) { r.rus6().platform_joints(a, i) += v; }});
  }
  return t;
}

const std::vector<ParameterSpec>& rus6_specs() {
  static const std::vector<ParameterSpec> table = rus6_table();
  return table;
}

}  // namespace

const std::vector<ParameterSpec>& Rus6FamilyErrorModel::parameter_specs(const Robot&) const { return rus6_specs(); }
                                                                        
Rus6Geometry<double> rus6_with_errors(const Rus6Geometry<double>& nominal, const Eigen::VectorXd& x) {
  Robot r;
  r.family_data = Rus6Description{nominal};
  const std::vector<ParameterSpec>& specs = rus6_specs();
  for (std::size_t k = 0; k < specs.size() && Eigen::Index(k) < x.size(); ++k)
    if (x(Eigen::Index(k)) != 0.0) specs[k].add(r, x(Eigen::Index(k)));
  return r.rus6();
}

namespace {

// rus6_error_twists of the machine g = nominal + x, given g.
bool error_twists(const Rus6Geometry<double>& nominal, const Rus6Geometry<double>& g, const Pose<double>& pose,
                  Eigen::Matrix<double, 6, Eigen::Dynamic>& T) {
  Vec6<double> q;
  Rus6Legs<double> legs;
  if (rus6_ik(g, pose, q, nullptr, &legs) != Status::Ok) return false;
  if (!rus6_levers_regular(g, legs)) return false;
  Mat6<double> K;
  rus6_wrenches_into(K, legs);
  const Eigen::PartialPivLU<Mat6<double>> lu(K);
  if (!(std::abs(lu.determinant()) > 0)) return false;
  const Mat6<double> K_inv = lu.inverse();
  T.resize(6, kRus6ParameterCount);
  for (int i = 0; i < 6; ++i) {
    const Vec3<double> u = legs.rod_units.col(i);
    const Vec3<double> crank = legs.crank_tips.col(i) - g.shaft_points.col(i);
    const Vec3<double> a = g.shaft_axes.col(i), z = g.crank_zero.col(i);
    // The tilt about y turns about the NOMINAL y_i (the first turn of the
    // composition R = R_y⁰(β_y)·R_z⁰(β_z)); the tilt about z about the
    // current z_i (= R_y⁰(β_y)·z_i⁰): both exact at any x.
    const Vec3<double> y0 = crank_y(nominal, i);
    Eigen::Matrix<double, 1, kRus6ParametersPerLeg> gi;
    gi.segment<3>(0) = -u.transpose();
    gi(3) = -u.dot(y0.cross(crank));
    gi(4) = -u.dot(z.cross(crank));
    gi(5) = -u.dot(a.cross(crank));
    gi(6) = -u.dot(crank) / g.crank_length(i);
    gi(7) = -1.0;
    gi.segment<3>(8) = u.transpose() * pose.R;
    T.middleCols<kRus6ParametersPerLeg>(kRus6ParametersPerLeg * i) = -K_inv.col(i) * gi;
  }
  return T.allFinite();
}

}  // namespace

bool rus6_error_twists(const Rus6Geometry<double>& nominal, const Eigen::VectorXd& x, const Pose<double>& pose,
                       Eigen::Matrix<double, 6, Eigen::Dynamic>& T) {
  return error_twists(nominal, x.size() > 0 ? rus6_with_errors(nominal, x) : nominal, pose, T);
}

namespace detail {
namespace {

// The 66 errors, the erroneous machine's exact FK, and the rigid-motion
// convention on the platform spheres (and, in the tracker's frame, the
// shaft points) with targets.
class Rus6Errors final : public FamilyErrors {
 public:
  explicit Rus6Errors(const Robot& robot) : robot_(robot), g_(robot.rus6()), with_errors_(g_) {}
  int size() const override { return kRus6ParameterCount; }
  std::vector<std::string> names() const override { return parameter_names(robot_); }
  std::vector<std::string> units() const override {
    std::vector<std::string> u;
    for (const ParameterSpec& s : rus6_specs()) u.push_back(s.unit);
    return u;
  }
  NodeGuess start(const Pose<double>& commanded) const override { return {commanded, {}}; }
  bool pose(const Eigen::VectorXd& errors, const Vec6<double>& q, NodeGuess& guess, Pose<double>& pose) const override {
    if (rus6_fk(with_errors(errors), q, guess.pose, pose).status != Status::Ok) return false;
    guess.pose = pose;
    return true;
  }
  Eigen::MatrixXd twist_columns(const Eigen::VectorXd& errors, const Pose<double>& pose) const override {
    Eigen::Matrix<double, 6, Eigen::Dynamic> T;
    if (!error_twists(g_, with_errors(errors), pose, T)) T.setConstant(6, kRus6ParameterCount, std::nan(""));
    return T;
  }
  bool nominal_twist_columns(const Pose<double>& pose, Eigen::MatrixXd& T) const override {
    Eigen::Matrix<double, 6, Eigen::Dynamic> t;
    if (!rus6_error_twists(g_, Eigen::VectorXd(), pose, t)) return false;
    T = t;
    return true;
  }
  // Full poses in the base frame fix every parameter. A rigid motion of all
  // platform spheres with the targets changes no target position; in the
  // tracker's frame neither does one of all shaft points with the
  // registration: their errors carry no net rigid motion.
  Eigen::MatrixXd convention_rows(const TargetLayout& layout, const Eigen::MatrixXd&, double) const override {
    if (layout.targets == 0) return Eigen::MatrixXd::Zero(0, layout.size());
    Eigen::MatrixXd C = Eigen::MatrixXd::Zero(layout.registration ? 12 : 6, layout.size());
    const Eigen::Matrix<double, 6, Eigen::Dynamic> spheres = rigid_motion_rows(g_.platform_joints);
    const Eigen::Matrix<double, 6, Eigen::Dynamic> shafts = rigid_motion_rows(g_.shaft_points);
    for (int i = 0; i < 6; ++i) {
      C.block<6, 3>(0, kRus6ParametersPerLeg * i + 8) = spheres.middleCols<3>(3 * i);
      if (layout.registration) C.block<6, 3>(6, kRus6ParametersPerLeg * i) = shafts.middleCols<3>(3 * i);
    }
    return C;
  }
  std::string convention() const override {
    return "with targets, the platform spheres' errors (and, in the instrument frame, the shaft points') carry no "
           "net rigid motion";
  }

 private:
  // The machine g_ + errors: a fit asks for the same errors at every node of
  // an evaluation and of a linearisation, and rus6_with_errors applies the
  // 66 parameters through their specs (a Robot each time): kept for the last
  // errors asked for (20 M instructions of a 6-RUS diagnosis; #33). One fit
  // owns its FamilyErrors (family_errors()), so no two threads share it.
  const Rus6Geometry<double>& with_errors(const Eigen::VectorXd& errors) const {
    if (!(errors.size() == errors_.size() && errors == errors_)) {
      with_errors_ = rus6_with_errors(g_, errors);
      errors_ = errors;
    }
    return with_errors_;
  }

  Robot robot_;
  Rus6Geometry<double> g_;
  mutable Eigen::VectorXd errors_;              // empty: g_ itself
  mutable Rus6Geometry<double> with_errors_;
};

}  // namespace
}  // namespace detail

std::unique_ptr<detail::FamilyErrors> Rus6FamilyErrorModel::errors(const Robot& open) const {
  return std::make_unique<detail::Rus6Errors>(open);
}

}  // namespace kincal::identify
