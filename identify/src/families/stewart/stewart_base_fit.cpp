// seed 001's base fit (the iterated least squares) as a linear problem at
// its solution: StewartFamilyPipeline::fit_base.
#include "effects/base_fit.hpp"
#include "families/stewart/stewart_family.hpp"
#include "kincal/core/stewart.hpp"
#include "kincal/identify/joint_limits.hpp"
#include "kincal/identify/stewart_calibration.hpp"

namespace kincal::identify {

detail::BaseModel StewartFamilyPipeline::fit_base(const Robot& robot, const PoseTable& data,
                                                  const std::vector<std::optional<EffectNode>>& en,
                                                  std::optional<EstimatorKind>, bool, double) const {
  using namespace detail;  // seed 001's model is fitted by OLS, to its minimum
  const StewartCalibration cal = calibrate_stewart(robot, data);
  const StewartGeometry<double> g = stewart_with_errors(without_limits(robot.stewart()), cal.theta);  // measured rows: no limits
  BaseModel base;
  base.parameters = stewart_parameter_count(robot);
  base.description = "seed 001 " + std::to_string(base.parameters) + "-parameter model" +
                     (robot.stewart_description().models_leg_offsets ? " with leg offsets" : "") + " (iterated LS, " +
                     std::to_string(cal.history.size()) + " rounds)";
  Vec6<double> w;
  w << 1, 1, 1, kOrientationWeightMm, kOrientationWeightMm, kOrientationWeightMm;
  for (std::size_t k = 0; k < data.rows.size(); ++k) {
    const PoseRow& row = data.rows[k];
    if (!row.measured || !usable_row(row) || !en[k]) continue;
    const Pose<double> measured = Pose<double>::from_xyz_rpy(*row.measured);
    Pose<double> predicted;
    if (stewart_fk(g, joints_of(row, *en[k]), measured, predicted).status != Status::Ok) continue;
    NodeData n;
    n.row = k;
    n.test = row.role == Role::Test;
    n.pose_rows = true;
    n.r = w.asDiagonal() * pose_error(measured, predicted);
    n.M = w.asDiagonal();
    n.H = w.asDiagonal() * stewart_error_jacobian(g, predicted, robot.stewart_description().models_leg_offsets);
    n.effect = *en[k];
    base.nodes.push_back(std::move(n));
  }
  base.model = stewart_model(robot, cal, data.file);
  return base;
}

}  // namespace kincal::identify
