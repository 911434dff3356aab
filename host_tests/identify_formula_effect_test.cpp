// Formula effects (identify/formula_effect.hpp; GUIDE "Effects written as
// formulas"; issue #32): the GUIDE's three examples against hand-written
// C++, exact derivatives against finite differences (here, in the test; the
// module differentiates symbolically), every refusal of the contract with
// its place, a non-finite value named by node, and the generated C++
// compiled (host, and the firmware's arm-none-eabi-g++ where installed)
// giving the evaluator's numbers.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "kincal/core/formula_effects.hpp"
#include "kincal/identify/formula_effect.hpp"
#include "kincal/identify/input_error.hpp"

namespace ki = kincal::identify;

namespace {

const ki::FormulaContext kContext{};  // 6 joints, no family variables

ki::FormulaEffectSpec joint_spec(const std::string& name, std::vector<int> joints, std::vector<std::string> per_joint,
                                 std::vector<std::string> shared, const std::string& formula) {
  ki::FormulaEffectSpec s;
  s.name = name;
  s.kind = ki::FormulaKind::Joint;
  s.joints = std::move(joints);
  s.per_joint = std::move(per_joint);
  s.shared = std::move(shared);
  s.formulas = {formula};
  return s;
}

// The GUIDE's three examples, as a robot description would carry them.
const char* kGuideEffects = R"J({
  "family": "stewart-6ups",
  "effects": [
    {"name": "leg_thermal", "description": "legs 1 and 2 expand with temperature",
     "kind": "joint", "joints": [1, 2], "per_joint": ["a"], "shared": [],
     "formula": "a * q * (temp - 20)"},
    {"name": "ramp", "kind": "joint", "joints": [3, 6], "per_joint": ["g"], "shared": ["q0"],
     "start": {"q0": 250}, "formula": "g * max(0, q - q0)^2"},
    {"name": "sag", "kind": "pose", "shared": ["k"],
     "formula": {"dx": "0", "dy": "0", "dz": "-k * (x^2 + y^2)", "drx": "0", "dry": "0", "drz": "0"}}
  ]
})J";

// A node: random commands, directions, loads, temperature, time and pose.
std::vector<double> random_node(const ki::FormulaLayout& l, std::mt19937& rng) {
  std::uniform_real_distribution<double> q(150, 400), u(-1, 1);
  std::vector<double> v(static_cast<std::size_t>(l.size()));
  for (int j = 1; j <= l.joints; ++j) {
    v[static_cast<std::size_t>(l.q(j))] = q(rng);
    v[static_cast<std::size_t>(l.dir(j))] = u(rng) < 0 ? -1 : 1;
    v[static_cast<std::size_t>(l.load(j))] = 50 * u(rng);
  }
  v[static_cast<std::size_t>(l.temp())] = 20 + 10 * u(rng);
  v[static_cast<std::size_t>(l.time())] = 100 + 50 * u(rng);
  for (int c = 0; c < 3; ++c) v[static_cast<std::size_t>(l.pose(c))] = 200 * u(rng);
  for (int c = 3; c < 6; ++c) v[static_cast<std::size_t>(l.pose(c))] = 0.1 * u(rng);
  for (int i = 0; i < l.input_count; ++i) v[static_cast<std::size_t>(l.input(i))] = 3 * u(rng);
  for (int i = 0; i < l.family_count; ++i) v[static_cast<std::size_t>(l.family(i))] = 2 * u(rng);
  return v;
}

// The InputError of `f`; fails the test when nothing (or something else) is thrown.
ki::InputError error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const ki::InputError& e) {
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    return e;
  }
  ADD_FAILURE() << "no InputError";
  return ki::InputError("none");
}

ki::InputError read_error(const std::string& text) {
  return error_of([&] { ki::read_formula_effects(text, "robot.json", kContext); });
}

// Line and column (1-based) of the first `needle` in `text`.
std::pair<std::size_t, std::size_t> line_column(const std::string& text, const std::string& needle) {
  const std::size_t at = text.find(needle);
  const ki::TextPosition p = ki::position_of(text, at);
  return {p.line, p.column};
}

// Effects list with one entry.
std::string one_effect(const std::string& entry) { return "{\"effects\": [\n  " + entry + "\n]}"; }

}  // namespace

