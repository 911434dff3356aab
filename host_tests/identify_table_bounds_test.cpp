// Issue #31 "No refused model without a warning": every bound the table check
// applies (core/machine_limits.hpp) is a robot description key —
// max_correction, max_geometry_error (mm), max_angle_error (rad), max_scale,
// max_thermal (1/°C) — defaulting to today's values; `identify` runs the
// check on the model it writes and warns, naming the value, the bound and the
// key, and `compensate` refuses the same model until the key is raised.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include "kincal/core/compensation.hpp"
#include "kincal/core/hybrid_error_twist.hpp"
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/hybrid_error_model.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/model.hpp"
#include "kincal/identify/robot.hpp"
#include "large_hexapod.hpp"

#include "tool_run.hpp"

namespace ki = kincal::identify;
namespace fs = std::filesystem;

namespace {

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

const char* const kCapKeys[] = {"max_geometry_error", "max_angle_error", "max_scale", "max_thermal"};

// A description with `keys` spliced in before "screw_lead".
std::string with_keys(const ki::Robot& robot, const std::string& keys) {
  std::string text = ki::robot_to_json(robot);
  return text.insert(text.find("\"screw_lead\""), keys);
}

std::string error_of(const std::string& text) {
  try {
    (void)ki::parse_robot(text, "robot.json");
  } catch (const ki::InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(identifyTableBounds, TheKeysRoundTripAndDefaultToTodaysCaps) {
  // Unset: the descriptions `kincal robot` wrote read and write as before,
  // byte for byte (large-hexapod.json is written by hand: its second
  // writing is), and the limits are core's defaults.
  for (const std::string name : {"stewart-seed001", "hybrid-seed000", "large-hexapod"}) {
    const std::string path = std::string(KINCAL_SOURCE_DIR) + "/examples/robots/" + name + ".json";
    const ki::Robot r = ki::load_robot(path);
    const std::string text = name == "large-hexapod" ? ki::robot_to_json(r) : ki::read_text_file(path);
    EXPECT_EQ(ki::robot_to_json(name == "large-hexapod" ? ki::parse_robot(text, "again.json") : r), text) << name;
    EXPECT_FALSE(r.max_geometry_error || r.max_angle_error || r.max_scale || r.max_thermal) << name;
    const kincal::MachineLimits<double> l = ki::machine_limits(r);
    EXPECT_EQ(l.max_geometry_error, 10.0);
    EXPECT_EQ(l.max_angle_error, 0.1);
    EXPECT_EQ(l.max_scale, 0.01);
    EXPECT_EQ(l.max_thermal, 1e-3);
  }
  // Set: read, written back, read again; carried by MODEL.json into the limits.
  for (const ki::Robot& base : {ki::builtin_robot("hybrid-seed000"), kincal_test::large_hexapod()}) {
    const std::string text = with_keys(base,
                                       "\"max_geometry_error\": 2.5,\n  \"max_angle_error\": 0.003,\n  "
                                       "\"max_scale\": 0,\n  \"max_thermal\": 2e-05,\n  ");
    const ki::Robot r = ki::parse_robot(text, "robot.json");
    ASSERT_TRUE(r.max_geometry_error && r.max_angle_error && r.max_scale && r.max_thermal);
    EXPECT_EQ(*r.max_geometry_error, 2.5);
    EXPECT_EQ(*r.max_angle_error, 0.003);
    EXPECT_EQ(*r.max_scale, 0.0);
    EXPECT_EQ(*r.max_thermal, 2e-5);
    const std::string again = ki::robot_to_json(r);
    for (const char* key : kCapKeys) EXPECT_TRUE(contains(again, std::string("\"") + key + "\"")) << again;
    EXPECT_EQ(ki::robot_to_json(ki::parse_robot(again, "again.json")), again);
    ki::CalibrationModel model;
    model.nominal = r;
    model.estimator = "ols";
    const ki::CalibrationModel read = ki::parse_model(ki::model_to_json(model), "MODEL.json");
    const kincal::MachineLimits<double> l = ki::machine_limits(read.nominal);
    EXPECT_EQ(l.max_geometry_error, 2.5);
    EXPECT_EQ(l.max_angle_error, 0.003);
    EXPECT_EQ(l.max_scale, 0.0);
    EXPECT_EQ(l.max_thermal, 2e-5);
    // A description with one key has only that one written back.
    const std::string one = ki::robot_to_json(ki::parse_robot(with_keys(base, "\"max_scale\": 0.002,\n  "), "one.json"));
    EXPECT_TRUE(contains(one, "\"max_scale\": 0.002")) << one;
    EXPECT_FALSE(contains(one, "max_thermal") || contains(one, "max_angle_error") || contains(one, "max_geometry_error"));
  }
}

TEST(identifyTableBounds, BadValuesAreOneLineErrorsWithAPosition) {
  const ki::Robot robot = ki::builtin_robot("stewart-seed001");
  const std::regex positioned("^robot\\.json:[0-9]+:[0-9]+: ");
  for (const char* key : kCapKeys)
    for (const std::string value : {"-1", "-1e-9", "\"0.1\"", "[0.1]", "null", "1e999", "true", "{}"}) {
      const std::string text = with_keys(robot, std::string("\"") + key + "\": " + value + ",\n  ");
      const std::string e = error_of(text);
      EXPECT_TRUE(std::regex_search(e, positioned)) << key << " = " << value << " -> " << e;
      // (1e999 is refused by the JSON reader, before the key is looked at.)
      if (value != "1e999") {
        EXPECT_TRUE(contains(e, key)) << key << " = " << value << " -> " << e;
      }
      EXPECT_FALSE(contains(e, "\n")) << e;
      // The position is that of the value: its line holds the key.
      const std::size_t line = std::stoul(e.substr(std::string("robot.json:").size()));
      std::size_t at = 0;
      for (std::size_t n = 1; n < line; ++n) at = text.find('\n', at) + 1;
      EXPECT_TRUE(contains(text.substr(at, text.find('\n', at) - at), key)) << key << " = " << value << " -> " << e;
    }
  // 0 is a cap (nothing of that kind allowed), not an error.
  EXPECT_EQ(error_of(with_keys(robot, "\"max_angle_error\": 0,\n  ")), "");
}

// core's classification of Δχ (HybridErrorLayout::angular, what the table
// check applies) is identify's (HybridErrorParameter::angular, the unit every
// message and PARAMS.csv uses), entry by entry.
TEST(identifyTableBounds, CoreAndIdentifyAgreeWhichSourceErrorsAreAngles) {
  const ki::HybridErrorModel em(ki::builtin_robot("hybrid-seed000").hybrid());
  ASSERT_EQ(static_cast<int>(em.parameters().size()), kincal::HybridErrorLayout::size());
  for (int k = 0; k < kincal::HybridErrorLayout::size(); ++k)
    EXPECT_EQ(kincal::HybridErrorLayout::angular(k), em.parameters()[static_cast<std::size_t>(k)].angular())
        << k << " " << em.parameters()[static_cast<std::size_t>(k)].name;
}

// Each cause of a refusal names the robot description key that raises its
// bound; the hybrid's angles are held to max_angle_error, its lengths to
// max_geometry_error.
TEST(identifyTableBounds, EveryRefusalNamesItsKey) {
  auto table_error = [](const ki::CalibrationModel& m) -> std::string {
    try {
      (void)ki::calibration_table(m);
    } catch (const ki::InputError& e) {
      return e.message();
    }
    return "";
  };
  const ki::Robot hybrid =
      ki::parse_robot(with_keys(ki::builtin_robot("hybrid-seed000"), "\"max_angle_error\": 0.001,\n  \"max_geometry_error\": 0.5,\n  "),
                      "h.json");
  ki::CalibrationModel m;
  m.nominal = hybrid;
  m.estimator = "ols";
  // An angle of 0.002 rad: above max_angle_error; a length of 0.002 mm is not.
  m.parameters = {{"dbeta_0_2", 0.002}};
  std::string e = table_error(m);
  EXPECT_TRUE(contains(e, "rad above max_angle_error 0.001 (robot description key 'max_angle_error')")) << e;
  EXPECT_TRUE(contains(e, "it comes from dbeta_0_2 = 0.002")) << e;
  m.parameters = {{"dy_0_2", 0.002}};
  EXPECT_EQ(table_error(m), "");
  // A length of 0.6 mm: above max_geometry_error (0.5), whatever the angle cap.
  m.parameters = {{"dy_0_2", 0.6}};
  e = table_error(m);
  EXPECT_TRUE(contains(e, "= 0.6 mm above max_geometry_error 0.5 (robot description key 'max_geometry_error')")) << e;
  m.parameters = {{"dbeta_0_2", 0.0009}};
  EXPECT_EQ(table_error(m), "");
  // A wrist encoder offset above its correction bound (0.02 rad).
  m.parameters = {{"dxi_5_4", 0.03}};
  e = table_error(m);
  EXPECT_TRUE(contains(e, "(robot description key 'max_correction')")) << e;
  // Effects: scale and thermal caps.
  m.parameters.clear();
  m.effects.set(m.nominal, "scale", "s2", 0.02);
  e = table_error(m);
  EXPECT_TRUE(contains(e, "above max_scale 0.01 (robot description key 'max_scale')")) << e;
  m.effects = {};
  m.effects.set(m.nominal, "thermal", "c", 2e-3);
  e = table_error(m);
  EXPECT_TRUE(contains(e, "above max_thermal 0.001 (robot description key 'max_thermal')")) << e;
  // Raised in the description: accepted.
  m.nominal = ki::parse_robot(with_keys(hybrid, "\"max_thermal\": 0.005,\n  "), "h2.json");
  EXPECT_EQ(table_error(m), "");
  // The 6-UPS: a joint centre off by more than max_geometry_error.
  ki::CalibrationModel s;
  s.nominal = ki::parse_robot(with_keys(ki::builtin_robot("stewart-seed001"), "\"max_geometry_error\": 0.1,\n  "), "s.json");
  s.estimator = "ols";
  s.parameters = {{"dYP3", 0.2}};
  e = table_error(s);
  EXPECT_TRUE(contains(e, "above max_geometry_error 0.1 (robot description key 'max_geometry_error')")) << e;
}

// ---- through the tool ----------------------------------------------------------

namespace {

const std::string kDir = std::string(KINCAL_BINARY_DIR) + "/table_bounds_test_out";
const std::string kExamples = std::string(KINCAL_SOURCE_DIR) + "/examples";

using kincal_test::test_name;
using kincal_test::ToolRun;
ToolRun run_tool(const std::string& args) { return kincal_test::run_tool_in(kDir, args); }
std::string write(const std::string& name, const std::string& text) { return kincal_test::write_in(kDir, name, text); }

std::size_t count(const std::string& s, const std::string& part) {
  std::size_t n = 0;
  for (std::size_t at = s.find(part); at != std::string::npos; at = s.find(part, at + 1)) ++n;
  return n;
}

// identify on `data` with the robot `robot_name` + `tight` (the key set to a
// small bound): one warning naming the key, the model written; compensate
// refuses it naming the key; with `raised` the model identified again is
// accepted without a warning.
void warn_refuse_accept(const std::string& tag, const std::string& builtin, const std::string& data,
                        const std::string& poses, const std::string& tight, const std::string& raised,
                        const std::string& key) {
  const ki::Robot base = ki::builtin_robot(builtin);
  const std::string tight_robot = write(tag + "-tight.json", with_keys(base, tight + ",\n  "));
  const std::string raised_robot = write(tag + "-raised.json", with_keys(base, raised + ",\n  "));
  const std::string model = kDir + "/" + tag + "-tight-model.json";
  const ToolRun id = run_tool("identify --robot \"" + tight_robot + "\" --data \"" + data + "\" --out \"" + model + "\"");
  ASSERT_EQ(id.code, 0) << id.err;
  EXPECT_TRUE(fs::exists(model)) << "the model is written all the same";
  EXPECT_EQ(count(id.err, "will refuse it"), 1u) << id.err;
  EXPECT_TRUE(contains(id.err, "(robot description key '" + key + "')")) << id.err;
  EXPECT_TRUE(contains(id.err, "above " + key + " ")) << id.err;  // the value and its bound
  EXPECT_TRUE(contains(id.err, "; it comes from ")) << id.err;     // the model value
  const ToolRun refused = run_tool("compensate --robot \"" + tight_robot + "\" --model \"" + model + "\" --poses \"" +
                                   poses + "\" --out \"" + kDir + "/" + tag + "-tight-q.csv\"");
  EXPECT_EQ(refused.code, 1) << refused.err;
  EXPECT_TRUE(contains(refused.err, "(robot description key '" + key + "')")) << refused.err;
  EXPECT_EQ(count(refused.err, "\n"), 1u) << refused.err;
  // The same model with the raised description: the model carries its bounds.
  const ToolRun other = run_tool("compensate --robot \"" + raised_robot + "\" --model \"" + model + "\" --poses \"" +
                                 poses + "\" --out \"" + kDir + "/" + tag + "-other-q.csv\"");
  EXPECT_EQ(other.code, 1);
  EXPECT_TRUE(contains(other.err, "another '" + key + "'")) << other.err;
  // Identified with the key raised: no warning, and compensate accepts it.
  const std::string raised_model = kDir + "/" + tag + "-raised-model.json";
  const ToolRun id2 =
      run_tool("identify --robot \"" + raised_robot + "\" --data \"" + data + "\" --out \"" + raised_model + "\"");
  ASSERT_EQ(id2.code, 0) << id2.err;
  EXPECT_FALSE(contains(id2.err, "refuse")) << id2.err;
  const ToolRun accepted = run_tool("compensate --robot \"" + raised_robot + "\" --model \"" + raised_model +
                                    "\" --poses \"" + poses + "\" --out \"" + kDir + "/" + tag + "-raised-q.csv\"");
  EXPECT_EQ(accepted.code, 0) << accepted.err;
}

}  // namespace

// The hybrid from seed 000's gauge: its identified structural angles are
// ~1e-4 rad, above a max_angle_error of 1e-5.
TEST(identifyTableBounds, TheToolWarnsOnAHybridModelItsTableWouldRefuse) {
  const std::string ex = kExamples + "/hybrid-seed000";
  const std::string data = kDir + "/hybrid-data.csv";
  ASSERT_EQ(run_tool("simulate --robot hybrid-seed000 --poses " + ex + "/poses.csv --errors " + ex +
                     "/errors.csv --noise-mm 0.005 --seed 3 --out \"" + data + "\"")
                .code,
            0);
  warn_refuse_accept("hybrid", "hybrid-seed000", data, ex + "/poses.csv", "\"max_angle_error\": 1e-05",
                     "\"max_angle_error\": 0.01", "max_angle_error");
}

// The 6-UPS with seed 001 Table 3's errors (tens of µm): above a
// max_geometry_error of 5 µm.
TEST(identifyTableBounds, TheToolWarnsOnASixUpsModelItsTableWouldRefuse) {
  const std::string data = kDir + "/stewart-data.csv";
  ASSERT_EQ(run_tool("simulate --robot stewart-seed001 --poses \"" + kExamples + "/seed001/grid_poses.csv\" --errors \"" +
                     kExamples + "/seed001/errors.csv\" --noise-mm 0.001 --out \"" + data + "\"")
                .code,
            0);
  warn_refuse_accept("stewart", "stewart-seed001", data, kExamples + "/seed001/grid_poses.csv",
                     "\"max_geometry_error\": 0.005", "\"max_geometry_error\": 1", "max_geometry_error");
}
