// Issue #33, "what must be shown": the 6-RUS diagnosis and compensation on
// data kincal did not make, with noise. The machine is
// independent/rus6_physical_simulator.hpp (its own kinematics — motor frames
// turned by rotation vectors, a crank pin beside the crank plane, FK by
// finite-difference Newton — and physical errors of 0.05 mm / 0.5 mrad)
// carrying, in turn, nothing else, gearbox backlash, gravity compliance
// (torques by virtual work through its own FK; stiff gearboxes, where the
// geometry absorbs it, and soft ones, where it must be named), thermal expansion of the
// rods only, and one effect outside the library (a worn gear segment: a
// quadratic error above a knee of motor 2's command, at three sizes). The
// rods case then takes the user's next step: the rods' expansion written as
// a formula over what the 6-RUS offers (rod, lever), named and compensated.
// Measured: full poses with 2 µm / 5 µrad noise at 120 random poses in
// rus6-ref's box, in motion
// order, every third held out, a temperature per row (15–35 °C), the
// approach directions from the motion order.
//
// The loop is the user's, through the command line: `kincal diagnose` with
// the noise given (--noise-um 2 --noise-urad 5) and estimated; `kincal
// identify --effects <accepted>`, `kincal compensate` of the held-out poses,
// the independent machine driven by those commands (at each pose's
// temperature, with the directions of the commands it is sent).
//
// The same cases measured by ONE tracker target in the tracker's own frame
// (--instrument-frame: its registration identified with the model): the
// error is where the target goes in the tracker's frame, the model's
// registration · pose · target against the true tracker · reached pose ·
// true target; 2 µm per target coordinate.
//
// The floor, as identify_independent_diagnosis_test.cpp measures it: the
// same machine without the effect, the same poses and noise draws,
// identified with the base model (then the true model: the crank pin is a
// shaft point moved along the shaft) and compensated the same way. Bar:
// held-out compensated position RMS ≤ 1.25 × floor where the verdict names
// a library effect.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "independent/cli_loop.hpp"
#include "independent/rus6_physical_simulator.hpp"
#include "kincal/identify/files.hpp"
#include "kincal/identify/robot.hpp"
#include "tool_run.hpp"

namespace {

namespace ind = kincal::independent;
using V6 = kincal::Vec6<double>;
using V3 = kincal::Vec3<double>;

using Diag = ind::Verdict;
using ind::joined;

// How the machine is measured, and so how the held-out error is taken.
struct Measurement {
  std::string dir;    // the working folder
  std::string robot;  // built-in name or description file
  std::string flags;  // appended to identify and diagnose
  std::string noise;  // diagnose's noise options when it is given
  ind::MeasurementSpec spec;
  std::optional<V3> true_target;  // one target: where it goes in the tracker's frame
};

Measurement full_poses() {
  Measurement m;
  m.dir = "identify_independent_rus6";
  m.robot = "rus6-ref";
  m.noise = " --noise-um 2 --noise-urad 5";
  m.spec.sigma_mm = 2e-3;
  m.spec.sigma_rad = 5e-6;
  m.spec.seed = 5;
  return m;
}

// A target 1.5 mm from where the description says, a tracker 2 m away and
// turned (other numbers than identify_independent_rus6_tracker_test's).
Measurement one_tracker_target() {
  Measurement m;
  m.dir = "identify_independent_rus6_one_target";
  std::filesystem::create_directories(m.dir);
  m.true_target = V3(55.0, 40.0, 28.0);
  m.spec.targets = {*m.true_target};
  m.spec.instrument_from_base = kincal::Pose<double>::from_xyz_rpy(-1500, 900, 300, -0.02, 0.04, -1.9);
  m.spec.sigma_mm = 2e-3;
  m.spec.seed = 6;
  kincal::identify::Robot robot = kincal::identify::builtin_robot("rus6-ref");
  robot.targets = {*m.true_target + V3(-1.0, 1.0, 0.5)};
  m.robot = kincal_test::write_in(m.dir, "rus6_one_target.json", kincal::identify::robot_to_json(robot));
  m.flags = " --instrument-frame";
  m.noise = " --noise-um 2";
  return m;
}

// The user's next step after `unexplained` on rods expanding (the library's
// `thermal` is uniform): the rods' expansion written as a formula effect
// with the numbers the 6-RUS offers per joint (`kincal effects --robot R`):
// a rod longer by a·rod·(temp − 20) acts as a crank turned by that over the
// lever. The measurement's robot with that `effects` key, as a file.
std::string with_rod_thermal_formula(const Measurement& m) {
  nlohmann::json doc = nlohmann::json::parse(kincal::identify::robot_to_json(kincal::identify::load_robot(m.robot)));
  doc["effects"] = nlohmann::json::parse(R"([{"name": "rod_thermal",
      "description": "the rods alone expand with temperature", "kind": "joint", "shared": ["a"],
      "formula": "a * rod * (temp - 20) / lever"}])");
  return kincal_test::write_in(m.dir, "rod_thermal_robot.json", doc.dump(2));
}