TEST(FormulaEffect, GuideExamplesEqualHandWrittenCpp) {
  const std::vector<ki::FormulaEffect> effects = ki::read_formula_effects(kGuideEffects, "robot.json", kContext);
  ASSERT_EQ(effects.size(), 3u);
  const ki::FormulaEffect& thermal = effects[0];
  const ki::FormulaEffect& ramp = effects[1];
  const ki::FormulaEffect& sag = effects[2];

  EXPECT_EQ(thermal.parameter_names(), (std::vector<std::string>{"a1", "a2"}));
  EXPECT_EQ(thermal.output_count(), 2);
  EXPECT_EQ(thermal.required_columns(), (std::vector<std::string>{"temp"}));
  EXPECT_TRUE(thermal.uses_temperature());
  EXPECT_EQ(ramp.parameter_names(), (std::vector<std::string>{"g3", "g6", "q0"}));
  EXPECT_EQ(ramp.start_values(), (std::vector<double>{0, 0, 250}));
  EXPECT_TRUE(ramp.required_columns().empty());
  EXPECT_EQ(ramp.output_name(1), "dq6");
  EXPECT_EQ(sag.kind(), ki::FormulaKind::Pose);
  EXPECT_EQ(sag.parameter_names(), (std::vector<std::string>{"k"}));
  EXPECT_EQ(sag.output_count(), 6);
  EXPECT_EQ(sag.output_name(2), "dz");

  std::mt19937 rng(7);
  const ki::FormulaLayout& l = thermal.layout();
  for (int n = 0; n < 200; ++n) {
    const std::vector<double> v = random_node(l, rng);
    const auto at = [&](int i) { return v[static_cast<std::size_t>(i)]; };
    const double a[2] = {1.1e-5, -2.3e-5};
    for (int k = 0; k < 2; ++k) {
      const int j = k + 1;
      EXPECT_NEAR(thermal.value(k, v.data(), a), a[k] * at(l.q(j)) * (at(l.temp()) - 20), 1e-15);
    }
    const double g[3] = {3e-5, -4e-5, 240.0 + 40.0 * (n % 3)};  // g3, g6, q0
    const int ramp_joint[2] = {3, 6};
    for (int k = 0; k < 2; ++k) {
      const double over = std::max(0.0, at(l.q(ramp_joint[k])) - g[2]);
      EXPECT_NEAR(ramp.value(k, v.data(), g), g[k] * over * over, 1e-13);
    }
    const double kk[1] = {2e-7};
    const double x = at(l.pose(0)), y = at(l.pose(1));
    double twist[6];
    ki::FormulaWorkspace ws;
    sag.evaluate(v.data(), kk, twist, nullptr, "n" + std::to_string(n), ws);
    for (int c = 0; c < 6; ++c) EXPECT_EQ(twist[c] == 0.0, c != 2) << c;
    EXPECT_NEAR(twist[2], -kk[0] * (x * x + y * y), 1e-15);
  }
}

