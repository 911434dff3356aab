// hybrid_residuals: gauge residuals turned into pose error twists (seed 000
// Eq. (9)) per role and layer, before and after calibration.
#include <gtest/gtest.h>

#include "kincal/identify/hybrid_calibration.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/simulate.hpp"

using namespace kincal;
using namespace kincal::identify;

namespace {

PoseTable measure(const Robot& nominal, const std::string& errors_csv, double noise_mm) {
  const Robot actual = apply_parameters(nominal, parse_parameters(errors_csv, "e.csv", nominal));
  SimulateOptions o;
  o.noise_mm = noise_mm;
  o.seed = 17;
  SimulateReport rep;
  return simulate(nominal, actual, read_pose_table(std::string(KINCAL_SOURCE_DIR) + "/examples/hybrid-seed000/poses.csv"),
                  o, rep);
}

}  // namespace

TEST(identifyHybridResiduals, ZeroForTheNominalMachineAndRecoversAKnownTwist) {
  const Robot nominal = builtin_robot("hybrid-seed000");
  const PoseTable exact = measure(nominal, "name,value\n", 0.0);
  const PoseErrorReport r = hybrid_residuals(nominal, nullptr, exact);
  EXPECT_EQ(r.rows.size(), 147u);
  EXPECT_LT(r.all.max_position_mm, 1e-9);
  // An encoder offset alone: the gauge-derived twist equals the pose error the
  // simulator reports from the measured pose, node by node.
  const PoseTable off = measure(nominal, "name,value\ndxi_3_1,0.2\n", 0.0);
  const PoseErrorReport e = hybrid_residuals(nominal, nullptr, off);
  const PoseErrorReport direct = pose_errors(off);
  ASSERT_EQ(e.rows.size(), direct.rows.size());
  double worst = 0;
  for (std::size_t k = 0; k < e.rows.size(); ++k) worst = std::max(worst, (e.rows[k].error - direct.rows[k].error).norm());
  EXPECT_LT(worst, 1e-3 * direct.all.max_position_mm);  // second order in the ~0.2 mm error
  EXPECT_GT(e.all.mean_position_mm, 0.05);
  EXPECT_EQ(e.groups.at("layer 2 (test)").count, 49u);
}

TEST(identifyHybridResiduals, CalibrationBringsTestLayerResidualsToTheNoise) {
  const Robot nominal = builtin_robot("hybrid-seed000");
  const PoseTable data = measure(nominal,
                                 "name,value\ndxi_3_1,0.3\ndxi_3_2,-0.25\ndxi_5_4,-0.0004\ndx_0_1,0.04\ndy_6_4,-0.04\n",
                                 0.0);
  const HybridCalibration c = calibrate_hybrid(nominal, data);
  const HybridCompensation comp = c.compensation(EstimatorKind::Liu);
  const PoseErrorReport before = hybrid_residuals(nominal, nullptr, data);
  const PoseErrorReport after = hybrid_residuals(nominal, &comp, data);
  EXPECT_GT(before.groups.at("test").rms_position_mm, 0.3);
  EXPECT_LT(after.groups.at("test").rms_position_mm, 0.005);  // noise-free: what the identifiable set leaves
  EXPECT_EQ(c.cal_ids.size(), 98u);
  EXPECT_EQ(c.cal_ids.front(), "L1-11");
}
