// Parameter-error files (PARAMS.csv) and the --effect placeholder.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "kincal/identify/input_error.hpp"
#include "kincal/identify/effects.hpp"
#include "kincal/identify/parameters.hpp"

namespace ki = kincal::identify;

namespace {
bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

ki::InputError params_error(const std::string& text, const ki::Robot& robot) {
  try {
    ki::parse_parameters(text, "p.csv", robot);
  } catch (const ki::InputError& e) {
    return e;
  }
  ADD_FAILURE() << "no InputError for:\n" << text;
  return ki::InputError("none");
}
}  // namespace

TEST(identifyParameters, StewartNamesFollowSeed001Table3) {
  const ki::Robot s = ki::builtin_robot("stewart-seed001");
  const std::vector<std::string> names = ki::parameter_names(s);
  ASSERT_EQ(names.size(), 42u);
  EXPECT_EQ(names[0], "dXB1");
  EXPECT_EQ(names[3], "dl1");
  EXPECT_EQ(names[6], "dZP1");
  EXPECT_EQ(names[41], "dZP6");
}

TEST(identifyParameters, StewartValuesAddToTheRightQuantity) {
  const ki::Robot s = ki::builtin_robot("stewart-seed001");
  const ki::ParameterSet p =
      ki::parse_parameters("name,value\ndXB2,0.5\ndZP6,-0.25\ndl3,0.125\ndYP1,1\n", "p.csv", s);
  const ki::Robot a = ki::apply_parameters(s, p);
  EXPECT_EQ(a.stewart().base(0, 1), s.stewart().base(0, 1) + 0.5);
  EXPECT_EQ(a.stewart().platform(2, 5), -0.25);
  EXPECT_EQ(a.stewart().length_offset(2), 0.125);
  EXPECT_EQ(a.stewart().platform(1, 0), s.stewart().platform(1, 0) + 1);
  // Nothing else changed.
  kincal::StewartGeometry<double> g = a.stewart();
  g.base(0, 1) -= 0.5;
  g.platform(2, 5) += 0.25;
  g.length_offset(2) = 0;
  g.platform(1, 0) -= 1;
  EXPECT_EQ(g.base, s.stewart().base);
  EXPECT_EQ(g.platform, s.stewart().platform);
  EXPECT_EQ(g.length_offset, s.stewart().length_offset);
}

TEST(identifyParameters, HybridNamesAreCaseSensitive) {
  const ki::Robot h = ki::builtin_robot("hybrid-seed000");
  // encoder offsets, UPS joint centres, wrist lengths, seed 000's 150 source
  // errors and the tool frame's 6 (issue #31)
  EXPECT_EQ(ki::parameter_names(h).size(), 6u + 9u + 9u + 3u + 150u + 6u);
  const ki::ParameterSet p = ki::parse_parameters(
      "name,value\ndq2,0.1\ndtheta5,0.001\ndXA1,0.2\ndXa1,0.3\nd_tool_length,-0.4\n", "p.csv", h);
  const ki::Robot a = ki::apply_parameters(h, p);
  EXPECT_EQ(a.hybrid().joint_offset(1), 0.1);
  EXPECT_EQ(a.hybrid().joint_offset(4), 0.001);
  EXPECT_EQ(a.hybrid().base_joints(0, 0), h.hybrid().base_joints(0, 0) + 0.2);
  EXPECT_EQ(a.hybrid().platform_joints(0, 0), h.hybrid().platform_joints(0, 0) + 0.3);
  EXPECT_EQ(a.hybrid().tool_length, 250 - 0.4);
  // The measurement frame is not part of the error set.
  EXPECT_EQ(a.hybrid().workpiece_origin, h.hybrid().workpiece_origin);
  EXPECT_EQ(a.hybrid().tool_offset, h.hybrid().tool_offset);
}

