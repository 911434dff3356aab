// The user's loop on an independently simulated machine, through the command
// line (identify_independent_*_test.cpp): `kincal identify` on the measured
// cal poses, `kincal compensate` of held-out poses, and the independent
// machine driven by those commands; what it reaches is compared with what
// was asked. Shared by the families' tests; the machine is any of
// independent/*_simulator.hpp (its `fk(q)` gives `.ok` and `.pose`).
#pragma once

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "independent/independent_common.hpp"
#include "kincal/identify/csv.hpp"
#include "kincal/identify/input_error.hpp"
#include "tool_run.hpp"

namespace kincal::independent {

// Random commanded poses, uniform in centre ± half per coordinate.
inline std::vector<V6> random_box_poses(int n, const V6& centre, const V6& half, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<V6> out;
  for (int k = 0; k < n; ++k) {
    V6 p;
    for (int i = 0; i < 6; ++i) p(i) = centre(i) + half(i) * u(rng);
    out.push_back(p);
  }
  return out;
}

inline std::string poses_csv(const std::vector<V6>& poses) {
  std::ostringstream s;
  s.precision(17);
  s << "id,x,y,z,rx,ry,rz\n";
  for (std::size_t k = 0; k < poses.size(); ++k) {
    s << "t" << k;
    for (int i = 0; i < 6; ++i) s << "," << poses[k](i);
    s << "\n";
  }
  return s.str();
}

// The held-out rows (role "test") of `d` as a poses file's text with their
// temperatures (`temp`), and those rows in order in `test`.
inline std::string held_out_poses_csv(const Dataset& d, std::vector<const DatasetRow*>& test) {
  std::ostringstream poses;
  poses.precision(17);
  poses << "id,x,y,z,rx,ry,rz,temp\n";
  for (const auto& r : d.rows)
    if (r.role == "test") {
      test.push_back(&r);
      poses << r.id;
      for (int k = 0; k < 6; ++k) poses << "," << r.commanded(k);
      poses << "," << r.temp << "\n";
    }
  return poses.str();
}


// The loop's two commands in `dir`: `kincal identify` of `data` (with
// `effects`; "" = the base only; `flags` appended, e.g. --instrument-frame)
// into <tag>_model.json, then, if it succeeded, `kincal compensate` of d's
// held-out rows into <tag>_joints.csv.
struct IdentifyCompensate {
  kincal_test::ToolRun identify, compensate;  // compensate.code stays -1 when identify failed
  std::vector<const DatasetRow*> test;        // the held-out rows, in the joints file's order
  std::string joints;
};
inline IdentifyCompensate identify_and_compensate(const std::string& dir, const std::string& robot,
                                                  const std::string& data, const std::string& tag,
                                                  const std::string& effects, const Dataset& d,
                                                  const std::string& flags = "") {
  IdentifyCompensate r;
  const std::string model = dir + "/" + tag + "_model.json";
  r.identify = kincal_test::run_tool_in(dir, "identify --robot " + robot + " --data " + data + " --out " + model +
                                                 (effects.empty() ? "" : " --effects " + effects) + flags);
  if (r.identify.code != 0) return r;
  const std::string poses_path = kincal_test::write_in(dir, tag + "_test_poses.csv", held_out_poses_csv(d, r.test));
  r.joints = dir + "/" + tag + "_joints.csv";
  r.compensate = kincal_test::run_tool_in(
      dir, "compensate --robot " + robot + " --model " + model + " --poses " + poses_path + " --out " + r.joints);
  return r;
}

// `kincal diagnose` of `data` in `dir` with the noise given (`noise`, by
// default 2 µm / 5 µrad) or estimated, `flags` appended: the verdict, the
// accepted effects and the noise it used.
struct Verdict {
  std::string verdict;
  std::vector<std::string> accepted;
  double noise_um = 0, noise_urad = 0;
  bool ok = false;
};
inline Verdict diagnose_in(const std::string& dir, const std::string& robot, const std::string& data,
                           const std::string& tag, bool give_noise, const std::string& flags = "",
                           const std::string& noise = " --noise-um 2 --noise-urad 5") {
  Verdict d;
  const std::string json = dir + "/" + tag + (give_noise ? "_diag_given.json" : "_diag_est.json");
  const kincal_test::ToolRun r = kincal_test::run_tool_in(
      dir, "diagnose --robot " + robot + " --data " + data + " --json " + json + (give_noise ? noise : "") + flags);
  EXPECT_EQ(r.code, 0) << tag << ": " << r.err;
  if (r.code != 0) return d;
  const nlohmann::json j = nlohmann::json::parse(identify::read_text_file(json));
  d.verdict = j.at("verdict").get<std::string>();
  for (const auto& a : j.at("accepted")) d.accepted.push_back(a.get<std::string>());
  d.noise_um = j.at("noise_um").get<double>();
  d.noise_urad = j.value("noise_urad", 0.0);
  d.ok = true;
  return d;
}

inline std::string joined(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ",") + x;
  return s;
}

