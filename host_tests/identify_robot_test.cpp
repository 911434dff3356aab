// Robot descriptions: built-ins, JSON round trip, the committed example files,
// the custom-hybrid derivation, and every schema error with its position.
#include <gtest/gtest.h>

#include <string>

#include "kincal/core/reference_machines.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/robot.hpp"

namespace ki = kincal::identify;

namespace {

void expect_same_stewart(const kincal::StewartGeometry<double>& a, const kincal::StewartGeometry<double>& b) {
  EXPECT_EQ(a.base, b.base);
  EXPECT_EQ(a.platform, b.platform);
  EXPECT_EQ(a.length_offset, b.length_offset);
  EXPECT_EQ(a.min_length, b.min_length);
  EXPECT_EQ(a.max_length, b.max_length);
  EXPECT_LT((a.home.R - b.home.R).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(a.home.p, b.home.p);
}

// β is stored as a number and the frames are re-derived, so allow rounding.
void expect_same_hybrid(const kincal::HybridGeometry<double>& a, const kincal::HybridGeometry<double>& b) {
  EXPECT_EQ(a.base_joints, b.base_joints);
  EXPECT_EQ(a.platform_joints, b.platform_joints);
  EXPECT_EQ(a.platform_to_wrist, b.platform_to_wrist);
  EXPECT_EQ(a.wrist_link, b.wrist_link);
  EXPECT_EQ(a.tool_length, b.tool_length);
  EXPECT_LT((a.workpiece_rotation - b.workpiece_rotation).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LT((a.workpiece_origin - b.workpiece_origin).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((a.tool_offset - b.tool_offset).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(a.joint_offset, b.joint_offset);
  EXPECT_EQ(a.min_joint, b.min_joint);
  EXPECT_EQ(a.max_joint, b.max_joint);
  EXPECT_EQ(a.min_extension, b.min_extension);
  EXPECT_EQ(a.max_extension, b.max_extension);
  EXPECT_EQ(a.home.theta1, b.home.theta1);
  EXPECT_EQ(a.home.theta2, b.home.theta2);
  EXPECT_EQ(a.home.extension, b.home.extension);
}

// Runs parse_robot and returns the InputError (fails the test if none).
ki::InputError parse_error(const std::string& text) {
  try {
    ki::parse_robot(text, "robot.json");
  } catch (const ki::InputError& e) {
    return e;
  }
  ADD_FAILURE() << "no InputError for:\n" << text;
  return ki::InputError("none");
}

std::string stewart_json() { return ki::robot_to_json(ki::builtin_robot("stewart-seed001")); }
std::string hybrid_json() { return ki::robot_to_json(ki::builtin_robot("hybrid-seed000")); }

std::string replace(std::string s, const std::string& from, const std::string& to) {
  const std::size_t at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) s.replace(at, from.size(), to);
  return s;
}

}  // namespace

TEST(identifyRobot, BuiltinsByName) {
  const ki::Robot s = ki::load_robot("stewart-seed001");
  ASSERT_TRUE(s.is_stewart());
  EXPECT_STREQ(s.family(), "stewart-6ups");
  expect_same_stewart(s.stewart(), kincal::make_stewart_seed001<double>());
  const ki::Robot h = ki::load_robot("hybrid-seed000");
  ASSERT_TRUE(h.is_hybrid());
  EXPECT_STREQ(h.family(), "hybrid-3ups-up-3r");
  expect_same_hybrid(h.hybrid(), kincal::make_hybrid_seed000<double>());
  EXPECT_EQ(h.hybrid_description().gauge_radius, 200.0);
  EXPECT_EQ(h.screw_lead, 5.0);
}

TEST(identifyRobot, JsonRoundTripOfBothBuiltins) {
  const ki::Robot s = ki::parse_robot(stewart_json(), "s.json");
  EXPECT_EQ(s.name, "stewart-seed001");
  expect_same_stewart(s.stewart(), kincal::make_stewart_seed001<double>());
  const ki::Robot h = ki::parse_robot(hybrid_json(), "h.json");
  EXPECT_EQ(h.name, "hybrid-seed000");
  expect_same_hybrid(h.hybrid(), kincal::make_hybrid_seed000<double>());
  EXPECT_EQ(h.hybrid_description().gauge_radius, 200.0);
  // Writing the parsed robot again gives the same text.
  EXPECT_EQ(ki::robot_to_json(s), stewart_json());
  EXPECT_EQ(ki::robot_to_json(h), hybrid_json());
}

TEST(identifyRobot, CommittedExampleFilesMatchBuiltins) {
  const std::string dir = std::string(KINCAL_SOURCE_DIR) + "/examples/robots/";
  const ki::Robot s = ki::load_robot(dir + "stewart-seed001.json");
  expect_same_stewart(s.stewart(), kincal::make_stewart_seed001<double>());
  const ki::Robot h = ki::load_robot(dir + "hybrid-seed000.json");
  expect_same_hybrid(h.hybrid(), kincal::make_hybrid_seed000<double>());
  // The files are exactly what `kincal robot --out` writes today.
  EXPECT_EQ(ki::read_text_file(dir + "stewart-seed001.json"), stewart_json());
  EXPECT_EQ(ki::read_text_file(dir + "hybrid-seed000.json"), hybrid_json());
  // The 6-RUS: the file reads back to the built-in exactly (every number of
  // the geometry), and is what `kincal robot --out` writes.
  const ki::Robot r = ki::load_robot(dir + "rus6-ref.json");
  const kincal::Rus6Geometry<double> ref = kincal::make_rus6_ref<double>();
  EXPECT_EQ(r.rus6().shaft_points, ref.shaft_points);
  EXPECT_EQ(r.rus6().shaft_axes, ref.shaft_axes);
  EXPECT_EQ(r.rus6().crank_zero, ref.crank_zero);
  EXPECT_EQ(r.rus6().platform_joints, ref.platform_joints);
  EXPECT_EQ(r.rus6().crank_length, ref.crank_length);
  EXPECT_EQ(r.rus6().rod_length, ref.rod_length);
  EXPECT_EQ(r.rus6().min_joint, ref.min_joint);
  EXPECT_EQ(r.rus6().max_joint, ref.max_joint);
  EXPECT_EQ(r.rus6().home_branch, ref.home_branch);
  EXPECT_LT((r.rus6().home.p - ref.home.p).norm(), 1e-12);
  EXPECT_EQ(r.screw_lead, ki::builtin_robot("rus6-ref").screw_lead);
  EXPECT_EQ(ki::read_text_file(dir + "rus6-ref.json"), ki::robot_to_json(ki::builtin_robot("rus6-ref")));
}

TEST(identifyRobot, CustomHybridDerivationMatchesCoreFactory) {
  const kincal::HybridGeometry<double> ref = kincal::make_hybrid_seed000<double>();
  const ki::HybridDesign d = ki::hybrid_design_of(ref);
  EXPECT_NEAR(d.beta, kincal::pi<double>() / 6, 1e-15);
  EXPECT_EQ(d.reference_extension, 850.0);
  expect_same_hybrid(ki::make_hybrid_geometry(d), ref);
  // At the reference pose the tool point is the workpiece origin and the tool
  // frame is aligned with the workpiece frame; the tool axis is −z there.
  ki::Robot r = ki::builtin_robot("hybrid-seed000");
  const kincal::Pose<double> home = r.home_pose();
  EXPECT_LT(home.p.norm(), 1e-12);
  EXPECT_LT((home.R - kincal::Mat3<double>::Identity()).norm(), 1e-15);
  EXPECT_LT((ref.tool_offset.transpose().col(2) + kincal::Vec3<double>::UnitZ()).norm(), 1e-15);
  // A custom machine (other β, longer tool) gets the same properties.
  ki::HybridDesign c = d;
  c.beta = 0.4;
  c.tool_length = 300;
  c.reference_extension = 900;
  r.hybrid() = ki::make_hybrid_geometry(c);
  const kincal::Pose<double> home2 = r.home_pose();
  EXPECT_LT(home2.p.norm(), 1e-12);
  EXPECT_LT((home2.R - kincal::Mat3<double>::Identity()).norm(), 1e-14);
  kincal::Vec6<double> q;
  ASSERT_EQ(r.inverse(home2, q), kincal::Status::Ok);
  EXPECT_NEAR(q(4), 0.4, 1e-12);  // θ5 = β at the reference pose
}

TEST(identifyRobot, UnknownBuiltinOrMissingFile) {
  try {
    ki::load_robot("/nonexistent/robot.json");
    FAIL();
  } catch (const ki::InputError& e) {
    EXPECT_EQ(e.file(), "/nonexistent/robot.json");
    EXPECT_NE(std::string(e.what()).find("nor a readable robot description file"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ki::builtin_robot("stewart-seed002"), ki::InputError);
}

TEST(identifyRobot, MalformedJsonReportsLineAndColumn) {
  // Line 3 has a missing comma between two members; the position is where
  // nlohmann/json's parser stopped: the end of the unexpected token.
  const std::string text = "{\n  \"format\": \"kincal-robot\"\n  \"version\": 1\n}\n";
  const ki::InputError e = parse_error(text);
  EXPECT_EQ(e.file(), "robot.json");
  EXPECT_EQ(e.line(), 3u);
  EXPECT_EQ(e.column(), 11u);
  EXPECT_NE(e.message().find("malformed JSON"), std::string::npos) << e.what();
  EXPECT_EQ(std::string(e.what()).rfind("robot.json:3:11: malformed JSON: syntax error", 0), 0u) << e.what();

  const ki::InputError trunc = parse_error(stewart_json().substr(0, 100));
  EXPECT_NE(trunc.message().find("malformed JSON"), std::string::npos);
  EXPECT_GT(trunc.line(), 1u);

  const ki::InputError empty = parse_error("");
  EXPECT_EQ(empty.line(), 1u);
  EXPECT_EQ(empty.column(), 1u);
}

TEST(identifyRobot, UnknownKeyIsNamedWithItsPosition) {
  const std::string text = replace(stewart_json(), "  \"screw_lead\"", "  \"colour\": \"red\",\n  \"screw_lead\"");
  const ki::InputError e = parse_error(text);
  EXPECT_NE(e.message().find("unknown key 'colour'"), std::string::npos) << e.what();
  EXPECT_NE(e.message().find("allowed:"), std::string::npos) << e.what();
  const std::size_t at = text.find("\"colour\"");
  const ki::TextPosition p = ki::position_of(text, at);
  EXPECT_EQ(e.line(), p.line);
  EXPECT_EQ(e.column(), p.column);
  // Nested objects too.
  const ki::InputError n = parse_error(replace(stewart_json(), "\"rz\": 0.0", "\"rz\": 0.0, \"w\": 1"));
  EXPECT_NE(n.message().find("unknown key 'w' in 'home'"), std::string::npos) << n.what();
}

TEST(identifyRobot, MissingKeyIsNamed) {
  std::string text = hybrid_json();
  text = replace(text, "  \"wrist_link\": 120.0,\n", "");
  const ki::InputError e = parse_error(text);
  EXPECT_NE(e.message().find("missing key 'wrist_link'"), std::string::npos) << e.what();
  EXPECT_EQ(e.line(), 1u);  // the enclosing object
  const ki::InputError f = parse_error(replace(stewart_json(), "\"family\": \"stewart-6ups\",\n", ""));
  EXPECT_NE(f.message().find("missing key 'family'"), std::string::npos) << f.what();
}

TEST(identifyRobot, WrongTypesAndValues) {
  const std::string s = stewart_json();
  {
    const std::string t = replace(s, "[120.0, -140.0, 0.0]", "[120.0, \"a\", 0.0]");
    const ki::InputError e = parse_error(t);
    EXPECT_NE(e.message().find("'base_joints/0/1' must be a number, not a string"), std::string::npos) << e.what();
    const ki::TextPosition p = ki::position_of(t, t.find("\"a\""));
    EXPECT_EQ(e.line(), p.line);
    EXPECT_EQ(e.column(), p.column);
  }
  {
    const ki::InputError e = parse_error(replace(s, "[120.0, -140.0, 0.0]", "[120.0, -140.0]"));
    EXPECT_NE(e.message().find("'base_joints/0' must have 3 entries, not 2"), std::string::npos) << e.what();
  }
  {
    // 1e999 overflows to infinity in the JSON parser: non-finite.
    const ki::InputError e = parse_error(replace(s, "[120.0, -140.0, 0.0]", "[1e999, -140.0, 0.0]"));
    EXPECT_NE(e.message().find("finite"), std::string::npos) << e.what();
  }
  {
    const ki::InputError e = parse_error(replace(hybrid_json(), "\"tool_length\": 250.0", "\"tool_length\": -250.0"));
    EXPECT_NE(e.message().find("'tool_length' must be positive"), std::string::npos) << e.what();
  }
  {
    const ki::InputError e = parse_error(replace(hybrid_json(), "\"wrist_link\": 120.0", "\"wrist_link\": -1"));
    EXPECT_NE(e.message().find("'wrist_link' is a length and must not be negative"), std::string::npos) << e.what();
  }
  {
    const ki::InputError e = parse_error(replace(s, "\"min\": [183.23808,", "\"min\": [-1,"));
    EXPECT_NE(e.message().find("must not be negative"), std::string::npos) << e.what();
  }
  {
    const ki::InputError e = parse_error(replace(s, "\"family\": \"stewart-6ups\"", "\"family\": \"delta\""));
    EXPECT_NE(e.message().find("unknown family 'delta'"), std::string::npos) << e.what();
  }
  {
    const ki::InputError e = parse_error(replace(s, "\"length\": \"mm\"", "\"length\": \"m\""));
    EXPECT_NE(e.message().find("unsupported length unit"), std::string::npos) << e.what();
  }
  {
    const ki::InputError e = parse_error(replace(s, "\"version\": 1", "\"version\": 2"));
    EXPECT_NE(e.message().find("version"), std::string::npos) << e.what();
  }
  {
    const ki::InputError e = parse_error(replace(s, "\"z\": 200.0", "\"z\": 900.0"));
    EXPECT_NE(e.message().find("the home pose is not reachable: out of limits"), std::string::npos) << e.what();
  }
  {
    const ki::InputError e = parse_error(replace(s, "\"name\": \"stewart-seed001\",", "\"name\": \"a\", \"name\": \"b\","));
    EXPECT_NE(e.message().find("duplicate key 'name'"), std::string::npos) << e.what();
  }
  {
    const ki::InputError e = parse_error("[1, 2]");
    EXPECT_NE(e.message().find("must be a JSON object"), std::string::npos) << e.what();
  }
}

TEST(identifyRobot, OptionalKeysHaveDefaults) {
  std::string t = replace(hybrid_json(), "  \"joint_offset\": [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],\n", "");
  t = replace(t, "  \"gauge_radius\": 200.0,\n", "");
  t = replace(t, ",\n  \"screw_lead\": 5.0", "");
  const ki::Robot h = ki::parse_robot(t, "h.json");
  EXPECT_EQ(h.hybrid_description().gauge_radius, 200.0);
  EXPECT_EQ(h.screw_lead, 5.0);
  EXPECT_EQ(h.hybrid().joint_offset, kincal::Vec6<double>::Zero());
}

TEST(identifyRobot, SummaryMentionsFamilyAndHome) {
  const std::string s = ki::robot_summary(ki::builtin_robot("hybrid-seed000"));
  EXPECT_NE(s.find("hybrid-3ups-up-3r"), std::string::npos);
  EXPECT_NE(s.find("joints at home"), std::string::npos);
}
