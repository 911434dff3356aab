// The diagnosis report (identify/src/diagnose/report.cpp): a self-contained HTML file.
// Checked on synthetic Diagnosis values, so the report is tested apart from
// the numbers diagnose() computes: structure (nesting of every tag), no
// network reference, escaping of data-borne text, and no crash or "nan" on
// empty or broken inputs.
#include <gtest/gtest.h>

#include <clocale>
#include <cmath>
#include <set>
#include <string>
#include <vector>

#include "kincal/identify/diagnosis.hpp"

namespace {

using kincal::identify::Diagnosis;
using kincal::identify::diagnosis_report_html;
using kincal::identify::DiagnosisStep;
using kincal::identify::EffectTest;
using kincal::identify::Hotspot;
using kincal::identify::NodeResidual;
using kincal::identify::ResidualGroup;

std::size_t count(const std::string& s, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t p = s.find(what); p != std::string::npos; p = s.find(what, p + what.size())) ++n;
  return n;
}

// Every element opened is closed in order (void elements and "/>" aside):
// stricter than a browser needs, and it catches a text that was not escaped
// (a stray '<' opens a tag that never closes).
::testing::AssertionResult well_nested(const std::string& html) {
  static const std::set<std::string> void_elements{"meta", "br", "hr", "img", "input", "link", "wbr"};
  std::vector<std::string> stack;
  std::size_t p = 0;
  while ((p = html.find('<', p)) != std::string::npos) {
    if (html.compare(p, 2, "<!") == 0) {
      p = html.find('>', p);
      if (p == std::string::npos) return ::testing::AssertionFailure() << "unterminated <!";
      continue;
    }
    const std::size_t end = html.find('>', p);
    if (end == std::string::npos) return ::testing::AssertionFailure() << "unterminated tag at " << p;
    const bool closing = html[p + 1] == '/';
    std::size_t q = p + (closing ? 2 : 1);
    std::string name;
    while (q < end && (std::isalnum(static_cast<unsigned char>(html[q])) || html[q] == '-')) name += html[q++];
    if (name.empty()) return ::testing::AssertionFailure() << "bad tag at " << p << ": " << html.substr(p, 40);
    if (closing) {
      if (stack.empty() || stack.back() != name)
        return ::testing::AssertionFailure() << "</" << name << "> at " << p << " closes <"
                                             << (stack.empty() ? "nothing" : stack.back()) << ">";
      stack.pop_back();
    } else if (html[end - 1] != '/' && !void_elements.count(name)) {
      stack.push_back(name);
      if (name == "style") {  // CSS text: skip to its end tag
        p = html.find("</style>", end);
        if (p == std::string::npos) return ::testing::AssertionFailure() << "unterminated <style>";
        continue;
      }
    }
    p = end + 1;
  }
  if (!stack.empty()) return ::testing::AssertionFailure() << "<" << stack.back() << "> never closed";
  return ::testing::AssertionSuccess();
}

// Absolute URLs other than the SVG namespace name (which is an identifier,
// never fetched) would make the report depend on the network.
std::size_t network_references(const std::string& html) {
  std::string s = html;
  const std::string ns = "http://www.w3.org/2000/svg";
  for (std::size_t p = s.find(ns); p != std::string::npos; p = s.find(ns, p)) s.erase(p, ns.size());
  return count(s, "http://") + count(s, "https://") + count(s, "src=") + count(s, "@import") + count(s, "url(http");
}