// The module's derivatives are exact (symbolic); here they meet central
// differences, on formulas that use every function.
TEST(FormulaEffect, GradientsMatchFiniteDifferences) {
  ki::FormulaContext context;
  context.family_variables = {"crank"};
  ki::FormulaEffectSpec joint = joint_spec(
      "mix", {1, 4, 5}, {"a", "b"}, {"c", "w"},
      "a * sin(q / 40 + c) + b^2 * exp(-w * temp / 100) * atan2(q1, q2) + sqrt(abs(q - 250) + 1) * sign(dir)"
      " + min(q, 300 + c)^3 / 1e6 + log(1 + w^2) / tan(0.3) + cos(load * a) + asin(0.1 * w) + acos(0.2) * atan(hum)"
      " + crank * c^(1/3) * b + q^-2 * a + pi * time / 1000 * b");
  joint.inputs = {"hum"};
  const ki::FormulaEffect mix(joint, context);
  ki::FormulaEffectSpec pose;
  pose.name = "bend";
  pose.kind = ki::FormulaKind::Pose;
  pose.shared = {"u", "v"};
  pose.formulas = {"u * z", "v * x * y / 1000", "-u * (x^2 + y^2) / 1000", "v * sin(rz)", "u * v * q3", "max(u, v) * rx"};
  const ki::FormulaEffect bend(pose, context);

  std::mt19937 rng(11);
  for (const ki::FormulaEffect* e : {&mix, &bend}) {
    const std::size_t P = e->parameter_names().size();
    for (int n = 0; n < 20; ++n) {
      const std::vector<double> v = random_node(e->layout(), rng);
      std::vector<double> p(P);
      std::uniform_real_distribution<double> u(0.2, 1.5);
      for (auto& x : p) x = u(rng);
      std::vector<double> values(static_cast<std::size_t>(e->output_count())),
          jac(static_cast<std::size_t>(e->output_count()) * P);
      ki::FormulaWorkspace ws;
      e->evaluate(v.data(), p.data(), values.data(), jac.data(), "node", ws);
      for (int o = 0; o < e->output_count(); ++o) {
        std::vector<double> g(P);
        e->gradient(o, v.data(), p.data(), g.data());
        EXPECT_DOUBLE_EQ(values[static_cast<std::size_t>(o)], e->value(o, v.data(), p.data()));
        for (std::size_t k = 0; k < P; ++k) {
          EXPECT_EQ(g[k], jac[static_cast<std::size_t>(o) * P + k]);
          const double h = 1e-6 * std::max(1.0, std::abs(p[k]));
          std::vector<double> up = p, down = p;
          up[k] += h;
          down[k] -= h;
          const double fd = (e->value(o, v.data(), up.data()) - e->value(o, v.data(), down.data())) / (2 * h);
          EXPECT_NEAR(g[k], fd, 1e-6 * std::max(1.0, std::abs(fd)))
              << e->name() << " " << e->output_name(o) << " d/d" << e->parameter_names()[k];
        }
      }
    }
  }
  // Per-joint parameters act on their own joint only.
  std::vector<double> v = random_node(mix.layout(), rng), p(mix.parameter_names().size(), 0.5), g(p.size());
  mix.gradient(1, v.data(), p.data(), g.data());  // joint 4: a4 (index 1), b4 (index 4)
  for (std::size_t k : {0u, 2u, 3u, 5u}) EXPECT_EQ(g[k], 0.0) << mix.parameter_names()[k];
  EXPECT_NE(g[1], 0.0);
  EXPECT_NE(g[4], 0.0);
  EXPECT_EQ(mix.required_columns(), (std::vector<std::string>{"temp", "time", "hum"}));
  EXPECT_TRUE(mix.uses_direction());
  EXPECT_TRUE(mix.uses_load());
}

// At a kink the derivative is the mean of the two sides (documented in
// formula_effect.cpp): finite, so a ramp whose start sits on a commanded
// value still gets a column.
TEST(FormulaEffect, KinkDerivativeIsTheMeanOfTheSides) {
  const ki::FormulaEffect m(joint_spec("kink", {1}, {}, {"q0"}, "max(0, q - q0)"), kContext);
  std::vector<double> v(static_cast<std::size_t>(m.layout().size()), 0.0);
  v[0] = 250;
  const double q0[1] = {250};
  double g[1];
  m.gradient(0, v.data(), q0, g);
  EXPECT_EQ(g[0], -0.5);
  const ki::FormulaEffect s(joint_spec("s", {1}, {"b"}, {}, "b * sign(q) + b * abs(q)"), kContext);
  v[0] = 0;
  const double b[1] = {2};
  double values[1], jac[1];
  ki::FormulaWorkspace ws;
  s.evaluate(v.data(), b, values, jac, "zero", ws);
  EXPECT_EQ(values[0], 0.0);
  EXPECT_EQ(jac[0], 0.0);
}

