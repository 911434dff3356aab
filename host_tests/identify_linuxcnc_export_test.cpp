// `kincal export linuxcnc` (identify/linuxcnc_export.hpp) checked from the
// files it writes, read back as LinuxCNC reads them:
//   - the HAL setp lines fed to an independent strut-length IK written here
//     the way genhexkins computes it (R = Rz(C)·Ry(B)·Rx(A) from degrees,
//     joint = |R·p + t − b|), minus the INI's home-offset shift, must equal
//     kincal's own compensation (core's Compensator) to 1e-9 mm on random
//     poses of a machine with millimetre errors;
//   - the compensation files, looked up as LinuxCNC's motion module does
//     (linear interpolation between entries at the joint's commanded
//     position, the forward or reverse column by the direction), must give
//     kincal's commands with scale, backlash and cyclic to within 0.1 µm;
//   - refusals: a hybrid model, an existing directory without --force.
// The LinuxCNC run itself (its own genhexkins and motion) is the `linuxcnc`
// stage of scripts/test-all.sh (host_tests/linuxcnc/).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>

#include "kincal/core/compensation.hpp"
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/linuxcnc_export.hpp"
#include "kincal/identify/model.hpp"
#include "kincal/identify/robot.hpp"

namespace {

using namespace kincal;
namespace ki = kincal::identify;
namespace fs = std::filesystem;

constexpr double kPi = 3.14159265358979323846;

// seed 001's hexapod with errors of a few millimetres (every base and
// platform joint coordinate and every leg offset: uniform ±`size` mm), its
// correction bound opened to carry them; effects as given.
ki::CalibrationModel model_with_errors(double size, std::uint64_t seed, bool effects) {
  ki::CalibrationModel m;
  m.nominal = ki::builtin_robot("stewart-seed001");
  m.nominal.max_correction = Vec6<double>::Constant(4 * size + 1);
  m.estimator = "ols";
  m.data_file = "meas.csv";
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-size, size);
  for (int i = 1; i <= 6; ++i)
    for (const char* p : {"dXB", "dYB", "dZB", "dl", "dXP", "dYP", "dZP"})
      m.parameters.push_back({p + std::to_string(i), u(rng), 0.0, true});
  if (effects) {
    std::uniform_real_distribution<double> w(-1.0, 1.0);
    for (int i = 1; i <= 6; ++i) {
      m.effects.set(m.nominal, "scale", "s" + std::to_string(i), 2e-4 * w(rng));
      m.effects.set(m.nominal, "backlash", "b" + std::to_string(i), 0.012 * w(rng));
      // Screw errors up to 4.2 µm: within what 256 entries carry over the
      // 100 mm stroke to 0.1 µm (0.0175 µm per µm of amplitude, measured).
      m.effects.set(m.nominal, "cyclic", "a" + std::to_string(i), 0.003 * w(rng));
      m.effects.set(m.nominal, "cyclic", "b" + std::to_string(i), 0.003 * w(rng));
    }
  }
  return m;
}

// `setp genhexkins.base.N.x V` lines → base / platform matrices.
void read_hal(const std::string& text, Eigen::Matrix<double, 3, 6>& base, Eigen::Matrix<double, 3, 6>& platform,
              int& lines) {
  std::istringstream in(text);
  lines = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream l(line);
    std::string setp, pin;
    double v = 0;
    l >> setp >> pin >> v;
    ASSERT_EQ(setp, "setp") << line;
    if (pin == "genhexkins.screw-lead") {  // kincal's struts have no screw-rotation term
      EXPECT_EQ(v, 0.0);
      continue;
    }
    // genhexkins.<base|platform>.<N>.<x|y|z>
    const auto a = pin.find('.'), b = pin.find('.', a + 1), c = pin.find('.', b + 1);
    const std::string body = pin.substr(a + 1, b - a - 1);
    const int n = std::stoi(pin.substr(b + 1, c - b - 1));
    const int axis = pin[c + 1] - 'x';
    ASSERT_TRUE(n >= 0 && n < 6 && axis >= 0 && axis < 3) << line;
    (body == "base" ? base : platform)(axis, n) = v;
    ++lines;
  }
}