Diagnosis synthetic(int layers, int per_side, bool with_test, bool with_covariates) {
  Diagnosis d;
  d.robot = "hybrid-seed000";
  d.data_file = "meas/hidden_scale.csv";
  d.family = "hybrid-3ups-up-3r";
  d.revolute = {false, false, false, true, true, true};  // the hybrid's wrist (joints 4-6)
  d.noise_um = 5.0;
  d.noise_source = "given";
  d.verdict = "unexplained";
  d.seconds = 0.123;
  d.notes = {"no temp column: thermal not testable", "row 7 <bad> & skipped"};
  int id = 0;
  for (int l = 0; l < layers; ++l)
    for (int i = 0; i < per_side; ++i)
      for (int j = 0; j < per_side; ++j) {
        NodeResidual n;
        n.id = "N" + std::to_string(id++);
        n.layer = l;
        n.test = with_test && l == layers / 2;
        const double x = -250 + 500.0 * i / std::max(1, per_side - 1), y = -250 + 500.0 * j / std::max(1, per_side - 1);
        n.commanded << x, y, -60.0 + 60.0 * l, 0, 0, 0;
        n.q << 700 + x / 5, 720 + y / 5, 740 + l * 30, 0.1 * i, 0.5 + 0.02 * j, -0.1;
        n.before << 0.2 * x, -0.15 * y, 30 + 0.05 * x;
        n.after << 3 * std::sin(0.03 * x), 2 * std::cos(0.02 * y), 1.5;
        n.joint_before << 0.2 * x, 0.1 * y, 5, 0, 40 * std::sin(0.01 * x), 3;
        n.joint_after << std::sin(0.1 * x), 0.5, -0.2, 0.1, 2, 0;
        if (with_covariates) {
          n.temperature = 20 + 0.01 * id;
          n.time = 10.0 * id;
        }
        d.nodes.push_back(n);
      }
  std::size_t tests = 0;
  for (const auto& n : d.nodes) tests += n.test ? 1 : 0;
  d.rms = {80.0, 75.0, d.nodes.size() - tests, tests};
  d.final_rms = {6.0, 7.5, d.nodes.size() - tests, tests};
  d.by_layer = {{"layer 0", 25, 70, 14}, {"layer 1", 25, 80, 16}, {"layer 2", 25, 90, 18}};
  d.by_joint = {{"joint 1", 75, 40, 8}, {"joint 3 for q3 in [412, 431] mm", 12, 300, 60}};
  d.by_region = {{"x<0,y<0", 20, 6, 1.2}, {"x>0 & y<0 <&>", 20, 9, 1.8}};
  d.by_covariate = {{"temp", 75, 5.5, 1.1}};
  auto effect = [](std::string name, double score, double p, bool accepted, int step) {
    EffectTest e;
    e.effect = std::move(name);
    e.parameters = 6;
    e.score = score;
    e.p_value = p;
    e.p_adjusted = std::min(1.0, 5 * p);
    e.confounded = 0.12;
    e.rms_after = {6.0, 7.5, 50, 25};
    e.test_gain = 0.9;
    e.accepted = accepted;
    e.step = step;
    return e;
  };
  d.ranking = {effect("scale", 4900, 1e-30, true, 1), effect("cyclic", 3.1, 0.002, false, 2),
               effect("backlash", 1.2, 0.3, false, 2), effect("compliance", 0.4, 0.9, false, 2)};
  EffectTest thermal;
  thermal.effect = "thermal";
  thermal.testable = false;
  thermal.why_not = "no temp column";
  d.ranking.push_back(thermal);
  d.accepted = {"scale"};
  d.steps = {DiagnosisStep{{"base"}, d.rms}, DiagnosisStep{{"base", "scale"}, d.final_rms}};
  d.hotspots = {Hotspot{"joint", "joint 3 for q3 in [412.0, 431.0] mm", 0.72, "residual follows q3 locally"},
                Hotspot{"region", "x>0,y<0", 0.18, ""}};
  return d;
}

TEST(IdentifyReport, WellFormedSelfContained) {
  const Diagnosis d = synthetic(3, 5, true, true);
  const std::string html = diagnosis_report_html(d);
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_NE(html.find("</html>"), std::string::npos);
  EXPECT_TRUE(well_nested(html));
  EXPECT_EQ(count(html, "<svg"), count(html, "</svg>"));
  EXPECT_GT(count(html, "<svg"), 10u);
  EXPECT_EQ(network_references(html), 0u);
  EXPECT_EQ(count(html, "<script"), 0u);
  EXPECT_NE(html.find("unexplained"), std::string::npos);
  for (const auto& e : d.ranking) EXPECT_NE(html.find(e.effect), std::string::npos) << e.effect;
  EXPECT_NE(html.find("no temp column"), std::string::npos);  // why_not shown
  EXPECT_NE(html.find(d.hotspots[0].where), std::string::npos);
  EXPECT_NE(html.find("x&gt;0,y&lt;0"), std::string::npos);  // hotspot 2, escaped
}

// The joints' units come from the robot (Diagnosis::revolute), not from the
// family's name: a family named like none of ours with revolute motors shows
// them in degrees, and the hybrid's name with all joints prismatic in mm.
TEST(IdentifyReport, JointUnitsFollowTheRobotNotTheFamilyName) {
  Diagnosis d = synthetic(2, 3, false, false);
  d.family = "rus6";
  d.revolute = {true, true, true, true, true, true};
  std::string html = diagnosis_report_html(d);
  EXPECT_NE(html.find("q1 (deg)"), std::string::npos);
  EXPECT_NE(html.find("q6 (deg)"), std::string::npos);
  EXPECT_EQ(html.find("q1 (mm)"), std::string::npos);
  d.family = "hybrid-3ups-up-3r";
  d.revolute = {};
  html = diagnosis_report_html(d);
  EXPECT_NE(html.find("q6 (mm)"), std::string::npos);
  EXPECT_EQ(html.find("(deg)"), std::string::npos);
}