TEST(FormulaEffect, ParseErrorNamesFileLineColumnAndPlaceInFormula) {
  const std::string text = one_effect(R"J({"name": "bad", "kind": "joint", "per_joint": ["a"],
   "formula": "q +* a"})J");
  const ki::InputError e = read_error(text);
  const auto [line, column] = line_column(text, "\"formula\"");
  EXPECT_EQ(e.file(), "robot.json");
  EXPECT_EQ(e.line(), line);
  EXPECT_EQ(e.column(), column);
  EXPECT_NE(e.message().find("effect 'bad'"), std::string::npos) << e.what();
  EXPECT_NE(e.message().find("character 4"), std::string::npos) << e.what();
  EXPECT_NE(e.message().find("\"q +* a\""), std::string::npos) << e.what();
  EXPECT_EQ(std::string(e.what()).rfind("robot.json:" + std::to_string(line) + ":" + std::to_string(column) + ": ", 0), 0u)
      << e.what();

  // More places: an unclosed call (just past the end), a^b^c, a bad character.
  const auto formula_error = [](const std::string& formula) {
    return error_of([&] { ki::FormulaEffect(joint_spec("f", {1}, {"a"}, {}, formula), kContext); }).message();
  };
  EXPECT_NE(formula_error("a * sin(q").find("character 10"), std::string::npos) << formula_error("a * sin(q");
  EXPECT_NE(formula_error("a^q^2").find("parentheses"), std::string::npos) << formula_error("a^q^2");
  EXPECT_NE(formula_error("a * q $ 2").find("character 7: unexpected character '$'"), std::string::npos)
      << formula_error("a * q $ 2");
  EXPECT_NE(formula_error("a * q * 1e99999").find("out of range"), std::string::npos);
  EXPECT_NE(formula_error("a * 1e400").find("does not fit a double"), std::string::npos);
  EXPECT_NE(formula_error("").find("is empty"), std::string::npos);
  EXPECT_NE(formula_error("a * sin(q, q)").find("character 5: sin takes 1 argument, not 2"), std::string::npos)
      << formula_error("a * sin(q, q)");
  EXPECT_NE(formula_error("a * tan()").find("tan takes 1 argument, not 0"), std::string::npos);  // crashed GiNaC
  EXPECT_NE(formula_error("a * max(q)").find("max takes 2 arguments, not 1"), std::string::npos);
  EXPECT_NE(formula_error("a / (q - q)").find("division by zero"), std::string::npos) << formula_error("a / (q - q)");
}

TEST(FormulaEffect, UnknownSymbolIsNamedWithTheAllowedOnes) {
  const std::string text = one_effect(R"J({"name": "u", "kind": "joint", "per_joint": ["a"], "inputs": ["hum"],
   "formula": "a * q * humidity"})J");
  const ki::InputError e = read_error(text);
  const std::string m = e.message();
  EXPECT_NE(m.find("unknown symbol 'humidity'"), std::string::npos) << m;
  EXPECT_NE(m.find("character 9"), std::string::npos) << m;
  EXPECT_NE(m.find("allowed: a, q, q1..q6, dir, dir1..dir6, load, load1..load6, temp, time, hum, pi"), std::string::npos) << m;
  EXPECT_EQ(e.line(), line_column(text, "\"formula\"").first);

  const auto message = [](const ki::FormulaEffectSpec& s) {
    return error_of([&] { ki::FormulaEffect(s, kContext); }).message();
  };
  EXPECT_NE(message(joint_spec("f", {1}, {"a"}, {}, "a * foo(q)")).find("unknown function 'foo' (functions: sin, cos"),
            std::string::npos);
  EXPECT_NE(message(joint_spec("f", {1}, {"a"}, {}, "a * q(1)")).find("'q' is a variable, not a function"),
            std::string::npos);
  EXPECT_NE(message(joint_spec("f", {1}, {"a"}, {}, "a * sin")).find("'sin' is a function"), std::string::npos);
  // x, y, z… are a pose effect's, not a joint effect's.
  EXPECT_NE(message(joint_spec("f", {1}, {"a"}, {}, "a * x")).find("unknown symbol 'x'"), std::string::npos);
  // GiNaC's own literals are no way in.
  EXPECT_NE(message(joint_spec("f", {1}, {"a"}, {}, "a * I")).find("unknown symbol 'I'"), std::string::npos);
}

