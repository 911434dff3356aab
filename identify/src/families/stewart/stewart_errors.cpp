// The 6-UPS's error parameters as the target fit and the planner see them
// (family_errors.hpp).
#include "families/stewart/stewart_family.hpp"
#include "families/family_errors.hpp"
#include "kincal/core/stewart.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/stewart_calibration.hpp"
#include "kincal/identify/target_measurement.hpp"

namespace kincal::identify {

namespace detail {
namespace {

// seed 001's 42 errors (per leg dXB dYB dZB dl dXP dYP dZP; then dsq1..dsq6
// for a robot with leg_offset_sq), the corrected machine's exact FK, and the
// rigid-motion convention on its joints.
class StewartErrors final : public FamilyErrors {
 public:
  explicit StewartErrors(const Robot& robot) : robot_(robot), g_(robot.stewart()) {}
  int size() const override { return stewart_parameter_count(robot_); }
  std::vector<std::string> names() const override { return parameter_names(robot_); }
  std::vector<std::string> units() const override {
    std::vector<std::string> u;
    for (const ParameterSpec& s : parameter_specs(robot_)) u.push_back(s.unit);
    return u;
  }
  NodeGuess start(const Pose<double>& commanded) const override { return {commanded, {}}; }
  bool pose(const Eigen::VectorXd& errors, const Vec6<double>& q, NodeGuess& guess, Pose<double>& pose) const override {
    if (stewart_fk(stewart_with_errors(g_, errors), q, guess.pose, pose).status != Status::Ok) return false;
    guess.pose = pose;
    return true;
  }
  Eigen::MatrixXd twist_columns(const Eigen::VectorXd& errors, const Pose<double>& pose) const override {
    return stewart_error_jacobian(stewart_with_errors(g_, errors), pose,
                                  robot_.stewart_description().models_leg_offsets);
  }
  bool nominal_twist_columns(const Pose<double>& pose, Eigen::MatrixXd& T) const override {
    T = stewart_error_jacobian(g_, pose, robot_.stewart_description().models_leg_offsets);
    return true;
  }
  // A rigid motion of all platform joints (with the targets) changes no
  // measurement; in the instrument frame neither does one of all base joints
  // (with the registration): their errors carry no net rigid motion.
  Eigen::MatrixXd convention_rows(const TargetLayout& layout, const Eigen::MatrixXd&, double) const override {
    Eigen::MatrixXd C = Eigen::MatrixXd::Zero(layout.registration ? 12 : 6, layout.size());
    const Eigen::Matrix<double, 6, Eigen::Dynamic> platform = rigid_motion_rows(g_.platform);
    const Eigen::Matrix<double, 6, Eigen::Dynamic> base = rigid_motion_rows(g_.base);
    for (int i = 0; i < 6; ++i) {
      C.block<6, 3>(0, 7 * i + 4) = platform.middleCols<3>(3 * i);
      if (layout.registration) C.block<6, 3>(6, 7 * i) = base.middleCols<3>(3 * i);
    }
    return C;
  }
  std::string convention() const override {
    return "the platform joints' errors (and, in the instrument frame, the base joints') carry no net rigid motion";
  }

 private:
  Robot robot_;
  StewartGeometry<double> g_;
};

}  // namespace
}  // namespace detail

std::unique_ptr<detail::FamilyErrors> StewartFamilyErrorModel::errors(const Robot& open) const {
  return std::make_unique<detail::StewartErrors>(open);
}

}  // namespace kincal::identify