// identify (with `effects`, "" = base only), compensate the held-out rows,
// drive the machine: the held-out position RMS, µm (−1: refused).
double held_out_rms(const Measurement& m, const std::string& data, const std::string& tag,
                    const std::string& effects, const ind::Rus6PhysicalSimulator& machine, const ind::Dataset& d) {
  const ind::IdentifyCompensate run = ind::identify_and_compensate(m.dir, m.robot, data, tag, effects, d, m.flags);
  EXPECT_EQ(run.identify.code, 0) << tag << ": " << run.identify.err;
  EXPECT_EQ(run.compensate.code, 0) << tag << ": " << run.compensate.err;
  if (run.identify.code != 0 || run.compensate.code != 0) return -1;
  // With one target: the model's promise, registration · pose · target.
  kincal::Pose<double> registration;
  V3 target = V3::Zero();
  if (m.true_target) {
    const nlohmann::json j = nlohmann::json::parse(kincal::identify::read_text_file(m.dir + "/" + tag + "_model.json"));
    std::map<std::string, double> inst;
    for (const auto& e : j.at("instrument")) inst[e.at("name").get<std::string>()] = e.at("value").get<double>();
    registration = kincal::Pose<double>::from_xyz_rpy(inst.at("reg_x"), inst.at("reg_y"), inst.at("reg_z"),
                                                      inst.at("reg_rx"), inst.at("reg_ry"), inst.at("reg_rz"));
    target = V3(inst.at("t1x"), inst.at("t1y"), inst.at("t1z"));
  }
  kincal::identify::PoseTableOptions o;
  o.joint_count = 6;
  const kincal::identify::PoseTable table = kincal::identify::read_pose_table(run.joints, o);
  EXPECT_EQ(table.rows.size(), run.test.size()) << tag;
  // The machine starts at home with every direction +1 (as the controller).
  V6 previous;
  EXPECT_TRUE(ind::Rus6PhysicalSimulator().ik(ind::Rus6PhysicalSimulator::home(), previous));
  ind::Rus6Inputs in;
  double sum = 0;
  int n = 0;
  for (std::size_t k = 0; k < table.rows.size() && k < run.test.size(); ++k) {
    const auto& row = table.rows[k];
    EXPECT_TRUE(row.q.has_value()) << tag << " row " << k;
    if (!row.q) continue;
    const V6 q = row.q->head<6>();
    for (int j = 0; j < 6; ++j)
      if (q(j) != previous(j)) in.dir(j) = q(j) > previous(j) ? 1.0 : -1.0;
    previous = q;
    in.temp = run.test[k]->temp;
    const kincal::Pose<double> asked = kincal::Pose<double>::from_xyz_rpy(run.test[k]->commanded);
    const ind::Rus6Reach r = machine.fk(q, in, asked);
    EXPECT_TRUE(r.ok) << tag << " row " << k;
    if (!r.ok) continue;
    if (m.true_target)
      sum += 1e6 * (m.spec.instrument_from_base.transform(r.pose.transform(*m.true_target)) -
                    registration.transform(asked.transform(target)))
                       .squaredNorm();
    else
      sum += 1e6 * (r.pose.p - asked.p).squaredNorm();
    ++n;
  }
  return n > 0 ? std::sqrt(sum / n) : -1;
}