// `[JOINT_n]` KEY = value of an INI fragment.
std::map<std::string, double> read_ini_numbers(const std::string& text) {
  std::map<std::string, double> out;
  std::istringstream in(text);
  std::string section;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    if (line[0] == '[') {
      section = line.substr(1, line.find(']') - 1);
      continue;
    }
    const auto eq = line.find(" = ");
    if (eq == std::string::npos) continue;
    char* end = nullptr;
    const std::string value = line.substr(eq + 3);
    const double v = std::strtod(value.c_str(), &end);
    if (end != value.c_str() && *end == '\0') out[section + "." + line.substr(0, eq)] = v;
  }
  return out;
}

// LinuxCNC's joint comp as its motion module applies it (control.c
// compute_screw_comp): the entry below the position, linear interpolation to
// the next, the forward or reverse column by the direction of motion.
struct CompFile {
  std::vector<double> nominal, forward, reverse;
  double operator()(double x, double dir) const {
    std::size_t k = 0;
    while (k + 2 < nominal.size() && x >= nominal[k + 1]) ++k;
    const double t = (x - nominal[k]) / (nominal[k + 1] - nominal[k]);
    const std::vector<double>& col = dir > 0 ? forward : reverse;
    return col[k] + t * (col[k + 1] - col[k]);
  }
};
CompFile read_comp(const std::string& text) {
  CompFile c;
  std::istringstream in(text);
  double n, f, r;
  while (in >> n >> f >> r) {
    c.nominal.push_back(n);
    c.forward.push_back(f);
    c.reverse.push_back(r);
  }
  return c;
}