// Numbers a family offers per joint (the 6-RUS's rod and lever): in a
// joint-kind formula the bare name is the acting joint's, name1..name6 any
// joint's; they sit where core's compensator writes them
// (FormulaSlot::family_joint, after kFormulaInputs input slots), so the
// generated C++ and the host read one array.
TEST(FormulaEffect, FamilyJointVariablesAreTheJointsOwnAndEachJoints) {
  ki::FormulaContext context;
  context.family_joint_variables = {"rod", "lever"};
  context.max_inputs = kincal::kFormulaInputs;
  const ki::FormulaEffect rods(
      joint_spec("rods", {2, 5}, {"a"}, {"b"}, "a * rod * (temp - 20) / lever + b * lever3"), context);
  const ki::FormulaLayout& l = rods.layout();
  EXPECT_EQ(l.family_joint(0, 1), kincal::FormulaSlot::family_joint);
  EXPECT_EQ(l.family_joint(1, 1), kincal::FormulaSlot::family_joint + 6);
  EXPECT_EQ(l.size(), kincal::FormulaSlot::count);
  EXPECT_TRUE(rods.uses_family());
  EXPECT_TRUE(rods.uses_temperature());
  EXPECT_FALSE(ki::FormulaEffect(joint_spec("plain", {1}, {"a"}, {}, "a * q"), context).uses_family());

  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> v = random_node(l, rng);
  for (int j = 1; j <= 6; ++j) {
    v[std::size_t(l.family_joint(0, j))] = 300 + j;
    v[std::size_t(l.family_joint(1, j))] = 80 * u(rng);
  }
  const double params[3] = {2e-5, 3e-5, 0.7};  // a2, a5, b
  for (int k = 0; k < 2; ++k) {
    const int j = rods.joints()[std::size_t(k)];
    const double expected = params[k] * (300 + j) * (v[std::size_t(l.temp())] - 20) / v[std::size_t(l.family_joint(1, j))] +
                            params[2] * v[std::size_t(l.family_joint(1, 3))];
    EXPECT_NEAR(rods.value(k, v.data(), params), expected, 1e-15 * (1 + std::abs(expected))) << "joint " << j;
  }

  // A pose effect has no joint of its own: lever3 yes, lever no.
  ki::FormulaEffectSpec pose;
  pose.name = "p";
  pose.kind = ki::FormulaKind::Pose;
  pose.shared = {"k"};
  pose.formulas = {"k * lever3", "0", "0", "0", "0", "0"};
  EXPECT_TRUE(ki::FormulaEffect(pose, context).uses_family());
  pose.formulas[0] = "k * lever";
  EXPECT_NE(error_of([&] { ki::FormulaEffect(pose, context); }).message().find("unknown symbol 'lever'"),
            std::string::npos);
  // The family's names are taken: no parameter or input may use them.
  EXPECT_NE(error_of([&] { ki::FormulaEffect(joint_spec("f", {1}, {"rod"}, {}, "rod * q"), context); })
                .message()
                .find("'rod' is used twice"),
            std::string::npos);
  // And an unknown symbol's message lists them.
  EXPECT_NE(error_of([&] { ki::FormulaEffect(joint_spec("f", {1}, {"a"}, {}, "a * crank"), context); })
                .message()
                .find("rod, rod1..rod6, lever, lever1..lever6"),
            std::string::npos);
}

