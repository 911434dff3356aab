// Issue #31, "what must be shown": the diagnosis on data kincal did not make,
// with noise. The machine is independent/hybrid_simulator.hpp (its own
// kinematics and physical geometry errors, 0.1 mm / 0.3 mrad) carrying, in
// turn, nothing else, each of the five library effects written from the
// physics by that simulator (HybridEffects: not kincal's effect code), and one
// effect outside the library (a lead error in the upper stroke of one leg).
// Measured: full poses (mx..mrz) with 2 µm / 5 µrad noise, 120 random poses
// over the task cuboid (tilts ±0.1 rad) in motion order, every third held out
// (`role` = test), a temperature per row (15–35 °C) and the approach
// directions (dir1..dir6) from the motion order.
//
// The loop is the user's, through the command line:
//   kincal diagnose --noise-um 2 --noise-urad 5   and without the noise given:
//     the verdict and the accepted effect;
//   kincal identify --effects <accepted>, kincal compensate of the held-out
//     poses, the independent machine driven by those commands (at each pose's
//     temperature, with the approach directions of the commands it is sent).
//
// The floor. What a fit of the TRUE model leaves after compensation is the
// noise's own contribution (through the identified parameters) plus what the
// base model cannot say about this machine's geometry. It is measured, not
// assumed: the same machine WITHOUT the effect, the same poses, the same
// noise draws, identified with the base model (which is then the true model)
// and compensated the same way — the "geometry only" row. A fit of the true
// model on the effect's data can do no better than that, except by the extra
// parameters' own variance; kincal's `identify --effects TRUE` on the same
// data is NOT used as the floor, because it would hide a kincal effect that
// differs from the physics (it is printed beside it, as "true fit").
// Bar: held-out compensated position RMS ≤ 1.25 × floor.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "independent/cli_loop.hpp"
#include "independent/hybrid_simulator.hpp"