TEST(IndependentRus6, TheSimulatorAgreesWithItself) {
  // Its FK of its own IK's commands returns the pose (nominal machine, from
  // home, not from the answer); with errors and every effect on, each leg's
  // closure holds at the pose it reports, and with the effects off the
  // machine is the effect-free one exactly.
  const ind::Rus6PhysicalSimulator nominal;
  V6 half;
  half << 40, 40, 40, 0.17, 0.17, 0.17;
  const V6 centre = ind::Rus6PhysicalSimulator::home().to_xyz_rpy();
  const ind::Rus6PhysicalErrors errors = ind::random_rus6_errors(0.05, 5e-4, 3);
  ind::Rus6Effects none, all;
  all.backlash = {1e-4, 0, 0, -2e-4, 0, 0};
  all.rod_alpha = 2e-5;
  all.ramp_joint = 1;
  all.ramp_gain = 1e-3;
  const ind::Rus6PhysicalSimulator plain(errors, none), effects(errors, all);
  ind::Rus6Inputs in;
  in.temp = 31;
  in.dir << 1, -1, 1, -1, 1, -1;
  for (const V6& p : ind::random_box_poses(20, centre, half, 41)) {
    const kincal::Pose<double> pose = kincal::Pose<double>::from_xyz_rpy(p);
    V6 q;
    ASSERT_TRUE(nominal.ik(pose, q));
    const ind::Rus6Reach back = nominal.fk(q);
    ASSERT_TRUE(back.ok);
    EXPECT_LT(kincal::pose_error(back.pose, pose).norm(), 1e-9);
    const ind::Rus6Reach a = plain.fk(q, in, pose), b = effects.fk(q, in, pose);
    ASSERT_TRUE(a.ok && b.ok);
    V6 theta = q;
    theta(0) += 1e-4;
    theta(3) += 2e-4;  // dir −1 · −2e-4
    theta(1) += 1e-3 * std::pow(std::max(0.0, q(1)), 2);
    for (int i = 0; i < 6; ++i) EXPECT_LT(std::abs(effects.closure(i, b.pose, theta(i), 1 + 2e-5 * 11)), 1e-9);
    EXPECT_EQ(plain.fk(q, in, pose).pose.p, ind::Rus6PhysicalSimulator(errors).fk(q, {}, pose).pose.p);
    EXPECT_GT((a.pose.p - b.pose.p).norm(), 1e-3);  // the effects move the platform
  }
}