TEST(FormulaEffect, EveryContractRuleHasItsError) {
  struct Case {
    std::string entry, expected, at_key;
  };
  const std::vector<Case> cases = {
      {R"J({"name": "u", "kind": "joint", "per_joint": ["a", "b"], "formula": "a * q"})J",
       "the parameter 'b' is not used by the formula", "\"per_joint\""},
      {R"J({"name": "u", "kind": "joint", "shared": ["c"], "per_joint": ["a"], "formula": "a * q + c * 0"})J",
       "the parameter 'c' is not used", "\"shared\""},
      {R"J({"name": "thermal", "kind": "joint", "per_joint": ["a"], "formula": "a * q"})J",
       "clashes with the built-in effect 'thermal'", "\"name\""},
      {R"J({"name": "u", "kind": "joint", "shared": ["temp"], "formula": "temp * q"})J",
       "the shared parameter 'temp' clashes with a built-in variable", "\"shared\""},
      {R"J({"name": "u", "kind": "joint", "shared": ["q3"], "formula": "q3 * q"})J",
       "'q3' clashes with a built-in variable", "\"shared\""},
      {R"J({"name": "u", "kind": "joint", "per_joint": ["a1"], "formula": "a1 * q"})J",
       "the per-joint parameter 'a1' ends in a digit", "\"per_joint\""},
      {R"J({"name": "u", "kind": "joint", "joints": [2, 7], "per_joint": ["a"], "formula": "a * q"})J",
       "joint 7 is out of range: joints are 1..6", "\"joints\""},
      {R"J({"name": "u", "kind": "joint", "joints": [0], "per_joint": ["a"], "formula": "a * q"})J",
       "joint 0 is out of range", "\"joints\""},
      {R"J({"name": "u", "kind": "joint", "joints": [2, 2], "per_joint": ["a"], "formula": "a * q"})J",
       "joint 2 is listed twice", "\"joints\""},
      {R"J({"name": "u", "kind": "joint", "per_joint": ["a"], "shared": ["a"], "formula": "a * q"})J",
       "'a' is used twice", "\"shared\""},
      {R"J({"name": "u", "kind": "joint", "joints": [1], "per_joint": ["a"], "shared": ["a1"], "formula": "a * q + a1"})J",
       "'a1' clashes with another name", "\"per_joint\""},
      {R"J({"name": "u", "kind": "joint", "per_joint": ["a"], "start": {"b": 1}, "formula": "a * q"})J",
       "'start' names 'b', which is no parameter (parameters: a1, a2, a3, a4, a5, a6)", "\"b\""},
      {R"J({"name": "u", "kind": "joint", "formula": "q"})J", "the effect has no parameter", "{\"name\""},
      {R"J({"name": "u v", "kind": "joint", "shared": ["c"], "formula": "c"})J", "the name must be a letter", "\"name\""},
      {R"J({"name": "u", "kind": "pose", "per_joint": ["a"], "formula": {"dz": "a"}})J",
       "a pose effect has no acting joint", "\"per_joint\""},
      {R"J({"name": "u", "kind": "pose", "shared": ["k"], "formula": {"dz": "k * q"}})J", "unknown symbol 'q'",
       "\"dz\""},
      {R"J({"name": "u", "kind": "pose", "shared": ["k"], "formula": {"dw": "k"}})J", "unknown key 'dw'", "\"dw\""},
      {R"J({"name": "u", "kind": "rotary", "shared": ["k"], "formula": "k"})J", "'kind' must be \"joint\" or \"pose\"",
       "\"rotary\""},
      {R"J({"name": "u", "kind": "joint", "shared": ["k"], "formula": "k", "colour": 1})J", "unknown key 'colour'",
       "\"colour\""},
      {R"J({"name": "u", "kind": "joint", "joints": [1.5], "shared": ["k"], "formula": "k"})J",
       "'joints' entries must be whole joint numbers", "1.5"},
  };
  for (const Case& c : cases) {
    const std::string text = one_effect(c.entry);
    const ki::InputError e = read_error(text);
    EXPECT_NE(e.message().find(c.expected), std::string::npos) << c.entry << "\n -> " << e.what();
    const auto [line, column] = line_column(text, c.at_key);
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_EQ(e.column(), column) << c.entry << "\n -> " << e.what();
    EXPECT_EQ(e.file(), "robot.json");
  }

  // Two effects with one name: the second is named, with the first's place.
  const std::string twice = R"J({"effects": [
  {"name": "u", "kind": "joint", "shared": ["k"], "formula": "k"},
  {"name": "u", "kind": "joint", "shared": ["c"], "formula": "c * q"}]})J";
  const ki::InputError e = read_error(twice);
  EXPECT_NE(e.message().find("two effects are named 'u' (the other is 'effects/0')"), std::string::npos) << e.what();
  EXPECT_EQ(e.line(), 3u);
  // Not an array; malformed JSON (the reader's own errors).
  EXPECT_NE(read_error(R"J({"effects": {}})J").message().find("'effects' must be an array"), std::string::npos);
  EXPECT_NE(read_error(R"J({"effects": [)J").message().find("malformed JSON"), std::string::npos);
  // No key: no effects.
  EXPECT_TRUE(ki::read_formula_effects(R"J({"family": "stewart-6ups"})J", "robot.json", kContext).empty());
}

TEST(FormulaEffect, NonFiniteValueAtANodeIsNamed) {
  const ki::FormulaEffect e(joint_spec("lg", {1, 2}, {"a"}, {}, "a * log(q)"), kContext);
  std::vector<double> v(static_cast<std::size_t>(e.layout().size()), 1.0);
  v[1] = -1;  // q2
  const double a[2] = {1, 1};
  double values[2], jac[4];
  ki::FormulaWorkspace ws;
  const ki::InputError err = error_of([&] { e.evaluate(v.data(), a, values, jac, "'n17' (MEAS.csv row 18)", ws); });
  const std::string m = err.what();
  EXPECT_NE(m.find("formula effect 'lg' is not finite at node 'n17' (MEAS.csv row 18): dq2 = nan"), std::string::npos) << m;
  EXPECT_NE(m.find("q2 = -1"), std::string::npos) << m;
  EXPECT_NE(m.find("a2 = 1"), std::string::npos) << m;
  // A finite value with an infinite derivative is refused too (sqrt at 0).
  const ki::FormulaEffect s(joint_spec("sq", {1}, {}, {"c"}, "sqrt(q - c)"), kContext);
  v[0] = 5;
  const double c[1] = {5};
  const std::string ms = error_of([&] { s.evaluate(v.data(), c, values, jac, "n3", ws); }).what();
  EXPECT_NE(ms.find("ddq1/dc = "), std::string::npos) << ms;
  // Without the Jacobian the value alone is checked, and it is finite.
  s.evaluate(v.data(), c, values, nullptr, "n3", ws);
  EXPECT_EQ(values[0], 0.0);
}