struct HeldOut {
  double position_um = 0;  // worst |reached − asked|, µm
  double rotation_urad = 0;
  double rms_um = 0;       // RMS of |reached − asked| over the poses
  double target_um = 0;    // with fitted targets: worst |target reached − where the model puts it|, µm
  int poses = 0;
};

// The targets' positions MODEL.json's `instrument` holds (t1x … t3z).
inline std::vector<V3> fitted_targets(const std::string& model) {
  const nlohmann::json j = nlohmann::json::parse(identify::read_text_file(model));
  std::vector<V3> t;
  for (int k = 1; k <= 3; ++k) {
    V3 p;
    int found = 0;
    for (const auto& e : j.at("instrument")) {
      const std::string name = e.at("name").get<std::string>();
      for (int a = 0; a < 3; ++a)
        if (name == "t" + std::to_string(k) + "xyz"[a]) p(a) = e.at("value").get<double>(), ++found;
    }
    if (found == 3) t.push_back(p);
  }
  return t;
}

// `data` measured on `machine`; identify with `robot`, compensate `test`,
// drive `machine`. Files go to `dir`/`name`_*. With targets whose positions
// identify fits (`true_targets`: where they are on the machine's tool), the
// tool frame is identify's convention, so what is compared is where the
// targets go: the model's X·t_k against the machine's T(q)·t_k,true.
template <class Machine>
HeldOut identify_and_compensate(const std::string& dir, const std::string& robot, const std::string& name,
                                const Machine& machine, const Dataset& data, const std::vector<V6>& test,
                                const std::vector<V3>* true_targets = nullptr) {
  HeldOut out;
  std::filesystem::create_directories(dir);
  EXPECT_TRUE(data.skipped.empty()) << name << ": " << data.skipped.size() << " cal poses not reached";
  const std::string data_path = dir + "/" + name + "_measured.csv";
  write_measurement_csv_file(data_path, data);
  const std::string model = dir + "/" + name + "_model.json";
  const kincal_test::ToolRun id = kincal_test::run_tool_in(
      dir, "identify --robot " + robot + " --data " + data_path + " --out " + model + " --keep-outliers");
  EXPECT_EQ(id.code, 0) << name << ": " << id.err;
  if (id.code != 0) return out;
  const std::string poses = kincal_test::write_in(dir, name + "_test.csv", poses_csv(test));
  const std::string joints = dir + "/" + name + "_joints.csv";
  const kincal_test::ToolRun comp = kincal_test::run_tool_in(
      dir, "compensate --robot " + robot + " --model " + model + " --poses " + poses + " --out " + joints);
  EXPECT_EQ(comp.code, 0) << name << ": " << comp.err;
  if (comp.code != 0) return out;
  identify::PoseTableOptions o;
  o.joint_count = 6;
  const identify::PoseTable table = identify::read_pose_table(joints, o);
  const std::vector<V3> fitted = true_targets != nullptr ? fitted_targets(model) : std::vector<V3>();
  if (true_targets != nullptr) {
    EXPECT_EQ(fitted.size(), true_targets->size()) << name;
  }
  for (std::size_t k = 0; k < table.rows.size(); ++k) {
    const identify::PoseRow& row = table.rows[k];
    if (!row.q) continue;
    const auto r = machine.fk(*row.q);
    EXPECT_TRUE(r.ok) << name << ": the machine does not reach row " << k;
    if (!r.ok) continue;
    const Pose<double> asked = Pose<double>::from_xyz_rpy(row.commanded);
    out.position_um = std::max(out.position_um, 1e3 * (r.pose.p - asked.p).norm());
    out.rms_um += 1e6 * (r.pose.p - asked.p).squaredNorm();
    out.rotation_urad =
        std::max(out.rotation_urad, 1e6 * log_so3(Mat3<double>(r.pose.R * asked.R.transpose())).norm());
    for (std::size_t t = 0; true_targets != nullptr && t < std::min(fitted.size(), true_targets->size()); ++t) {
      const V3 model_says = asked.R * fitted[t] + asked.p;
      const V3 reached = r.pose.R * (*true_targets)[t] + r.pose.p;
      out.target_um = std::max(out.target_um, 1e3 * (reached - model_says).norm());
    }
    ++out.poses;
  }
  if (out.poses > 0) out.rms_um = std::sqrt(out.rms_um / out.poses);
  return out;
}

}  // namespace kincal::independent