namespace {

namespace ind = kincal::independent;
using V6 = kincal::Vec6<double>;

const std::string kDir = "identify_independent_diagnosis";
const std::string kRobot = "hybrid-seed000";

struct Case {
  std::string name;
  ind::HybridEffects effects;
  std::string truth;  // kincal's name of the effect; "" = none; "outside"
};

using Diag = ind::Verdict;
using ind::joined;

Diag diagnose(const std::string& data, const std::string& tag, bool give_noise) {
  return ind::diagnose_in(kDir, kRobot, data, tag, give_noise);
}

struct Held {
  double rms_um = -1, rot_urad = -1;
  int poses = 0;
};

// identify (with `effects`, "" = base only), compensate the held-out rows,
// drive the machine.
// `may_refuse`: the model may be one `compensate` refuses (the outside effect
// drives the base fit past max_geometry_error: a legitimate, warned outcome).
Held compensate(const std::string& data, const std::string& tag, const std::string& effects,
                const ind::HybridSimulator& machine, const ind::Dataset& d, bool may_refuse = false) {
  Held h;
  const ind::IdentifyCompensate run = ind::identify_and_compensate(kDir, kRobot, data, tag, effects, d);
  EXPECT_EQ(run.identify.code, 0) << tag << ": " << run.identify.err;
  if (run.identify.code != 0) return h;
  if (!may_refuse) {
    EXPECT_EQ(run.compensate.code, 0) << tag << ": " << run.compensate.err;
  }
  if (run.compensate.code != 0) {
    h.rms_um = -1;  // refused
    return h;
  }
  const std::vector<const ind::DatasetRow*>& test = run.test;
  const std::string& joints = run.joints;
  kincal::identify::PoseTableOptions o;
  o.joint_count = 6;
  const kincal::identify::PoseTable table = kincal::identify::read_pose_table(joints, o);
  EXPECT_EQ(table.rows.size(), test.size()) << tag;
  // The machine starts at home with every direction +1 (as the controller).
  ind::V6 previous;
  EXPECT_TRUE(ind::HybridSimulator().ik(kincal::Pose<double>(), previous));
  ind::HybridInputs in;
  double sum = 0, rot = 0;
  for (std::size_t k = 0; k < table.rows.size() && k < test.size(); ++k) {
    const auto& row = table.rows[k];
    EXPECT_TRUE(row.q.has_value()) << tag << " row " << k;
    if (!row.q) continue;
    const ind::V6 q = row.q->head<6>();
    for (int j = 0; j < 6; ++j)
      if (q(j) != previous(j)) in.dir(j) = q(j) > previous(j) ? 1.0 : -1.0;
    previous = q;
    in.temp = test[k]->temp;
    const auto r = machine.fk(q, in);
    EXPECT_TRUE(r.ok) << tag << " row " << k;
    if (!r.ok) continue;
    const kincal::Pose<double> asked = kincal::Pose<double>::from_xyz_rpy(test[k]->commanded);
    sum += 1e6 * (r.pose.p - asked.p).squaredNorm();
    rot += 1e12 * kincal::log_so3(kincal::Mat3<double>(r.pose.R * asked.R.transpose())).squaredNorm();
    ++h.poses;
  }
  if (h.poses > 0) {
    h.rms_um = std::sqrt(sum / h.poses);
    h.rot_urad = std::sqrt(rot / h.poses);
  }
  return h;
}

TEST(IndependentDiagnosis, EachEffectIsNamedAndCompensatedNearTheFloorWithNoise) {
  std::filesystem::create_directories(kDir);
  // Design: 120 random poses in motion order, every third held out, a
  // temperature per row.
  V6 half;
  half << 250, 250, 60, 0.1, 0.1, 0.1;
  const std::vector<V6> poses = ind::random_box_poses(120, V6::Zero(), half, 3111);
  std::vector<double> temps;
  std::vector<std::string> roles;
  {
    std::mt19937_64 rng(3112);
    std::uniform_real_distribution<double> t(15.0, 35.0);
    for (std::size_t k = 0; k < poses.size(); ++k) {
      temps.push_back(t(rng));
      roles.push_back(k % 3 == 2 ? "test" : "cal");
    }
  }
  const ind::HybridErrors geometry = ind::random_hybrid_errors(0.1, 3e-4, 17);
  ind::MeasurementSpec spec;
  spec.sigma_mm = 2e-3;
  spec.sigma_rad = 5e-6;
  spec.seed = 5;

  // Leg 2's commands over the design, for the outside effect's knee.
  std::vector<double> q2;
  for (const V6& p : poses) {
    ind::V6 q;
    if (ind::HybridSimulator().ik(kincal::Pose<double>::from_xyz_rpy(p), q)) q2.push_back(q(1));
  }
  std::sort(q2.begin(), q2.end());
  const double knee = q2[q2.size() / 2], top = q2.back();

  std::vector<Case> cases;
  cases.push_back({"geometry only", {}, ""});
  {
    ind::HybridEffects e;
    e.scale = {5e-5, -4e-5, 3e-5, 0, 0, 0};
    cases.push_back({"scale", e, "scale"});
  }
  {
    ind::HybridEffects e;
    e.backlash = {0.030, 0, -0.020, 0, 0, 0};  // lost motion, mm
    cases.push_back({"backlash", e, "backlash"});
  }
  {
    ind::HybridEffects e;
    e.compliance = {0.06, 0.04, 0.05, 0, 0, 0};
    cases.push_back({"compliance", e, "compliance"});
  }
  {
    ind::HybridEffects e;
    e.thermal = 4e-6;
    cases.push_back({"thermal", e, "thermal"});
  }
  {
    ind::HybridEffects e;
    e.cyclic_amplitude = {0.008, 0.006, 0.005};
    e.cyclic_phase = {0.3, 2.0, -1.2};
    cases.push_back({"cyclic", e, "cyclic"});
  }
  {
    ind::HybridEffects e;
    e.ramp_joint = 1;
    e.ramp_knee = knee;
    e.ramp_slope = 0.040 / std::max(1.0, top - knee);  // 40 µm at the top of the measured stroke
    cases.push_back({"outside (leg 2 upper-stroke ramp)", e, "outside"});
  }

  double floor_um = -1;
  std::printf("  leg 2 stroke knee %.1f mm, top %.1f mm\n", knee, top);
  std::printf("  %-34s | %-22s | %-22s | %8s %8s %8s %6s\n", "case", "given: verdict/acc", "estimated (um/urad)",
              "base", "comp", "truefit", "ratio");
  for (std::size_t c = 0; c < cases.size(); ++c) {
    const Case& k = cases[c];
    const std::string tag = "case" + std::to_string(c);
    const ind::HybridSimulator machine(geometry, k.effects);
    const ind::Dataset d = ind::make_hybrid_effect_dataset(geometry, k.effects, poses, spec, temps, roles);
    EXPECT_TRUE(d.skipped.empty()) << k.name;
    const std::string data = kDir + "/" + tag + "_measured.csv";
    ind::write_measurement_csv_file(data, d);

    const Diag given = diagnose(data, tag, true), est = diagnose(data, tag, false);
    const Held base = compensate(data, tag + "_base", "", machine, d, k.truth == "outside");
    const Held comp = given.accepted.empty() ? base : compensate(data, tag + "_acc", joined(given.accepted), machine, d);
    Held truefit = base;
    if (!k.truth.empty() && k.truth != "outside")
      truefit = joined(given.accepted) == k.truth ? comp : compensate(data, tag + "_true", k.truth, machine, d);
    if (c == 0) floor_um = base.rms_um;
    const double ratio = comp.rms_um / floor_um;
    std::printf("  %-34s | %-12s %-9s | %-12s %-9s %4.2f/%4.1f | %8.3f %8.3f %8.3f %6.2f\n", k.name.c_str(),
                given.verdict.c_str(), joined(given.accepted).c_str(), est.verdict.c_str(),
                joined(est.accepted).c_str(), est.noise_um, est.noise_urad, base.rms_um, comp.rms_um,
                truefit.rms_um, ratio);
    std::fflush(stdout);

    ASSERT_TRUE(given.ok && est.ok) << k.name;
    if (k.truth.empty()) {
      EXPECT_EQ(given.verdict, "consistent") << k.name;
      EXPECT_EQ(est.verdict, "consistent") << k.name;
    } else if (k.truth == "outside") {
      // No library effect can carry it (a formula effect can: issue #32):
      // the verdict must say so; compensation is not judged.
      EXPECT_EQ(given.verdict, "unexplained") << k.name;
      EXPECT_EQ(est.verdict, "unexplained") << k.name;
    } else {
      EXPECT_EQ(given.verdict, "explained") << k.name;
      EXPECT_EQ(joined(given.accepted), k.truth) << k.name;
      EXPECT_EQ(est.verdict, "explained") << k.name;
      EXPECT_EQ(joined(est.accepted), k.truth) << k.name;
      EXPECT_LE(comp.rms_um, 1.25 * floor_um) << k.name;
    }
  }
}

}  // namespace