// The generated C++ compiles with the host compiler, and in double gives
// the evaluator's numbers (same operations in the same order), in float
// within float's rounding; with arm-none-eabi-g++ present it also compiles
// for the Cortex-M7 in both scalars.
TEST(FormulaEffect, GeneratedCppCompilesAndEqualsTheEvaluator) {
  ki::FormulaContext context;
  std::vector<ki::FormulaEffect> effects = ki::read_formula_effects(kGuideEffects, "robot.json", context);
  ki::FormulaEffectSpec rich = joint_spec(
      "rich", {2, 5}, {"a", "b"}, {"c"},
      "a * sin(q / 40 + c) + b * exp(-c * temp / 100) * atan2(q1, q2) + sqrt(abs(q - 250) + 1) * sign(dir)"
      " + min(q, 300)^3 / 1e6 + log(1 + c^2) / tan(0.3) + cos(load * a) + asin(0.1 * c) + acos(0.2) * atan(hum)"
      " + q^-2 * a + q^(1/3) * b + pi * time / 1000 * b + q^11 * 1e-30 * c + q^c * 1e-3");
  rich.inputs = {"hum"};
  effects.emplace_back(rich, context);

  std::ostringstream src;
  src << "#include <cmath>\n#include <cstdio>\n\n";
  for (const auto& e : effects) src << e.cpp_function(e.cpp_function_name()) << "\n";
  const std::string functions = src.str();
  std::ostringstream main_src;
  main_src << functions << "template <class S> void print(const char* name, const double* p, int np, const double* v, int nv, int n) {\n"
           << "  S ps[16], vs[64], out[8];\n"
           << "  for (int i = 0; i < np; ++i) ps[i] = S(p[i]);\n"
           << "  for (int i = 0; i < nv; ++i) vs[i] = S(v[i]);\n";
  for (const auto& e : effects)
    main_src << "  if (std::string_view(name) == \"" << e.name() << "\") " << e.cpp_function_name() << "<S>(ps, vs, out);\n";
  main_src << "  for (int i = 0; i < n; ++i) std::printf(\"%.17g\\n\", static_cast<double>(out[i]));\n}\n";
  main_src << "int main() {\n";

  std::mt19937 rng(5);
  std::vector<std::vector<double>> expected;
  std::vector<std::string> names;
  for (const auto& e : effects) {
    for (int n = 0; n < 3; ++n) {
      const std::vector<double> v = random_node(e.layout(), rng);
      std::vector<double> p(e.parameter_names().size());
      for (std::size_t k = 0; k < p.size(); ++k) p[k] = 0.3 + 0.1 * static_cast<double>(k);
      if (e.name() == "ramp") p[2] = 250;
      std::vector<double> out(static_cast<std::size_t>(e.output_count()));
      ki::FormulaWorkspace ws;
      e.evaluate(v.data(), p.data(), out.data(), nullptr, "n", ws);
      expected.push_back(out);
      names.push_back(e.name());
      const auto list = [](const std::vector<double>& x) {
        std::ostringstream s;
        s.precision(17);
        for (double d : x) s << d << ", ";
        return s.str();
      };
      main_src << "  { const double p[] = {" << list(p) << "}; const double v[] = {" << list(v) << "};\n"
               << "    print<double>(\"" << e.name() << "\", p, " << p.size() << ", v, " << v.size() << ", "
               << out.size() << ");\n"
               << "    print<float>(\"" << e.name() << "\", p, " << p.size() << ", v, " << v.size() << ", " << out.size()
               << "); }\n";
    }
  }
  main_src << "}\n";

  const std::string dir = std::string(KINCAL_BINARY_DIR) + "/host_tests/formula_codegen";
  ASSERT_EQ(std::system(("mkdir -p '" + dir + "'").c_str()), 0);
  {
    std::ofstream f(dir + "/main.cpp");
    f << "#include <string_view>\n" << main_src.str();
  }
  const std::string compile = std::string("'") + KINCAL_HOST_CXX + "' -std=c++17 -O2 -Wall -Wextra -Werror -o '" + dir +
                              "/generated' '" + dir + "/main.cpp' 2> '" + dir + "/compile.log'";
  ASSERT_EQ(std::system(compile.c_str()), 0) << "see " << dir << "/compile.log";
  ASSERT_EQ(std::system(("'" + dir + "/generated' > '" + dir + "/out.txt'").c_str()), 0);
  std::ifstream in(dir + "/out.txt");
  for (std::size_t i = 0; i < expected.size(); ++i) {
    for (int scalar = 0; scalar < 2; ++scalar) {
      for (std::size_t o = 0; o < expected[i].size(); ++o) {
        double got = 0;
        ASSERT_TRUE(in >> got) << "output ends early";
        const double want = expected[i][o];
        if (scalar == 0)
          EXPECT_NEAR(got, want, 1e-13 * std::max(1.0, std::abs(want))) << names[i] << " output " << o << " (double)";
        else
          EXPECT_NEAR(got, want, 2e-4 * std::max(1.0, std::abs(want))) << names[i] << " output " << o << " (float)";
      }
    }
  }

  // The firmware's compiler: the functions alone, both scalars instantiated.
  const std::string arm = KINCAL_ARM_CXX;
  if (arm.empty()) GTEST_SKIP() << "arm-none-eabi-g++ not installed: host compilation checked only";
  {
    std::ofstream f(dir + "/firmware.cpp");
    f << functions;
    for (const auto& e : effects)
      for (const char* s : {"float", "double"})
        f << "template void " << e.cpp_function_name() << "<" << s << ">(const " << s << "*, const " << s << "*, " << s
          << "*);\n";
  }
  const std::string cross = "'" + arm + "' -std=c++17 -Os -mcpu=cortex-m7 -mfpu=fpv5-d16 -mfloat-abi=hard -mthumb"
                            " -fno-exceptions -fno-rtti -Wall -Wextra -Werror -Wdouble-promotion -c -o '" + dir +
                            "/firmware.o' '" + dir + "/firmware.cpp' 2> '" + dir + "/firmware.log'";
  EXPECT_EQ(std::system(cross.c_str()), 0) << "see " << dir << "/firmware.log";
}