// genhexkins' inverse kinematics, written here from its definition: A, B, C
// in degrees, R = Rz(C)·Ry(B)·Rx(A), strut = |R·p + t − b|.
Vec6<double> genhexkins_struts(const Eigen::Matrix<double, 3, 6>& base, const Eigen::Matrix<double, 3, 6>& platform,
                               const Vec6<double>& xyzabc_deg) {
  const double d = kPi / 180;
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(xyzabc_deg(5) * d, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(xyzabc_deg(4) * d, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(xyzabc_deg(3) * d, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  Vec6<double> L;
  for (int i = 0; i < 6; ++i) L(i) = (R * platform.col(i) + xyzabc_deg.head<3>() - base.col(i)).norm();
  return L;
}

// Random poses in seed 001's workspace (±25 mm, z 185–225, ±3°: struts 200–270 mm of the 183–283 stroke).
std::vector<Vec6<double>> random_poses(std::mt19937_64& rng, int n) {
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Vec6<double>> out;
  for (int k = 0; k < n; ++k) {
    Vec6<double> v;
    v << 25 * u(rng), 25 * u(rng), 205 + 20 * u(rng), 3 * u(rng), 3 * u(rng), 3 * u(rng);  // degrees
    out.push_back(v);
  }
  return out;
}

Pose<double> pose_of(const Vec6<double>& xyzabc_deg) {
  Vec6<double> v = xyzabc_deg;
  v.tail<3>() *= kPi / 180;
  return Pose<double>::from_xyz_rpy(v);
}

TEST(LinuxCncExport, GeometryAndHomeOffsetsGiveKincalsCommandsThroughAnIndependentGenhexkins) {
  for (const double size : {0.05, 3.0}) {  // micrometre-scale and millimetre errors
    const ki::CalibrationModel model = model_with_errors(size, 7, false);
    const ki::LinuxCncExport out = ki::linuxcnc_export(model);
    Eigen::Matrix<double, 3, 6> base, platform;
    int lines = 0;
    read_hal(out.files.at("kincal-geometry.hal"), base, platform, lines);
    EXPECT_EQ(lines, 36);
    EXPECT_TRUE(out.comp.empty());
    EXPECT_EQ(out.files.count("joint-0.comp"), 0u);
    const std::map<std::string, double> ini = read_ini_numbers(out.files.at("kincal.ini"));
    // The shift of each home offset from the nominal one (the strut length at
    // the home pose) is the identified encoder offset.
    Vec6<double> home_nominal, shift;
    ASSERT_EQ(model.nominal.inverse(model.nominal.home_pose(), home_nominal), Status::Ok);
    for (int j = 0; j < 6; ++j) shift(j) = ini.at("JOINT_" + std::to_string(j) + ".HOME_OFFSET") - home_nominal(j);

    const auto table = ki::stewart_calibration_table(model);
    Compensator<StewartMachine<double>> comp(table, trust_table_bounds);
    ASSERT_EQ(comp.status(), CompensationStatus::Ok);
    auto state = comp.start(Vec6<double>::Zero());
    std::mt19937_64 rng(11);
    double worst = 0;
    for (const Vec6<double>& p : random_poses(rng, 200)) {
      Vec6<double> q;
      ASSERT_EQ(comp.compensate(state, pose_of(p), q), CompensationStatus::Ok);
      const Vec6<double> lcnc = genhexkins_struts(base, platform, p) - shift;
      worst = std::max(worst, (lcnc - q).cwiseAbs().maxCoeff());
    }
    EXPECT_LT(worst, 1e-9) << "errors of " << size << " mm";
  }
}

TEST(LinuxCncExport, CompensationTablesCarryScaleBacklashAndCyclicWithinATenthOfAMicrometre) {
  const ki::CalibrationModel model = model_with_errors(2.0, 3, true);
  const ki::LinuxCncExport out = ki::linuxcnc_export(model);
  ASSERT_EQ(out.comp.size(), 6u);
  EXPECT_EQ(out.not_carried.size(), 0u);
  Eigen::Matrix<double, 3, 6> base, platform;
  int lines = 0;
  read_hal(out.files.at("kincal-geometry.hal"), base, platform, lines);
  const std::map<std::string, double> ini = read_ini_numbers(out.files.at("kincal.ini"));
  Vec6<double> home_nominal, shift;
  ASSERT_EQ(model.nominal.inverse(model.nominal.home_pose(), home_nominal), Status::Ok);
  std::vector<CompFile> files;
  for (int j = 0; j < 6; ++j) {
    const std::string key = "JOINT_" + std::to_string(j);
    shift(j) = ini.at(key + ".HOME_OFFSET") - home_nominal(j);
    EXPECT_EQ(ini.at(key + ".COMP_FILE_TYPE"), 1.0);
    files.push_back(read_comp(out.files.at("joint-" + std::to_string(j) + ".comp")));
    EXPECT_LE(files.back().nominal.size(), std::size_t(ki::kLinuxCncMaxCompEntries));
    EXPECT_GE(files.back().nominal.size(), 3u);
    // The table covers the stroke in strut lengths (the limits written).
    EXPECT_LE(files.back().nominal.front(), ini.at(key + ".MIN_LIMIT"));
    EXPECT_GE(files.back().nominal.back(), ini.at(key + ".MAX_LIMIT"));
  }
  const auto table = ki::stewart_calibration_table(model);
  Compensator<StewartMachine<double>> comp(table, trust_table_bounds);
  ASSERT_EQ(comp.status(), CompensationStatus::Ok);
  comp.set_user_effect(nullptr);
  auto state = comp.start(Vec6<double>::Zero());
  std::mt19937_64 rng(5);
  std::uniform_int_distribution<int> coin(0, 1);
  double worst = 0, largest_effect = 0;
  for (const Vec6<double>& p : random_poses(rng, 300)) {
    Vec6<double> dir;
    for (int j = 0; j < 6; ++j) dir(j) = coin(rng) ? 1.0 : -1.0;
    NcPoint<double> point;
    point.pose = pose_of(p);
    point.direction = &dir;
    Vec6<double> q;
    ASSERT_EQ(comp.compensate(state, point, q), CompensationStatus::Ok);
    const Vec6<double> L = genhexkins_struts(base, platform, p);
    for (int j = 0; j < 6; ++j) {
      const double lcnc = L(j) + files[j](L(j), dir(j)) - shift(j);
      worst = std::max(worst, std::abs(lcnc - q(j)));
      largest_effect = std::max(largest_effect, std::abs(q(j) - (L(j) - shift(j))));
    }
  }
  EXPECT_LT(worst, 1e-4);           // 0.1 µm
  EXPECT_GT(largest_effect, 0.01);  // the tables carry tens of micrometres
  // The README names what is carried and how well.
  for (const char* name : {"scale", "backlash", "cyclic"})
    EXPECT_NE(out.files.at("README.md").find(name), std::string::npos) << name;
  EXPECT_TRUE(out.warnings.empty()) << out.warnings.front();
}

// A screw error LinuxCNC's 256 entries cannot carry to the tolerance over
// the stroke (20 µm: 0.35 µm reached) is written with a warning that names
// the joint and the error reached, in the README too.
TEST(LinuxCncExport, ATableThatCannotReachTheToleranceIsWrittenWithAWarning) {
  ki::CalibrationModel model = model_with_errors(0.1, 8, false);
  model.effects.set(model.nominal, "cyclic", "a3", 0.02);
  const ki::LinuxCncExport out = ki::linuxcnc_export(model);
  ASSERT_EQ(out.comp.size(), 6u);
  EXPECT_EQ(out.comp[2].nominal.size(), std::size_t(ki::kLinuxCncMaxCompEntries));
  EXPECT_GT(out.comp[2].max_error_mm, 1e-4);
  EXPECT_LT(out.comp[1].max_error_mm, 1e-9);  // no cyclic error on joint 1: two intervals carry nothing exactly
  ASSERT_EQ(out.warnings.size(), 1u);
  EXPECT_NE(out.warnings[0].find("joint 2"), std::string::npos) << out.warnings[0];
  EXPECT_NE(out.files.at("README.md").find(out.warnings[0]), std::string::npos);
}

TEST(LinuxCncExport, InchUnitsScaleEveryLength) {
  const ki::CalibrationModel model = model_with_errors(1.0, 9, true);
  const ki::LinuxCncExport mm = ki::linuxcnc_export(model);
  ki::LinuxCncExportOptions o;
  o.inch = true;
  const ki::LinuxCncExport inch = ki::linuxcnc_export(model, o);
  Eigen::Matrix<double, 3, 6> b1, p1, b2, p2;
  int lines = 0;
  read_hal(mm.files.at("kincal-geometry.hal"), b1, p1, lines);
  read_hal(inch.files.at("kincal-geometry.hal"), b2, p2, lines);
  EXPECT_LT((b1 / 25.4 - b2).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((p1 / 25.4 - p2).cwiseAbs().maxCoeff(), 1e-9);
  const auto a = read_ini_numbers(mm.files.at("kincal.ini")), c = read_ini_numbers(inch.files.at("kincal.ini"));
  EXPECT_NEAR(a.at("JOINT_2.HOME_OFFSET") / 25.4, c.at("JOINT_2.HOME_OFFSET"), 1e-9);
  const CompFile f1 = read_comp(mm.files.at("joint-4.comp")), f2 = read_comp(inch.files.at("joint-4.comp"));
  ASSERT_EQ(f1.nominal.size(), f2.nominal.size());
  EXPECT_NEAR(f1.forward[3] / 25.4, f2.forward[3], 1e-11);
}

TEST(LinuxCncExport, WhatLinuxCncCannotCarryIsListedWithThePredictedError) {
  ki::CalibrationModel model = model_with_errors(0.5, 4, true);
  model.effects.set(model.nominal, "thermal", "c", 1.5e-5);
  // Measured poses at temperatures away from 20 °C.
  ki::PoseTable data;
  data.file = "meas.csv";
  data.has_temp = true;
  std::mt19937_64 rng(2);
  int k = 0;
  for (const Vec6<double>& p : random_poses(rng, 40)) {
    ki::PoseRow r;
    r.id = "n" + std::to_string(k++);
    r.commanded = p;
    r.commanded.tail<3>() *= kPi / 180;
    r.temp = 20.0 + 0.2 * k;
    data.rows.push_back(r);
  }
  ki::LinuxCncExportOptions o;
  o.data = &data;
  const ki::LinuxCncExport out = ki::linuxcnc_export(model, o);
  ASSERT_EQ(out.not_carried, std::vector<std::string>{"thermal"});
  ASSERT_GE(out.predictions.size(), 4u);
  // kincal's whole model: nothing left; LinuxCNC without thermal: the thermal
  // strain of a ~210 mm position at up to 8 °C, tens of micrometres.
  EXPECT_LT(out.predictions[0].rms_position_mm, 1e-6);
  EXPECT_GT(out.predictions[1].rms_position_mm, 5e-3);
  EXPECT_EQ(out.predictions[1].poses, 40u);
  const std::string& readme = out.files.at("README.md");
  EXPECT_NE(readme.find("`thermal`"), std::string::npos);
  EXPECT_NE(readme.find("LinuxCNC with these files"), std::string::npos);
}

TEST(LinuxCncExport, RefusesAHybridModelAndAnExistingDirectory) {
  ki::CalibrationModel hybrid;
  hybrid.nominal = ki::builtin_robot("hybrid-seed000");
  hybrid.source_file = "hybrid.json";
  try {
    (void)ki::linuxcnc_export(hybrid);
    FAIL() << "a hybrid model was exported";
  } catch (const ki::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("LinuxCNC has no kinematics for the family"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("hybrid.json"), std::string::npos) << e.what();
  }

  const fs::path dir = fs::path(KINCAL_BINARY_DIR) / "linuxcnc_export_test_dir";
  fs::remove_all(dir);
  const ki::LinuxCncExport out = ki::linuxcnc_export(model_with_errors(0.2, 1, true));
  ki::write_export_directory(out.files, dir.string(), false);
  EXPECT_TRUE(fs::is_regular_file(dir / "kincal.ini"));
  EXPECT_TRUE(fs::is_regular_file(dir / "joint-5.comp"));
  // Not overwritten unless asked; the old content stays whole.
  const ki::LinuxCncExport geometry = ki::linuxcnc_export(model_with_errors(0.2, 1, false));
  EXPECT_THROW(ki::write_export_directory(geometry.files, dir.string(), false), ki::InputError);
  EXPECT_TRUE(fs::is_regular_file(dir / "joint-5.comp"));
  // Asked: replaced whole (no comp files of the old export left), nothing staged left beside it.
  ki::write_export_directory(geometry.files, dir.string(), true);
  EXPECT_FALSE(fs::exists(dir / "joint-5.comp"));
  EXPECT_TRUE(fs::is_regular_file(dir / "kincal-geometry.hal"));
  for (const auto& entry : fs::directory_iterator(dir.parent_path()))
    EXPECT_EQ(entry.path().filename().string().find("linuxcnc_export_test_dir.kincal-"), std::string::npos)
        << entry.path();
  fs::remove_all(dir);
}

}  // namespace

namespace {
// A model with leg lines beside their U centres (robot key leg_offset_sq):
// genhexkins has no parameter for them, so the export refuses the model with
// the leg and the key named, instead of writing files that would leave the
// offset's √(D² − o²) uncompensated. All zeros: exported as before.
TEST(LinuxCncExport, RefusesALegLineOffsetItCannotCarry) {
  ki::CalibrationModel model = model_with_errors(0.2, 11, false);
  model.nominal.stewart_description().models_leg_offsets = true;
  model.source_file = "legs.json";
  EXPECT_NO_THROW((void)ki::linuxcnc_export(model));
  model.parameters.push_back({"dsq4", 0.8, 0.0, true});
  try {
    (void)ki::linuxcnc_export(model);
    FAIL() << "a model with a leg-line offset was exported";
  } catch (const ki::InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("leg 4"), std::string::npos) << what;
    EXPECT_NE(what.find("leg_offset_sq"), std::string::npos) << what;
  }
}
}  // namespace