void each_effect_is_named_and_compensated(const Measurement& m) {
  std::filesystem::create_directories(m.dir);
  V6 half;
  half << 40, 40, 40, 0.17, 0.17, 0.17;
  const std::vector<V6> poses =
      ind::random_box_poses(120, ind::Rus6PhysicalSimulator::home().to_xyz_rpy(), half, 5151);
  std::vector<double> temps;
  std::vector<std::string> roles;
  {
    std::mt19937_64 rng(5152);
    std::uniform_real_distribution<double> t(15.0, 35.0);
    for (std::size_t k = 0; k < poses.size(); ++k) {
      temps.push_back(t(rng));
      roles.push_back(k % 3 == 2 ? "test" : "cal");
    }
  }
  const ind::Rus6PhysicalErrors geometry = ind::random_rus6_errors(0.05, 5e-4, 17);
  // Motor 2's commands over the design, for the outside effect's knee.
  std::vector<double> q2;
  for (const V6& p : poses) {
    V6 q;
    if (ind::Rus6PhysicalSimulator().ik(kincal::Pose<double>::from_xyz_rpy(p), q)) q2.push_back(q(1));
  }
  std::sort(q2.begin(), q2.end());
  const double knee = q2[q2.size() / 2], top = q2.back();

  struct Case {
    std::string name;
    ind::Rus6Effects effects;
    std::string truth;  // kincal's effect; "" none; "outside"
  };
  std::vector<Case> cases;
  cases.push_back({"geometry only", {}, ""});
  {
    ind::Rus6Effects e;
    e.backlash = {1e-4, 0, 0, -1.5e-4, 0, 0};
    cases.push_back({"motor backlash", e, "backlash"});
  }
  {
    ind::Rus6Effects e;
    e.weight = 50;  // N, a payload at the platform's centre
    e.compliance = {2e-8, 3e-8, 2.5e-8, 2e-8, 3e-8, 2.5e-8};
    cases.push_back({"gravity compliance", e, "absorbed:compliance"});
    // The same payload on gearboxes 30× softer (1.1–1.7 kN·m/rad, a small
    // harmonic drive): the base model leaves 16 µm of the deflection (held
    // out). Now compliance must be named and compensated. (Between the two,
    // 200–500 N on the stiff gearboxes, base RMS 2.4–5.4 µm: named both
    // ways, compensated to 0.99–1.28× the floor — backward elimination
    // holds the weakest k_i at 0 there; docs/diagnosis.md.)
    ind::Rus6Effects soft = e;
    for (double& k : soft.compliance) k *= 30;
    cases.push_back({"gravity compliance, soft gearboxes", soft, "compliance"});
  }
  {
    ind::Rus6Effects e;
    e.rod_alpha = 2.3e-5;  // aluminium rods, steel elsewhere ignored
    cases.push_back({"rod thermal expansion", e, "outside:thermal"});
  }
  // The worn segment at three sizes at the top of motor 2's range: 2 and
  // 3 mrad (base RMS 8.9 and 13.3 µm from full poses) asserted both ways.
  // With the noise estimated the estimate takes the segment in (4.1–5.2 µm
  // for 2, 3.2–4.3 µm from one target); from one target at 3 mrad the final
  // model's held-out nodes, predicted worse than its cal nodes are fitted
  // (σ-free, p = 1.2e-4), are what keeps the verdict `unexplained` (it read
  // `explained` before that test). At 1 mrad (base RMS 3.6 µm from full
  // poses) the estimate (2.74 µm; 2.56 from one target) passes the residual
  // after `cyclic` for noise and no σ-free test sees it (held-out against
  // cal p = 0.63 and 0.037) — the estimate's limit on 120 random poses in
  // six joints: printed, asserted with the noise given (docs/diagnosis.md).
  for (const double top_error : {2e-3, 3e-3, 1e-3}) {
    ind::Rus6Effects e;
    e.ramp_joint = 1;
    e.ramp_knee = knee;
    e.ramp_gain = top_error / std::pow(std::max(0.05, top - knee), 2);
    cases.push_back({"outside (motor 2 worn gear, " + std::to_string(int(top_error * 1e3)) + " mrad)", e,
                     top_error > 1.5e-3 ? "outside" : "outside:small"});
  }

  double floor_um = -1;
  std::printf("  motor 2 knee %.3f rad, top %.3f rad\n", knee, top);
  std::printf("  %-36s | %-24s | %-30s | %8s %8s %6s\n", "case", "given: verdict/accepted", "estimated (um/urad)",
              "base", "comp", "ratio");
  for (std::size_t c = 0; c < cases.size(); ++c) {
    const Case& k = cases[c];
    const std::string tag = "case" + std::to_string(c);
    const ind::Rus6PhysicalSimulator machine(geometry, k.effects);
    const ind::Dataset d = ind::make_rus6_dataset(machine, poses, m.spec, temps, roles);
    EXPECT_TRUE(d.skipped.empty()) << k.name;
    const std::string data = m.dir + "/" + tag + "_measured.csv";
    ind::write_measurement_csv_file(data, d);
    const Diag given = ind::diagnose_in(m.dir, m.robot, data, tag, true, m.flags, m.noise),
               est = ind::diagnose_in(m.dir, m.robot, data, tag, false, m.flags);
    const double base = held_out_rms(m, data, tag + "_base", "", machine, d);
    const double comp =
        given.accepted.empty() ? base : held_out_rms(m, data, tag + "_acc", joined(given.accepted), machine, d);
    if (c == 0) floor_um = base;
    std::printf("  %-36s | %-12s %-11s | %-12s %-9s %4.2f/%4.1f | %8.3f %8.3f %6.2f\n", k.name.c_str(),
                given.verdict.c_str(), joined(given.accepted).c_str(), est.verdict.c_str(),
                joined(est.accepted).c_str(), est.noise_um, est.noise_urad, base, comp, comp / floor_um);
    std::fflush(stdout);
    ASSERT_TRUE(given.ok && est.ok) << k.name;
    if (k.truth.empty()) {
      EXPECT_EQ(given.verdict, "consistent") << k.name;
      EXPECT_EQ(est.verdict, "consistent") << k.name;
    } else if (k.truth == "outside") {
      // Unexplained both ways (cyclic takes part of it).
      EXPECT_EQ(given.verdict, "unexplained") << k.name;
      EXPECT_EQ(est.verdict, "unexplained") << k.name;
    } else if (k.truth == "outside:small") {
      EXPECT_EQ(given.verdict, "unexplained") << k.name;
    } else if (k.truth == "outside:thermal") {
      // Rods alone expanding is not the library's uniform `thermal`: the
      // verdict says the library cannot carry it (it accepts `thermal` for
      // what it can). With the noise estimated: the estimate's
      // interpolation is exact for a misfit linear in the temperature
      // (4.2 µm for 2; 24 µm before it took the temperature in), and the
      // final residual still follows the temperature between joint-space
      // neighbours (structure).
      EXPECT_EQ(given.verdict, "unexplained") << k.name;
      EXPECT_EQ(est.verdict, "unexplained") << k.name;
      EXPECT_EQ(joined(given.accepted), "thermal") << k.name;
      // The user adds the rods' expansion as a formula (what the simulator
      // does differently: it lengthens each rod by α·ℓ·ΔT in its own
      // closure, with its own crank-pin geometry and FK; the formula acts
      // through kincal's nominal lever, first order). Now it is named with
      // the noise given and estimated, and compensated near the floor.
      Measurement with = m;
      with.robot = with_rod_thermal_formula(m);
      const Diag fg = ind::diagnose_in(with.dir, with.robot, data, tag + "_formula", true, with.flags, with.noise),
                 fe = ind::diagnose_in(with.dir, with.robot, data, tag + "_formula", false, with.flags);
      ASSERT_TRUE(fg.ok && fe.ok) << k.name;
      const double fcomp = held_out_rms(with, data, tag + "_formula_acc", joined(fg.accepted), machine, d);
      std::printf("  %-36s | %-12s %-11s | %-12s %-9s %4.2f/%4.1f | %8.3f %8.3f %6.2f\n",
                  " + the formula rod_thermal", fg.verdict.c_str(), joined(fg.accepted).c_str(), fe.verdict.c_str(),
                  joined(fe.accepted).c_str(), fe.noise_um, fe.noise_urad, base, fcomp, fcomp / floor_um);
      EXPECT_EQ(fg.verdict, "explained") << k.name;
      EXPECT_EQ(fe.verdict, "explained") << k.name;
      EXPECT_EQ(joined(fg.accepted), "rod_thermal") << k.name;
      EXPECT_EQ(joined(fe.accepted), "rod_thermal") << k.name;
      EXPECT_LE(fcomp, 1.25 * floor_um) << k.name;
    } else if (k.truth == "absorbed:compliance") {
      // A fixed payload's deflection is a smooth function of the pose that
      // the 66 geometric parameters absorb on this workspace (the diagnosis
      // reports compliance as ~99 % confounded with the base): "consistent"
      // is right, and the base model compensates it to the floor.
      EXPECT_TRUE(given.verdict == "consistent" || joined(given.accepted) == "compliance") << k.name;
      EXPECT_TRUE(est.verdict == "consistent" || joined(est.accepted) == "compliance") << k.name;
      EXPECT_LE(comp, 1.25 * floor_um) << k.name;
    } else {
      EXPECT_EQ(joined(given.accepted), k.truth) << k.name;
      EXPECT_EQ(joined(est.accepted), k.truth) << k.name;
      EXPECT_LE(comp, 1.25 * floor_um) << k.name;
    }
  }
}

TEST(IndependentRus6, EachEffectIsNamedAndCompensatedNearTheFloorWithNoise) {
  each_effect_is_named_and_compensated(full_poses());
}

TEST(IndependentRus6, OneTrackerTargetEachEffectIsNamedAndCompensated) {
  each_effect_is_named_and_compensated(one_tracker_target());
}

}  // namespace