// Not a timed test (GUIDE "Bars": benchmarks, not timings, carry the bar):
// prints the cost of one call next to a hand-written lambda for the report.
TEST(FormulaEffect, EvaluationCostPerCall) {
  const std::vector<ki::FormulaEffect> effects = ki::read_formula_effects(kGuideEffects, "robot.json", kContext);
  const ki::FormulaEffect& ramp = effects[1];
  std::mt19937 rng(3);
  std::vector<std::vector<double>> nodes;
  for (int n = 0; n < 256; ++n) nodes.push_back(random_node(ramp.layout(), rng));
  const double p[3] = {3e-5, -4e-5, 250};
  const auto hand = [](double q, double g, double q0) {
    const double over = std::max(0.0, q - q0);
    return g * over * over;
  };
  constexpr int kCalls = 2000000;
  volatile double sink = 0;
  using clock = std::chrono::steady_clock;
  const auto time_of = [&](auto&& f) {
    const auto t0 = clock::now();
    double s = 0;
    for (int i = 0; i < kCalls; ++i) s += f(nodes[static_cast<std::size_t>(i) & 255], i & 1);
    sink = sink + s;
    return std::chrono::duration<double, std::nano>(clock::now() - t0).count() / kCalls;
  };
  ki::FormulaWorkspace ws;
  const double t_hand = time_of([&](const std::vector<double>& v, int k) { return hand(v[k ? 5 : 2], p[k], p[2]); });
  const double t_value = time_of([&](const std::vector<double>& v, int k) { return ramp.value(k, v.data(), p, ws); });
  double g[3];
  const double t_grad = time_of([&](const std::vector<double>& v, int k) {
    ramp.gradient(k, v.data(), p, g, ws);
    return g[0];
  });
  double values[2], jac[6];
  const double t_node = time_of([&](const std::vector<double>& v, int) {
    ramp.evaluate(v.data(), p, values, jac, "n", ws);
    return values[0];
  });
  std::printf("ramp: hand-written %.1f ns, value() %.1f ns, gradient() %.1f ns, evaluate() both joints + Jacobian %.1f ns\n",
              t_hand, t_value, t_grad, t_node);
  EXPECT_GT(t_value, 0.0);
}