TEST(IdentifyReport, EscapesDataBorneText) {
  Diagnosis d = synthetic(2, 3, true, false);
  d.robot = "my \"robot\" <&>";
  d.ranking[1].effect = "user<&>effect";
  d.notes.push_back("<script>alert(1)</script>");
  d.nodes[0].id = "id<&>\"x\"";
  const std::string html = diagnosis_report_html(d);
  EXPECT_TRUE(well_nested(html));
  EXPECT_EQ(html.find("<&>"), std::string::npos);
  EXPECT_NE(html.find("user&lt;&amp;&gt;effect"), std::string::npos);
  EXPECT_NE(html.find("x&gt;0 &amp; y&lt;0 &lt;&amp;&gt;"), std::string::npos);  // region label
  EXPECT_NE(html.find("my &quot;robot&quot; &lt;&amp;&gt;"), std::string::npos);
  EXPECT_NE(html.find("row 7 &lt;bad&gt; &amp; skipped"), std::string::npos);   // notes listed
  EXPECT_EQ(count(html, "<script"), 0u);
}

TEST(IdentifyReport, EmptyDiagnosisDoesNotCrash) {
  const Diagnosis d;
  const std::string html = diagnosis_report_html(d);
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_TRUE(well_nested(html));
  EXPECT_EQ(count(html, "<svg"), count(html, "</svg>"));
  EXPECT_EQ(network_references(html), 0u);
  EXPECT_NE(html.find("No per-node residuals"), std::string::npos);
  EXPECT_NE(html.find("No candidate effect"), std::string::npos);
}

TEST(IdentifyReport, MissingLayersTestRowsAndCovariates) {
  Diagnosis d = synthetic(1, 6, false, false);
  for (auto& n : d.nodes) n.layer.reset();
  d.by_layer.clear();
  d.hotspots.clear();
  d.verdict = "explained";
  d.rms.test_nodes = d.final_rms.test_nodes = 0;
  for (auto& s : d.steps) s.rms.test_nodes = 0;
  const std::string html = diagnosis_report_html(d);
  EXPECT_TRUE(well_nested(html));
  EXPECT_NE(html.find("all nodes"), std::string::npos);
  EXPECT_NE(html.find("no temperature or time column"), std::string::npos);
  EXPECT_NE(html.find("no test rows"), std::string::npos);
  EXPECT_EQ(html.find("id=\"hotspots\""), std::string::npos);  // nothing to list when explained
  EXPECT_EQ(html.find("test (held out)</text>"), std::string::npos);  // no test bars in the steps chart
}

TEST(IdentifyReport, NonFiniteValuesAreGuarded) {
  Diagnosis d = synthetic(2, 4, true, true);
  const double nan = std::nan(""), inf = INFINITY;
  d.noise_um = nan;
  d.rms.cal = inf;
  d.final_rms.test = nan;
  d.nodes[0].before(0) = nan;
  d.nodes[1].after(2) = inf;
  d.nodes[2].commanded(0) = nan;
  d.nodes[3].q(2) = inf;
  d.nodes[4].joint_before(4) = nan;
  d.nodes[5].temperature = nan;
  d.by_joint[0].rms_um = nan;
  d.ranking[0].p_value = nan;
  d.steps[1].rms.test = inf;
  d.hotspots[0].share = nan;
  const std::string html = diagnosis_report_html(d);
  EXPECT_TRUE(well_nested(html));
  // No non-finite number reaches an SVG attribute or a table cell as text.
  for (const char* bad : {"nan", "inf\"", "=\"inf", "=\"-inf", "e+30"}) EXPECT_EQ(html.find(bad), std::string::npos) << bad;
  EXPECT_NE(html.find("n/a"), std::string::npos);
}

TEST(IdentifyReport, SizeStaysReasonable) {
  // ~200 nodes (4 layers of 7 x 7) with every picture: a few hundred KB at most.
  const Diagnosis d = synthetic(4, 7, true, true);
  ASSERT_EQ(d.nodes.size(), 196u);
  const std::string html = diagnosis_report_html(d);
  EXPECT_TRUE(well_nested(html));
  EXPECT_LT(html.size(), 400u * 1024u);
  // Two maps per layer.
  EXPECT_EQ(count(html, "· before</text>"), 4u + 6u + 2u);  // maps + joints + covariates
}

TEST(IdentifyReport, NumbersAreLocaleIndependent) {
  // std::to_chars: a decimal point whatever the C locale says (when a
  // comma-decimal locale is installed; otherwise this is the plain case).
  const std::string old = std::setlocale(LC_ALL, nullptr);
  std::setlocale(LC_ALL, "de_DE.UTF-8");
  const Diagnosis d = synthetic(1, 3, false, false);
  const std::string html = diagnosis_report_html(d);
  std::setlocale(LC_ALL, old.c_str());
  EXPECT_NE(html.find("5.00 µm per position coordinate"), std::string::npos);
}

}  // namespace