TEST(identifyParameters, UnknownNameListsTheValidOnes) {
  const ki::Robot s = ki::builtin_robot("stewart-seed001");
  const ki::InputError e = params_error("name,value\ndXB1,0.1\ndXB7,0.2\n", s);
  EXPECT_EQ(e.file(), "p.csv");
  EXPECT_EQ(e.line(), 3u);
  EXPECT_EQ(e.column(), 1u);
  EXPECT_TRUE(contains(e.message(), "unknown parameter 'dXB7' for family stewart-6ups (valid: dXB1, dYB1, dZB1, dl1,"))
      << e.what();
  EXPECT_TRUE(contains(e.message(), "dZP6)")) << e.what();
  // A hybrid name is not a stewart name.
  EXPECT_TRUE(contains(params_error("name,value\ndq1,0.1\n", s).message(), "unknown parameter 'dq1'"));
}

TEST(identifyParameters, OtherBadInput) {
  const ki::Robot s = ki::builtin_robot("stewart-seed001");
  EXPECT_EQ(std::string(params_error("name,value\ndl1,0.1\ndl1,0.2\n", s).what()),
            "p.csv:3:1: parameter 'dl1' given twice (first at line 2)");
  EXPECT_EQ(std::string(params_error("name,value\ndl1,nan\n", s).what()),
            "p.csv:2:5: non-finite value 'nan' in column 'value' (NaN/Inf are rejected)");
  EXPECT_TRUE(contains(params_error("name,val\ndl1,0.1\n", s).what(), "p.csv:1: missing required columns: value"));
  EXPECT_TRUE(contains(params_error("", s).what(), "empty file"));
  // A header alone is an empty error set, not an error.
  EXPECT_TRUE(ki::parse_parameters("name,value\n", "p.csv", s).values.empty());
}

TEST(identifyParameters, EffectOptionsAreParsedAndCheckedAgainstTheRegistry) {
  const ki::EffectSetting e = ki::parse_effect_option("scale:s1=1e-4");
  EXPECT_EQ(e.effect, "scale");
  EXPECT_EQ(e.parameter, "s1");
  EXPECT_EQ(e.value, 1e-4);
  const ki::Robot robot = ki::builtin_robot("stewart-seed001");
  ki::EffectValues values;
  values.set(robot, e.effect, e.parameter, e.value);
  EXPECT_EQ(values.to_core(robot).scale(0), 1e-4);
  try {
    values.set(robot, "warp", "s1", 1.0);
    FAIL() << "unknown effect accepted";
  } catch (const ki::InputError& err) {
    EXPECT_TRUE(contains(err.what(), "unknown effect 'warp' (known: scale, backlash, compliance, thermal, cyclic")) << err.what();
  }
  EXPECT_THROW(values.set(robot, "scale", "s7", 1.0), ki::InputError);
  EXPECT_THROW(values.set(ki::builtin_robot("hybrid-seed000"), "cyclic", "a4", 1.0), ki::InputError);
  for (const std::string bad : {"scale", "scale:s1", "scale:=1", ":s1=1", "scale:s1=", "scale:s1=abc", "scale:s1=nan"})
    EXPECT_THROW(ki::parse_effect_option(bad), ki::InputError) << bad;
}

TEST(identifyParameters, OneEffectOptionMaySetSeveralNumbers) {
  const std::vector<ki::EffectSetting> e = ki::parse_effect_options("scale:s1=1e-4,s3=-2.5e-5");
  ASSERT_EQ(e.size(), 2u);
  EXPECT_EQ(e[0].effect, "scale");
  EXPECT_EQ(e[0].parameter, "s1");
  EXPECT_EQ(e[0].value, 1e-4);
  EXPECT_EQ(e[1].effect, "scale");
  EXPECT_EQ(e[1].parameter, "s3");
  EXPECT_EQ(e[1].value, -2.5e-5);
  EXPECT_EQ(ki::parse_effect_options("thermal:c=1.2e-5").size(), 1u);
  for (const std::string bad : {"scale:s1=1e-4,", "scale:s1=1e-4,,s2=1", "scale:s1=1e-4,s2", "scale:s1=1e-4,s2=x", "scale"})
    try {
      ki::parse_effect_options(bad);
      ADD_FAILURE() << bad << " accepted";
    } catch (const ki::InputError& err) {
      EXPECT_TRUE(contains(err.what(), "--effect '")) << err.what();
    }
}
