// Generated from examples/firmware/model.json by kincal 0.1.0 (`kincal table`). Do not edit:
// regenerate it (the static_asserts below reject an edited value).
//
// robot: hybrid-seed000 (hybrid-3ups-up-3r), estimator: liu, data: measured.csv
// Table format version 4 (core/calibration_table.hpp); values in its canonical order, 17 significant
// digits (exact round trip), lengths in mm, angles in rad. The calibration table is what
// `kincal compensate` runs on for this model; the nominal table is the firmware's fallback
// when the calibration table fails its start-up check (docs/firmware.md).
#pragma once

#include <cmath>
#include <cstdint>

#include "kincal/core/calibration_table.hpp"
#include "kincal/core/formula_effects.hpp"
#include "kincal/core/machine_limits.hpp"

static_assert(::kincal::kCalibrationTableVersion == 4,
              "generated for calibration table format version 4; regenerate with this kincal");

namespace kincal::generated {

inline constexpr const char* kModelFile = "examples/firmware/model.json";
inline constexpr const char* kRobot = "hybrid-seed000";
inline constexpr const char* kGenerator = "kincal 0.1.0";
inline constexpr ::kincal::MachineFamily kFamily = ::kincal::MachineFamily::Hybrid;
inline constexpr std::uint32_t kFormatVersion = 4;
template <class Scalar> using Machine = ::kincal::HybridMachine<Scalar>;

// The machine limits (core/machine_limits.hpp), from the nominal robot description,
// never from identified values: the controller checks the tables against them. A port
// may replace them with limits of its own (its drives' travel).
inline constexpr ::kincal::MachineLimits<double> kLimits_double = {
    {628.0, 628.0, 628.0, -2.8999999999999999, -1.3999999999999999, -1.3999999999999999},  // min_joint
    {1178.0, 1178.0, 1178.0, 2.8999999999999999, 1.3999999999999999, 1.3999999999999999},  // max_joint
    {5.0, 5.0, 5.0, 0.02, 0.02, 0.02},  // max_correction
    10.0, 0.01, 0.001, 0.10000000000000001};  // max_geometry_error, max_scale, max_thermal, max_angle_error

inline constexpr ::kincal::MachineLimits<float> kLimits_float = {
    {628.0, 628.0, 628.0, -2.9000000953674316, -1.3999999761581421, -1.3999999761581421},  // min_joint
    {1178.0, 1178.0, 1178.0, 2.9000000953674316, 1.3999999761581421, 1.3999999761581421},  // max_joint
    {5.0, 5.0, 5.0, 0.019999999552965164, 0.019999999552965164, 0.019999999552965164},  // max_correction
    10.0, 0.0099999997764825821, 0.0010000000474974513, 0.10000000149011612};  // max_geometry_error, max_scale, max_thermal, max_angle_error

inline constexpr double kCalibrationValues_double[303] = {
    // machine.nominal.base_joints
    2.1431318985078682e-14, 350.0, 0.0, -303.10889132455367, -174.99999999999977, 0.0, 303.10889132455344, -175.00000000000014, 0.0,
    // machine.nominal.platform_joints
    8.2663658942446335e-15, 135.0, 0.0, -116.91342951089928, -67.499999999999915, 0.0, 116.91342951089918, -67.500000000000057, 0.0,
    // machine.nominal.platform_to_wrist
    405.0,
    // machine.nominal.wrist_link
    120.0,
    // machine.nominal.tool_length
    250.0,
    // machine.nominal.workpiece_rotation
    1.9229626863835643e-16, 1.0, 1.1102230246251564e-16, 0.86602540378443882, -2.2204460492503131e-16, 0.49999999999999994, 0.49999999999999994, 0.0, -0.86602540378443882,
    // machine.nominal.workpiece_origin
    0.0, -184.99999999999994, 1575.4293994002423,
    // machine.nominal.tool_offset
    1.9229626863835643e-16, 1.0000000000000002, 0.0, 1.0, -1.9229626863835641e-16, 1.1102230246251563e-16, 1.1102230246251564e-16, 0.0, -1.0000000000000002,
    // machine.nominal.joint_offset
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // machine.nominal.min_joint
    628.0, 628.0, 628.0, -2.8999999999999999, -1.3999999999999999, -1.3999999999999999,
    // machine.nominal.max_joint
    1178.0, 1178.0, 1178.0, 2.8999999999999999, 1.3999999999999999, 1.3999999999999999,
    // machine.nominal.min_extension
    400.0,
    // machine.nominal.max_extension
    1400.0,
    // machine.nominal.home
    0.0, 0.0, 850.0,
    // machine.nominal.characteristic_length
    1000.0,
    // machine.up_split
    345.0,
    // machine.encoder_offsets
    0.39511769299799115, -0.14943435943912547, 0.21465961555432553, 0.00039284890179797668, -0.00041635285485834133, 0.00035285983603009668,
    // machine.source_errors (Δχ̂ of seed 000 Eq. (7), identify's HybridErrorModel order)
    0.0,  // dxi_3_1 mm
    0.0,  // dxi_3_2 mm
    0.0,  // dxi_3_3 mm
    0.0,  // dxi_4_4 rad
    0.0,  // dxi_5_4 rad
    0.0,  // dxi_6_4 rad
    0.022518035069926515,  // dx_0_1 mm
    -0.0049661720112016564,  // dy_0_1 mm
    0.008152314564684628,  // dz_0_1 mm
    0.0,  // dalpha_0_1 rad
    0.0,  // dbeta_0_1 rad
    0.0,  // dgamma_0_1 rad
    0.0,  // dx_1_1 mm
    0.0,  // dy_1_1 mm
    0.0,  // dz_1_1 mm
    0.0,  // dalpha_1_1 rad
    0.0,  // dbeta_1_1 rad
    0.0,  // dx_2_1 mm
    0.01197526706996741,  // dy_2_1 mm
    0.0,  // dz_2_1 mm
    0.0,  // dalpha_2_1 rad
    0.0,  // dbeta_2_1 rad
    0.0,  // dx_3_1 mm
    0.0,  // dy_3_1 mm
    0.0,  // dalpha_3_1 rad
    0.0,  // dbeta_3_1 rad
    0.0,  // dgamma_3_1 rad
    0.0,  // dx_4_1 mm
    0.0,  // dy_4_1 mm
    0.0,  // dz_4_1 mm
    0.0,  // dalpha_4_1 rad
    0.0,  // dbeta_4_1 rad
    0.0,  // dx_5_1 mm
    -1.2818278669469709,  // dy_5_1 mm
    -0.26265015109732565,  // dz_5_1 mm
    0.0,  // dalpha_5_1 rad
    0.0,  // dbeta_5_1 rad
    -0.013728479855399841,  // dx_6_1 mm
    0.0,  // dy_6_1 mm
    0.0,  // dz_6_1 mm
    0.0,  // dalpha_6_1 rad
    0.0,  // dbeta_6_1 rad
    0.0013893236188409182,  // dx_0_2 mm
    -0.036518765006415543,  // dy_0_2 mm
    0.017358650751580745,  // dz_0_2 mm
    0.0,  // dalpha_0_2 rad
    0.0,  // dbeta_0_2 rad
    0.0,  // dgamma_0_2 rad
    0.0,  // dx_1_2 mm
    0.0,  // dy_1_2 mm
    0.0,  // dz_1_2 mm
    0.0,  // dalpha_1_2 rad
    0.0,  // dbeta_1_2 rad
    0.0,  // dx_2_2 mm
    0.010274233522417603,  // dy_2_2 mm
    0.0,  // dz_2_2 mm
    0.0,  // dalpha_2_2 rad
    0.0,  // dbeta_2_2 rad
    0.0,  // dx_3_2 mm
    0.0,  // dy_3_2 mm
    0.0,  // dalpha_3_2 rad
    0.0,  // dbeta_3_2 rad
    0.0,  // dgamma_3_2 rad
    0.0,  // dx_4_2 mm
    0.0,  // dy_4_2 mm
    0.0,  // dz_4_2 mm
    0.0,  // dalpha_4_2 rad
    0.0,  // dbeta_4_2 rad
    0.0,  // dx_5_2 mm
    -1.2657097488648299,  // dy_5_2 mm
    -0.37711455986211412,  // dz_5_2 mm
    0.0,  // dalpha_5_2 rad
    0.0,  // dbeta_5_2 rad
    -0.054156442094490796,  // dx_6_2 mm
    0.0,  // dy_6_2 mm
    0.0,  // dz_6_2 mm
    0.0,  // dalpha_6_2 rad
    0.0,  // dbeta_6_2 rad
    -0.0056205656252518053,  // dx_0_3 mm
    -0.0077203744322385925,  // dy_0_3 mm
    0.054614803700068049,  // dz_0_3 mm
    0.0,  // dalpha_0_3 rad
    0.0,  // dbeta_0_3 rad
    0.0,  // dgamma_0_3 rad
    0.0,  // dx_1_3 mm
    0.0,  // dy_1_3 mm
    0.0,  // dz_1_3 mm
    0.0,  // dalpha_1_3 rad
    0.0,  // dbeta_1_3 rad
    0.0,  // dx_2_3 mm
    0.030356803839035613,  // dy_2_3 mm
    0.0,  // dz_2_3 mm
    0.0,  // dalpha_2_3 rad
    0.0,  // dbeta_2_3 rad
    0.0,  // dx_3_3 mm
    0.0,  // dy_3_3 mm
    0.0,  // dalpha_3_3 rad
    0.0,  // dbeta_3_3 rad
    0.0,  // dgamma_3_3 rad
    0.0,  // dx_4_3 mm
    0.0,  // dy_4_3 mm
    0.0,  // dz_4_3 mm
    0.0,  // dalpha_4_3 rad
    0.0,  // dbeta_4_3 rad
    0.0,  // dx_5_3 mm
    -1.3576543523225355,  // dy_5_3 mm
    -0.37143811501176416,  // dz_5_3 mm
    0.0,  // dalpha_5_3 rad
    0.0,  // dbeta_5_3 rad
    0.077271295348617791,  // dx_6_3 mm
    0.0,  // dy_6_3 mm
    0.0,  // dz_6_3 mm
    0.0,  // dalpha_6_3 rad
    0.0,  // dbeta_6_3 rad
    0.064941254490770511,  // dx_0_4 mm
    0.032706101223514264,  // dy_0_4 mm
    0.030463930515289971,  // dz_0_4 mm
    0.0,  // dalpha_0_4 rad
    -5.8201847053828392e-05,  // dbeta_0_4 rad
    2.6020662585420698e-05,  // dgamma_0_4 rad
    0.0,  // dx_1_4 mm
    0.0,  // dy_1_4 mm
    0.0,  // dz_1_4 mm
    0.0,  // dalpha_1_4 rad
    0.0,  // dbeta_1_4 rad
    0.0,  // dx_2_4 mm
    0.0017945222054865121,  // dy_2_4 mm
    -0.1127425272082245,  // dz_2_4 mm
    0.0,  // dalpha_2_4 rad
    -0.00012432845660472633,  // dbeta_2_4 rad
    -0.088811866048699104,  // dx_3_4 mm
    0.0,  // dy_3_4 mm
    -1.7964337942640931e-06,  // dalpha_3_4 rad
    0.0,  // dbeta_3_4 rad
    -4.4306834062202875e-05,  // dgamma_3_4 rad
    0.087910806368726391,  // dx_4_4 mm
    0.0060808783499935034,  // dy_4_4 mm
    -1.3506457201021771,  // dz_4_4 mm
    -1.3068754371212904e-05,  // dalpha_4_4 rad
    -1.68792870559463e-05,  // dbeta_4_4 rad
    0.0,  // dx_5_4 mm
    0.0044959046556039065,  // dy_5_4 mm
    0.031671122757714089,  // dz_5_4 mm
    0.0,  // dalpha_5_4 rad
    3.9914416279370462e-05,  // dbeta_5_4 rad
    0.0,  // dx_6_4 mm
    -0.020973340276806141,  // dy_6_4 mm
    0.0,  // dz_6_4 mm
    0.0,  // dalpha_6_4 rad
    3.0344277496188283e-05,  // dbeta_6_4 rad
    0.0,  // dx_7_4 mm
    0.0,  // dy_7_4 mm
    0.0,  // dz_7_4 mm
    0.0,  // dalpha_7_4 rad
    0.0,  // dbeta_7_4 rad
    0.0,  // dgamma_7_4 rad
    // effects.scale
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.backlash
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.compliance
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.cyclic_sin
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.cyclic_cos
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.thermal
    0.0,
    // effects.screw_lead
    5.0,
    // effects.screw_joints
    7.0,
    // effects.load_direction
    -0.49999999999999994, 0.0, 0.86602540378443882,
    // effects.thermal_origin
    -627.49999999999989, -4.1078251911130779e-14, 1456.8618817494707,
    // effects.reference_temperature
    20.0,
    // effects.user
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // bounds.max_correction
    5.0, 5.0, 5.0, 0.02, 0.02, 0.02,
    // bounds.min_joint
    628.0, 628.0, 628.0, -2.8999999999999999, -1.3999999999999999, -1.3999999999999999,
    // bounds.max_joint
    1178.0, 1178.0, 1178.0, 2.8999999999999999, 1.3999999999999999, 1.3999999999999999,
};
inline constexpr std::uint32_t kCalibrationCrc_double = 0x33E673BEu;
inline constexpr ::kincal::CalibrationTable<::kincal::HybridMachine<double>> kCalibrationTable_double =
    ::kincal::table_from_values<::kincal::HybridMachine<double>>(kCalibrationValues_double, kCalibrationCrc_double);
static_assert(::kincal::table_crc(kCalibrationTable_double) == kCalibrationCrc_double,
              "Calibration table (double): CRC mismatch, the values were edited or corrupted; regenerate with kincal table");
static_assert(::kincal::validate_table(kCalibrationTable_double, kLimits_double) == ::kincal::CompensationStatus::Ok,
              "Calibration table (double): fails validate_table (values, bounds, machine limits)");

inline constexpr double kNominalValues_double[303] = {
    // machine.nominal.base_joints
    2.1431318985078682e-14, 350.0, 0.0, -303.10889132455367, -174.99999999999977, 0.0, 303.10889132455344, -175.00000000000014, 0.0,
    // machine.nominal.platform_joints
    8.2663658942446335e-15, 135.0, 0.0, -116.91342951089928, -67.499999999999915, 0.0, 116.91342951089918, -67.500000000000057, 0.0,
    // machine.nominal.platform_to_wrist
    405.0,
    // machine.nominal.wrist_link
    120.0,
    // machine.nominal.tool_length
    250.0,
    // machine.nominal.workpiece_rotation
    1.9229626863835643e-16, 1.0, 1.1102230246251564e-16, 0.86602540378443882, -2.2204460492503131e-16, 0.49999999999999994, 0.49999999999999994, 0.0, -0.86602540378443882,
    // machine.nominal.workpiece_origin
    0.0, -184.99999999999994, 1575.4293994002423,
    // machine.nominal.tool_offset
    1.9229626863835643e-16, 1.0000000000000002, 0.0, 1.0, -1.9229626863835641e-16, 1.1102230246251563e-16, 1.1102230246251564e-16, 0.0, -1.0000000000000002,
    // machine.nominal.joint_offset
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // machine.nominal.min_joint
    628.0, 628.0, 628.0, -2.8999999999999999, -1.3999999999999999, -1.3999999999999999,
    // machine.nominal.max_joint
    1178.0, 1178.0, 1178.0, 2.8999999999999999, 1.3999999999999999, 1.3999999999999999,
    // machine.nominal.min_extension
    400.0,
    // machine.nominal.max_extension
    1400.0,
    // machine.nominal.home
    0.0, 0.0, 850.0,
    // machine.nominal.characteristic_length
    1000.0,
    // machine.up_split
    345.0,
    // machine.encoder_offsets
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // machine.source_errors (Δχ̂ of seed 000 Eq. (7), identify's HybridErrorModel order)
    0.0,  // dxi_3_1 mm
    0.0,  // dxi_3_2 mm
    0.0,  // dxi_3_3 mm
    0.0,  // dxi_4_4 rad
    0.0,  // dxi_5_4 rad
    0.0,  // dxi_6_4 rad
    0.0,  // dx_0_1 mm
    0.0,  // dy_0_1 mm
    0.0,  // dz_0_1 mm
    0.0,  // dalpha_0_1 rad
    0.0,  // dbeta_0_1 rad
    0.0,  // dgamma_0_1 rad
    0.0,  // dx_1_1 mm
    0.0,  // dy_1_1 mm
    0.0,  // dz_1_1 mm
    0.0,  // dalpha_1_1 rad
    0.0,  // dbeta_1_1 rad
    0.0,  // dx_2_1 mm
    0.0,  // dy_2_1 mm
    0.0,  // dz_2_1 mm
    0.0,  // dalpha_2_1 rad
    0.0,  // dbeta_2_1 rad
    0.0,  // dx_3_1 mm
    0.0,  // dy_3_1 mm
    0.0,  // dalpha_3_1 rad
    0.0,  // dbeta_3_1 rad
    0.0,  // dgamma_3_1 rad
    0.0,  // dx_4_1 mm
    0.0,  // dy_4_1 mm
    0.0,  // dz_4_1 mm
    0.0,  // dalpha_4_1 rad
    0.0,  // dbeta_4_1 rad
    0.0,  // dx_5_1 mm
    0.0,  // dy_5_1 mm
    0.0,  // dz_5_1 mm
    0.0,  // dalpha_5_1 rad
    0.0,  // dbeta_5_1 rad
    0.0,  // dx_6_1 mm
    0.0,  // dy_6_1 mm
    0.0,  // dz_6_1 mm
    0.0,  // dalpha_6_1 rad
    0.0,  // dbeta_6_1 rad
    0.0,  // dx_0_2 mm
    0.0,  // dy_0_2 mm
    0.0,  // dz_0_2 mm
    0.0,  // dalpha_0_2 rad
    0.0,  // dbeta_0_2 rad
    0.0,  // dgamma_0_2 rad
    0.0,  // dx_1_2 mm
    0.0,  // dy_1_2 mm
    0.0,  // dz_1_2 mm
    0.0,  // dalpha_1_2 rad
    0.0,  // dbeta_1_2 rad
    0.0,  // dx_2_2 mm
    0.0,  // dy_2_2 mm
    0.0,  // dz_2_2 mm
    0.0,  // dalpha_2_2 rad
    0.0,  // dbeta_2_2 rad
    0.0,  // dx_3_2 mm
    0.0,  // dy_3_2 mm
    0.0,  // dalpha_3_2 rad
    0.0,  // dbeta_3_2 rad
    0.0,  // dgamma_3_2 rad
    0.0,  // dx_4_2 mm
    0.0,  // dy_4_2 mm
    0.0,  // dz_4_2 mm
    0.0,  // dalpha_4_2 rad
    0.0,  // dbeta_4_2 rad
    0.0,  // dx_5_2 mm
    0.0,  // dy_5_2 mm
    0.0,  // dz_5_2 mm
    0.0,  // dalpha_5_2 rad
    0.0,  // dbeta_5_2 rad
    0.0,  // dx_6_2 mm
    0.0,  // dy_6_2 mm
    0.0,  // dz_6_2 mm
    0.0,  // dalpha_6_2 rad
    0.0,  // dbeta_6_2 rad
    0.0,  // dx_0_3 mm
    0.0,  // dy_0_3 mm
    0.0,  // dz_0_3 mm
    0.0,  // dalpha_0_3 rad
    0.0,  // dbeta_0_3 rad
    0.0,  // dgamma_0_3 rad
    0.0,  // dx_1_3 mm
    0.0,  // dy_1_3 mm
    0.0,  // dz_1_3 mm
    0.0,  // dalpha_1_3 rad
    0.0,  // dbeta_1_3 rad
    0.0,  // dx_2_3 mm
    0.0,  // dy_2_3 mm
    0.0,  // dz_2_3 mm
    0.0,  // dalpha_2_3 rad
    0.0,  // dbeta_2_3 rad
    0.0,  // dx_3_3 mm
    0.0,  // dy_3_3 mm
    0.0,  // dalpha_3_3 rad
    0.0,  // dbeta_3_3 rad
    0.0,  // dgamma_3_3 rad
    0.0,  // dx_4_3 mm
    0.0,  // dy_4_3 mm
    0.0,  // dz_4_3 mm
    0.0,  // dalpha_4_3 rad
    0.0,  // dbeta_4_3 rad
    0.0,  // dx_5_3 mm
    0.0,  // dy_5_3 mm
    0.0,  // dz_5_3 mm
    0.0,  // dalpha_5_3 rad
    0.0,  // dbeta_5_3 rad
    0.0,  // dx_6_3 mm
    0.0,  // dy_6_3 mm
    0.0,  // dz_6_3 mm
    0.0,  // dalpha_6_3 rad
    0.0,  // dbeta_6_3 rad
    0.0,  // dx_0_4 mm
    0.0,  // dy_0_4 mm
    0.0,  // dz_0_4 mm
    0.0,  // dalpha_0_4 rad
    0.0,  // dbeta_0_4 rad
    0.0,  // dgamma_0_4 rad
    0.0,  // dx_1_4 mm
    0.0,  // dy_1_4 mm
    0.0,  // dz_1_4 mm
    0.0,  // dalpha_1_4 rad
    0.0,  // dbeta_1_4 rad
    0.0,  // dx_2_4 mm
    0.0,  // dy_2_4 mm
    0.0,  // dz_2_4 mm
    0.0,  // dalpha_2_4 rad
    0.0,  // dbeta_2_4 rad
    0.0,  // dx_3_4 mm
    0.0,  // dy_3_4 mm
    0.0,  // dalpha_3_4 rad
    0.0,  // dbeta_3_4 rad
    0.0,  // dgamma_3_4 rad
    0.0,  // dx_4_4 mm
    0.0,  // dy_4_4 mm
    0.0,  // dz_4_4 mm
    0.0,  // dalpha_4_4 rad
    0.0,  // dbeta_4_4 rad
    0.0,  // dx_5_4 mm
    0.0,  // dy_5_4 mm
    0.0,  // dz_5_4 mm
    0.0,  // dalpha_5_4 rad
    0.0,  // dbeta_5_4 rad
    0.0,  // dx_6_4 mm
    0.0,  // dy_6_4 mm
    0.0,  // dz_6_4 mm
    0.0,  // dalpha_6_4 rad
    0.0,  // dbeta_6_4 rad
    0.0,  // dx_7_4 mm
    0.0,  // dy_7_4 mm
    0.0,  // dz_7_4 mm
    0.0,  // dalpha_7_4 rad
    0.0,  // dbeta_7_4 rad
    0.0,  // dgamma_7_4 rad
    // effects.scale
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.backlash
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.compliance
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.cyclic_sin
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.cyclic_cos
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.thermal
    0.0,
    // effects.screw_lead
    5.0,
    // effects.screw_joints
    7.0,
    // effects.load_direction
    -0.49999999999999994, 0.0, 0.86602540378443882,
    // effects.thermal_origin
    -627.49999999999989, -4.1078251911130779e-14, 1456.8618817494707,
    // effects.reference_temperature
    20.0,
    // effects.user
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // bounds.max_correction
    5.0, 5.0, 5.0, 0.02, 0.02, 0.02,
    // bounds.min_joint
    628.0, 628.0, 628.0, -2.8999999999999999, -1.3999999999999999, -1.3999999999999999,
    // bounds.max_joint
    1178.0, 1178.0, 1178.0, 2.8999999999999999, 1.3999999999999999, 1.3999999999999999,
};
inline constexpr std::uint32_t kNominalCrc_double = 0x435F8469u;
inline constexpr ::kincal::CalibrationTable<::kincal::HybridMachine<double>> kNominalTable_double =
    ::kincal::table_from_values<::kincal::HybridMachine<double>>(kNominalValues_double, kNominalCrc_double);
static_assert(::kincal::table_crc(kNominalTable_double) == kNominalCrc_double,
              "Nominal table (double): CRC mismatch, the values were edited or corrupted; regenerate with kincal table");
static_assert(::kincal::validate_table(kNominalTable_double, kLimits_double) == ::kincal::CompensationStatus::Ok,
              "Nominal table (double): fails validate_table (values, bounds, machine limits)");

inline constexpr double kCalibrationValues_float[303] = {
    // machine.nominal.base_joints
    2.1431319311435507e-14, 350.0, 0.0, -303.10888671875, -175.0, 0.0, 303.10888671875, -175.0, 0.0,
    // machine.nominal.platform_joints
    8.2663656329100624e-15, 135.0, 0.0, -116.91342926025391, -67.5, 0.0, 116.91342926025391, -67.5, 0.0,
    // machine.nominal.platform_to_wrist
    405.0,
    // machine.nominal.wrist_link
    120.0,
    // machine.nominal.tool_length
    250.0,
    // machine.nominal.workpiece_rotation
    1.9229626518697845e-16, 1.0, 1.1102230246251565e-16, 0.86602538824081421, -2.2204460492503131e-16, 0.5, 0.5, 0.0, -0.86602538824081421,
    // machine.nominal.workpiece_origin
    0.0, -185.0, 1575.429443359375,
    // machine.nominal.tool_offset
    1.9229626518697845e-16, 1.0, 0.0, 1.0, -1.9229626518697845e-16, 1.1102230246251565e-16, 1.1102230246251565e-16, 0.0, -1.0,
    // machine.nominal.joint_offset
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // machine.nominal.min_joint
    628.0, 628.0, 628.0, -2.9000000953674316, -1.3999999761581421, -1.3999999761581421,
    // machine.nominal.max_joint
    1178.0, 1178.0, 1178.0, 2.9000000953674316, 1.3999999761581421, 1.3999999761581421,
    // machine.nominal.min_extension
    400.0,
    // machine.nominal.max_extension
    1400.0,
    // machine.nominal.home
    0.0, 0.0, 850.0,
    // machine.nominal.characteristic_length
    1000.0,
    // machine.up_split
    345.0,
    // machine.encoder_offsets
    0.39511770009994507, -0.14943435788154602, 0.21465961635112762, 0.00039284888771362603, -0.0004163528501521796, 0.00035285984631627798,
    // machine.source_errors (Δχ̂ of seed 000 Eq. (7), identify's HybridErrorModel order)
    0.0,  // dxi_3_1 mm
    0.0,  // dxi_3_2 mm
    0.0,  // dxi_3_3 mm
    0.0,  // dxi_4_4 rad
    0.0,  // dxi_5_4 rad
    0.0,  // dxi_6_4 rad
    0.022518035024404526,  // dx_0_1 mm
    -0.0049661719240248203,  // dy_0_1 mm
    0.0081523144617676735,  // dz_0_1 mm
    0.0,  // dalpha_0_1 rad
    0.0,  // dbeta_0_1 rad
    0.0,  // dgamma_0_1 rad
    0.0,  // dx_1_1 mm
    0.0,  // dy_1_1 mm
    0.0,  // dz_1_1 mm
    0.0,  // dalpha_1_1 rad
    0.0,  // dbeta_1_1 rad
    0.0,  // dx_2_1 mm
    0.011975266970694065,  // dy_2_1 mm
    0.0,  // dz_2_1 mm
    0.0,  // dalpha_2_1 rad
    0.0,  // dbeta_2_1 rad
    0.0,  // dx_3_1 mm
    0.0,  // dy_3_1 mm
    0.0,  // dalpha_3_1 rad
    0.0,  // dbeta_3_1 rad
    0.0,  // dgamma_3_1 rad
    0.0,  // dx_4_1 mm
    0.0,  // dy_4_1 mm
    0.0,  // dz_4_1 mm
    0.0,  // dalpha_4_1 rad
    0.0,  // dbeta_4_1 rad
    0.0,  // dx_5_1 mm
    -1.2818278074264526,  // dy_5_1 mm
    -0.26265016198158264,  // dz_5_1 mm
    0.0,  // dalpha_5_1 rad
    0.0,  // dbeta_5_1 rad
    -0.013728479854762554,  // dx_6_1 mm
    0.0,  // dy_6_1 mm
    0.0,  // dz_6_1 mm
    0.0,  // dalpha_6_1 rad
    0.0,  // dbeta_6_1 rad
    0.0013893236173316836,  // dx_0_2 mm
    -0.03651876375079155,  // dy_0_2 mm
    0.017358651384711266,  // dz_0_2 mm
    0.0,  // dalpha_0_2 rad
    0.0,  // dbeta_0_2 rad
    0.0,  // dgamma_0_2 rad
    0.0,  // dx_1_2 mm
    0.0,  // dy_1_2 mm
    0.0,  // dz_1_2 mm
    0.0,  // dalpha_1_2 rad
    0.0,  // dbeta_1_2 rad
    0.0,  // dx_2_2 mm
    0.010274233296513557,  // dy_2_2 mm
    0.0,  // dz_2_2 mm
    0.0,  // dalpha_2_2 rad
    0.0,  // dbeta_2_2 rad
    0.0,  // dx_3_2 mm
    0.0,  // dy_3_2 mm
    0.0,  // dalpha_3_2 rad
    0.0,  // dbeta_3_2 rad
    0.0,  // dgamma_3_2 rad
    0.0,  // dx_4_2 mm
    0.0,  // dy_4_2 mm
    0.0,  // dz_4_2 mm
    0.0,  // dalpha_4_2 rad
    0.0,  // dbeta_4_2 rad
    0.0,  // dx_5_2 mm
    -1.2657097578048706,  // dy_5_2 mm
    -0.37711456418037415,  // dz_5_2 mm
    0.0,  // dalpha_5_2 rad
    0.0,  // dbeta_5_2 rad
    -0.054156441241502762,  // dx_6_2 mm
    0.0,  // dy_6_2 mm
    0.0,  // dz_6_2 mm
    0.0,  // dalpha_6_2 rad
    0.0,  // dbeta_6_2 rad
    -0.0056205657310783863,  // dx_0_3 mm
    -0.0077203745022416115,  // dy_0_3 mm
    0.054614804685115814,  // dz_0_3 mm
    0.0,  // dalpha_0_3 rad
    0.0,  // dbeta_0_3 rad
    0.0,  // dgamma_0_3 rad
    0.0,  // dx_1_3 mm
    0.0,  // dy_1_3 mm
    0.0,  // dz_1_3 mm
    0.0,  // dalpha_1_3 rad
    0.0,  // dbeta_1_3 rad
    0.0,  // dx_2_3 mm
    0.03035680390894413,  // dy_2_3 mm
    0.0,  // dz_2_3 mm
    0.0,  // dalpha_2_3 rad
    0.0,  // dbeta_2_3 rad
    0.0,  // dx_3_3 mm
    0.0,  // dy_3_3 mm
    0.0,  // dalpha_3_3 rad
    0.0,  // dbeta_3_3 rad
    0.0,  // dgamma_3_3 rad
    0.0,  // dx_4_3 mm
    0.0,  // dy_4_3 mm
    0.0,  // dz_4_3 mm
    0.0,  // dalpha_4_3 rad
    0.0,  // dbeta_4_3 rad
    0.0,  // dx_5_3 mm
    -1.357654333114624,  // dy_5_3 mm
    -0.37143811583518982,  // dz_5_3 mm
    0.0,  // dalpha_5_3 rad
    0.0,  // dbeta_5_3 rad
    0.077271297574043274,  // dx_6_3 mm
    0.0,  // dy_6_3 mm
    0.0,  // dz_6_3 mm
    0.0,  // dalpha_6_3 rad
    0.0,  // dbeta_6_3 rad
    0.064941257238388062,  // dx_0_4 mm
    0.03270610049366951,  // dy_0_4 mm
    0.03046393021941185,  // dz_0_4 mm
    0.0,  // dalpha_0_4 rad
    -5.8201847423333675e-05,  // dbeta_0_4 rad
    2.6020663426606916e-05,  // dgamma_0_4 rad
    0.0,  // dx_1_4 mm
    0.0,  // dy_1_4 mm
    0.0,  // dz_1_4 mm
    0.0,  // dalpha_1_4 rad
    0.0,  // dbeta_1_4 rad
    0.0,  // dx_2_4 mm
    0.0017945221625268459,  // dy_2_4 mm
    -0.11274252831935883,  // dz_2_4 mm
    0.0,  // dalpha_2_4 rad
    -0.00012432844960130751,  // dbeta_2_4 rad
    -0.088811866939067841,  // dx_3_4 mm
    0.0,  // dy_3_4 mm
    -1.7964338212550501e-06,  // dalpha_3_4 rad
    0.0,  // dbeta_3_4 rad
    -4.4306834752205759e-05,  // dgamma_3_4 rad
    0.087910808622837067,  // dx_4_4 mm
    0.0060808784328401089,  // dy_4_4 mm
    -1.3506456613540649,  // dz_4_4 mm
    -1.3068754014966544e-05,  // dalpha_4_4 rad
    -1.6879286704352126e-05,  // dbeta_4_4 rad
    0.0,  // dx_5_4 mm
    0.0044959047809243202,  // dy_5_4 mm
    0.031671121716499329,  // dz_5_4 mm
    0.0,  // dalpha_5_4 rad
    3.9914415538078174e-05,  // dbeta_5_4 rad
    0.0,  // dx_6_4 mm
    -0.020973339676856995,  // dy_6_4 mm
    0.0,  // dz_6_4 mm
    0.0,  // dalpha_6_4 rad
    3.0344277547555976e-05,  // dbeta_6_4 rad
    0.0,  // dx_7_4 mm
    0.0,  // dy_7_4 mm
    0.0,  // dz_7_4 mm
    0.0,  // dalpha_7_4 rad
    0.0,  // dbeta_7_4 rad
    0.0,  // dgamma_7_4 rad
    // effects.scale
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.backlash
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.compliance
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.cyclic_sin
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.cyclic_cos
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.thermal
    0.0,
    // effects.screw_lead
    5.0,
    // effects.screw_joints
    7.0,
    // effects.load_direction
    -0.5, 0.0, 0.86602538824081421,
    // effects.thermal_origin
    -627.5, -4.1078251911130792e-14, 1456.8619384765625,
    // effects.reference_temperature
    20.0,
    // effects.user
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // bounds.max_correction
    5.0, 5.0, 5.0, 0.019999999552965164, 0.019999999552965164, 0.019999999552965164,
    // bounds.min_joint
    628.0, 628.0, 628.0, -2.9000000953674316, -1.3999999761581421, -1.3999999761581421,
    // bounds.max_joint
    1178.0, 1178.0, 1178.0, 2.9000000953674316, 1.3999999761581421, 1.3999999761581421,
};
inline constexpr std::uint32_t kCalibrationCrc_float = 0x318C1B6Du;
inline constexpr ::kincal::CalibrationTable<::kincal::HybridMachine<float>> kCalibrationTable_float =
    ::kincal::table_from_values<::kincal::HybridMachine<float>>(kCalibrationValues_float, kCalibrationCrc_float);
static_assert(::kincal::table_crc(kCalibrationTable_float) == kCalibrationCrc_float,
              "Calibration table (float): CRC mismatch, the values were edited or corrupted; regenerate with kincal table");
static_assert(::kincal::validate_table(kCalibrationTable_float, kLimits_float) == ::kincal::CompensationStatus::Ok,
              "Calibration table (float): fails validate_table (values, bounds, machine limits)");

inline constexpr double kNominalValues_float[303] = {
    // machine.nominal.base_joints
    2.1431319311435507e-14, 350.0, 0.0, -303.10888671875, -175.0, 0.0, 303.10888671875, -175.0, 0.0,
    // machine.nominal.platform_joints
    8.2663656329100624e-15, 135.0, 0.0, -116.91342926025391, -67.5, 0.0, 116.91342926025391, -67.5, 0.0,
    // machine.nominal.platform_to_wrist
    405.0,
    // machine.nominal.wrist_link
    120.0,
    // machine.nominal.tool_length
    250.0,
    // machine.nominal.workpiece_rotation
    1.9229626518697845e-16, 1.0, 1.1102230246251565e-16, 0.86602538824081421, -2.2204460492503131e-16, 0.5, 0.5, 0.0, -0.86602538824081421,
    // machine.nominal.workpiece_origin
    0.0, -185.0, 1575.429443359375,
    // machine.nominal.tool_offset
    1.9229626518697845e-16, 1.0, 0.0, 1.0, -1.9229626518697845e-16, 1.1102230246251565e-16, 1.1102230246251565e-16, 0.0, -1.0,
    // machine.nominal.joint_offset
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // machine.nominal.min_joint
    628.0, 628.0, 628.0, -2.9000000953674316, -1.3999999761581421, -1.3999999761581421,
    // machine.nominal.max_joint
    1178.0, 1178.0, 1178.0, 2.9000000953674316, 1.3999999761581421, 1.3999999761581421,
    // machine.nominal.min_extension
    400.0,
    // machine.nominal.max_extension
    1400.0,
    // machine.nominal.home
    0.0, 0.0, 850.0,
    // machine.nominal.characteristic_length
    1000.0,
    // machine.up_split
    345.0,
    // machine.encoder_offsets
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // machine.source_errors (Δχ̂ of seed 000 Eq. (7), identify's HybridErrorModel order)
    0.0,  // dxi_3_1 mm
    0.0,  // dxi_3_2 mm
    0.0,  // dxi_3_3 mm
    0.0,  // dxi_4_4 rad
    0.0,  // dxi_5_4 rad
    0.0,  // dxi_6_4 rad
    0.0,  // dx_0_1 mm
    0.0,  // dy_0_1 mm
    0.0,  // dz_0_1 mm
    0.0,  // dalpha_0_1 rad
    0.0,  // dbeta_0_1 rad
    0.0,  // dgamma_0_1 rad
    0.0,  // dx_1_1 mm
    0.0,  // dy_1_1 mm
    0.0,  // dz_1_1 mm
    0.0,  // dalpha_1_1 rad
    0.0,  // dbeta_1_1 rad
    0.0,  // dx_2_1 mm
    0.0,  // dy_2_1 mm
    0.0,  // dz_2_1 mm
    0.0,  // dalpha_2_1 rad
    0.0,  // dbeta_2_1 rad
    0.0,  // dx_3_1 mm
    0.0,  // dy_3_1 mm
    0.0,  // dalpha_3_1 rad
    0.0,  // dbeta_3_1 rad
    0.0,  // dgamma_3_1 rad
    0.0,  // dx_4_1 mm
    0.0,  // dy_4_1 mm
    0.0,  // dz_4_1 mm
    0.0,  // dalpha_4_1 rad
    0.0,  // dbeta_4_1 rad
    0.0,  // dx_5_1 mm
    0.0,  // dy_5_1 mm
    0.0,  // dz_5_1 mm
    0.0,  // dalpha_5_1 rad
    0.0,  // dbeta_5_1 rad
    0.0,  // dx_6_1 mm
    0.0,  // dy_6_1 mm
    0.0,  // dz_6_1 mm
    0.0,  // dalpha_6_1 rad
    0.0,  // dbeta_6_1 rad
    0.0,  // dx_0_2 mm
    0.0,  // dy_0_2 mm
    0.0,  // dz_0_2 mm
    0.0,  // dalpha_0_2 rad
    0.0,  // dbeta_0_2 rad
    0.0,  // dgamma_0_2 rad
    0.0,  // dx_1_2 mm
    0.0,  // dy_1_2 mm
    0.0,  // dz_1_2 mm
    0.0,  // dalpha_1_2 rad
    0.0,  // dbeta_1_2 rad
    0.0,  // dx_2_2 mm
    0.0,  // dy_2_2 mm
    0.0,  // dz_2_2 mm
    0.0,  // dalpha_2_2 rad
    0.0,  // dbeta_2_2 rad
    0.0,  // dx_3_2 mm
    0.0,  // dy_3_2 mm
    0.0,  // dalpha_3_2 rad
    0.0,  // dbeta_3_2 rad
    0.0,  // dgamma_3_2 rad
    0.0,  // dx_4_2 mm
    0.0,  // dy_4_2 mm
    0.0,  // dz_4_2 mm
    0.0,  // dalpha_4_2 rad
    0.0,  // dbeta_4_2 rad
    0.0,  // dx_5_2 mm
    0.0,  // dy_5_2 mm
    0.0,  // dz_5_2 mm
    0.0,  // dalpha_5_2 rad
    0.0,  // dbeta_5_2 rad
    0.0,  // dx_6_2 mm
    0.0,  // dy_6_2 mm
    0.0,  // dz_6_2 mm
    0.0,  // dalpha_6_2 rad
    0.0,  // dbeta_6_2 rad
    0.0,  // dx_0_3 mm
    0.0,  // dy_0_3 mm
    0.0,  // dz_0_3 mm
    0.0,  // dalpha_0_3 rad
    0.0,  // dbeta_0_3 rad
    0.0,  // dgamma_0_3 rad
    0.0,  // dx_1_3 mm
    0.0,  // dy_1_3 mm
    0.0,  // dz_1_3 mm
    0.0,  // dalpha_1_3 rad
    0.0,  // dbeta_1_3 rad
    0.0,  // dx_2_3 mm
    0.0,  // dy_2_3 mm
    0.0,  // dz_2_3 mm
    0.0,  // dalpha_2_3 rad
    0.0,  // dbeta_2_3 rad
    0.0,  // dx_3_3 mm
    0.0,  // dy_3_3 mm
    0.0,  // dalpha_3_3 rad
    0.0,  // dbeta_3_3 rad
    0.0,  // dgamma_3_3 rad
    0.0,  // dx_4_3 mm
    0.0,  // dy_4_3 mm
    0.0,  // dz_4_3 mm
    0.0,  // dalpha_4_3 rad
    0.0,  // dbeta_4_3 rad
    0.0,  // dx_5_3 mm
    0.0,  // dy_5_3 mm
    0.0,  // dz_5_3 mm
    0.0,  // dalpha_5_3 rad
    0.0,  // dbeta_5_3 rad
    0.0,  // dx_6_3 mm
    0.0,  // dy_6_3 mm
    0.0,  // dz_6_3 mm
    0.0,  // dalpha_6_3 rad
    0.0,  // dbeta_6_3 rad
    0.0,  // dx_0_4 mm
    0.0,  // dy_0_4 mm
    0.0,  // dz_0_4 mm
    0.0,  // dalpha_0_4 rad
    0.0,  // dbeta_0_4 rad
    0.0,  // dgamma_0_4 rad
    0.0,  // dx_1_4 mm
    0.0,  // dy_1_4 mm
    0.0,  // dz_1_4 mm
    0.0,  // dalpha_1_4 rad
    0.0,  // dbeta_1_4 rad
    0.0,  // dx_2_4 mm
    0.0,  // dy_2_4 mm
    0.0,  // dz_2_4 mm
    0.0,  // dalpha_2_4 rad
    0.0,  // dbeta_2_4 rad
    0.0,  // dx_3_4 mm
    0.0,  // dy_3_4 mm
    0.0,  // dalpha_3_4 rad
    0.0,  // dbeta_3_4 rad
    0.0,  // dgamma_3_4 rad
    0.0,  // dx_4_4 mm
    0.0,  // dy_4_4 mm
    0.0,  // dz_4_4 mm
    0.0,  // dalpha_4_4 rad
    0.0,  // dbeta_4_4 rad
    0.0,  // dx_5_4 mm
    0.0,  // dy_5_4 mm
    0.0,  // dz_5_4 mm
    0.0,  // dalpha_5_4 rad
    0.0,  // dbeta_5_4 rad
    0.0,  // dx_6_4 mm
    0.0,  // dy_6_4 mm
    0.0,  // dz_6_4 mm
    0.0,  // dalpha_6_4 rad
    0.0,  // dbeta_6_4 rad
    0.0,  // dx_7_4 mm
    0.0,  // dy_7_4 mm
    0.0,  // dz_7_4 mm
    0.0,  // dalpha_7_4 rad
    0.0,  // dbeta_7_4 rad
    0.0,  // dgamma_7_4 rad
    // effects.scale
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.backlash
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.compliance
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.cyclic_sin
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.cyclic_cos
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // effects.thermal
    0.0,
    // effects.screw_lead
    5.0,
    // effects.screw_joints
    7.0,
    // effects.load_direction
    -0.5, 0.0, 0.86602538824081421,
    // effects.thermal_origin
    -627.5, -4.1078251911130792e-14, 1456.8619384765625,
    // effects.reference_temperature
    20.0,
    // effects.user
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    // bounds.max_correction
    5.0, 5.0, 5.0, 0.019999999552965164, 0.019999999552965164, 0.019999999552965164,
    // bounds.min_joint
    628.0, 628.0, 628.0, -2.9000000953674316, -1.3999999761581421, -1.3999999761581421,
    // bounds.max_joint
    1178.0, 1178.0, 1178.0, 2.9000000953674316, 1.3999999761581421, 1.3999999761581421,
};
inline constexpr std::uint32_t kNominalCrc_float = 0x8DB7100Du;
inline constexpr ::kincal::CalibrationTable<::kincal::HybridMachine<float>> kNominalTable_float =
    ::kincal::table_from_values<::kincal::HybridMachine<float>>(kNominalValues_float, kNominalCrc_float);
static_assert(::kincal::table_crc(kNominalTable_float) == kNominalCrc_float,
              "Nominal table (float): CRC mismatch, the values were edited or corrupted; regenerate with kincal table");
static_assert(::kincal::validate_table(kNominalTable_float, kLimits_float) == ::kincal::CompensationStatus::Ok,
              "Nominal table (float): fails validate_table (values, bounds, machine limits)");

// --- formula effects (the robot description's `effects`; core/formula_effects.hpp)
// The named inputs the NC stream must carry, in the machine's input order.
inline constexpr int kFormulaInputCount = 0;
inline constexpr const char* kFormulaInputNames[::kincal::kFormulaInputs] = {nullptr, nullptr, nullptr, nullptr};
template <class Scalar> using Formulas = ::kincal::NoFormulaEffects;  // none

// By scalar: calibration_table<double>() etc.
template <class Scalar> struct Tables;
template <> struct Tables<double> {
  static constexpr const ::kincal::CalibrationTable<Machine<double>>& calibration() { return kCalibrationTable_double; }
  static constexpr const ::kincal::CalibrationTable<Machine<double>>& nominal() { return kNominalTable_double; }
  static constexpr const ::kincal::MachineLimits<double>& limits() { return kLimits_double; }
};
template <> struct Tables<float> {
  static constexpr const ::kincal::CalibrationTable<Machine<float>>& calibration() { return kCalibrationTable_float; }
  static constexpr const ::kincal::CalibrationTable<Machine<float>>& nominal() { return kNominalTable_float; }
  static constexpr const ::kincal::MachineLimits<float>& limits() { return kLimits_float; }
};

}  // namespace kincal::generated
