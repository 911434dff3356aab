// Model-versus-measurement diagnosis (`kincal diagnose`, GUIDE "Command-line
// contract"): fit the base model on the cal rows, compare residuals with the
// noise overall / per layer / per role / per joint / against every covariate,
// rank the candidate effects by an F test of what each adds beyond the fitted
// model (columns orthogonalised against it, Holm's multiple-testing control)
// and by the held-out gain, accept effects stepwise, and give a verdict with
// hotspots. docs/diagnosis.md explains every number.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "kincal/identify/csv.hpp"
#include "kincal/identify/outliers.hpp"
#include "kincal/identify/robot.hpp"

namespace kincal::identify {

struct DiagnoseOptions {
  std::optional<double> noise_um;    // σ of a measured position coordinate (µm), if known
  std::optional<double> noise_urad;  // σ of a measured orientation coordinate (µrad; 6-UPS pose), if known
  double alpha = 0.01;             // family-wise significance level (Holm)
  // An effect must cut the held-out RMS by this much to be accepted — or by
  // half of what separates it from the noise if less, and by anything where
  // the model is consistent with the noise (diagnosis.md, step 4).
  double min_test_gain = 0.05;
  std::vector<std::string> candidates;  // empty: every registered effect
  bool progress = false;                // progress lines on stderr
  // Cal nodes the outlier screen flags (identify/outliers.hpp, on the final
  // model) are left out and the diagnosis repeated without them, unless kept.
  bool keep_outliers = false;
  // After each accepted effect, fit it with the base nonlinearly and test the
  // next candidates at that solution (false: one linear step from the base fit).
  bool relinearise = true;
};

// RMS of the residual per measured coordinate (µm): gauge target coordinates
// for the hybrid; position coordinates (and orientation × 200 mm) for 6-UPS.
struct RoleRms {
  double cal = 0, test = 0;
  std::size_t cal_nodes = 0, test_nodes = 0;
};

struct EffectTest {
  std::string effect;
  bool testable = true;
  std::string why_not;       // when not testable
  int parameters = 0;
  double score = 0;          // F statistic of the added columns (orthogonalised against the model)
  double p_value = 1;        // raw
  double p_adjusted = 1;     // Holm-adjusted
  double confounded = 0;     // fraction (0–1) of the effect's column energy inside the model's span
  // Mallows' Cp of the model with this effect, RSS/σ² + 2·rank (σ: the
  // noise, else the current model's residual scale): the stepwise search
  // takes, of the effects that qualify, the one of lowest Cp.
  double cp = 0;
  RoleRms rms_after;         // model + this effect, refitted on cal
  double test_gain = 0;      // 1 − rms_after.test / rms_before.test (0 if no test rows)
  bool accepted = false;
  int step = 0;              // stepwise step at which it was ranked (1-based)
  // Where confounded > 0.9: the confounding that measuring a plan of as many
  // poses (at most 150) made for the confounded effects would leave
  // (`kincal plan --effects plan_effects --count plan_count`, estimated by a
  // greedy plan on 300 workspace candidates: identify/plan.hpp); < 0 when
  // not computed.
  double plan_confounded = -1;
  std::size_t plan_count = 0;
  std::string plan_effects;  // comma separated
};

struct DiagnosisStep {
  std::vector<std::string> model;  // accepted effects so far ("base" first)
  RoleRms rms;
};

// Residual grouped by something (a layer, a joint, a workspace region, a
// covariate bin): the RMS there against the noise.
struct ResidualGroup {
  std::string label;      // "layer 2", "joint 3", "x>0,y<0", "q3 in [412, 431] mm", "temp"
  std::size_t nodes = 0;
  double rms_um = 0;
  double ratio = 0;       // rms / noise
};

struct Hotspot {
  std::string kind;       // "joint", "region", "covariate", "layer"
  std::string where;      // e.g. "joint 3 for q3 in [412.0, 431.0] mm"
  double share = 0;       // fraction of the excess residual energy there
  std::string detail;
};

// Per-node data for the report's pictures (cal and test rows, final model).
struct NodeResidual {
  std::string id;
  std::optional<long long> layer;
  bool test = false;
  Vec6<double> commanded = Vec6<double>::Zero();
  Vec6<double> q = Vec6<double>::Zero();
  std::optional<double> temperature, time;
  Vec3<double> before = Vec3<double>::Zero();  // tool-point position residual of the base model, µm
  Vec3<double> after = Vec3<double>::Zero();   // with the accepted effects, µm
  Vec6<double> joint_before = Vec6<double>::Zero();  // implied joint-space residual, µm or µrad
  Vec6<double> joint_after = Vec6<double>::Zero();
};

// Two candidate effects the data can hardly tell apart: beyond the base
// model, the columns of one lie almost inside the span of the other's.
struct CollinearPair {
  std::string first, second;  // first: the effect whose columns lie inside the span of the second's
  double share = 0;           // mean share (0–1) of first's columns (orthogonalised against the base) in second's
};

// The estimators behind an estimated noise (docs/diagnosis.md "How kincal
// knows the noise"), in the residual's units (µm or µrad).
struct NoiseEstimates {
  double joint_space = 0;       // local-linear pseudo-residuals, nearest nodes in joint space (the one used)
  double joint_space_wide = 0;  // the same over twice as many neighbours (the trust test)
  double joint_space_pairs = 0; // plain difference with the nearest node in joint space
  double workspace = 0;         // plain differences, nearest commanded pose / motion order (before #31)
  double spacing = 0;           // median distance to the neighbours, in strokes
};

struct Diagnosis {
  std::string robot, data_file, family;
  // Which joints are revolute (rad; the report shows them in degrees and
  // their residuals in µrad) rather than prismatic (mm): the robot's own
  // word (Robot::revolute), never read off the family's name.
  std::array<bool, 6> revolute{};
  double noise_um = 0;
  std::string noise_source;  // "given", "repeated nodes", "estimated from neighbouring nodes in …"
  // An estimated noise the data cannot vouch for (too few nodes, neighbours
  // whose difference does not cancel the residual's structure): the verdict
  // is then `noise-unknown` (or `unexplained` where the residual has
  // structure) and `noise_untrusted` says why and names --noise-um.
  bool noise_trusted = true;
  std::string noise_untrusted;
  NoiseEstimates position_estimates, orientation_estimates;
  // Structure in the final residual over joint-space neighbours, σ-free
  // (noise_estimate.hpp joint_space_structure): ratio < 1 and p < alpha is
  // structure, and the verdict is never consistent or explained then.
  double structure_ratio = 1, structure_p = 1;
  // The covariate the final residual follows most between joint-space
  // neighbours (noise_estimate.hpp): its name ("" without one), Spearman's ρ, p.
  std::string structure_covariate;
  double structure_covariate_rho = 0, structure_covariate_p = 1;
  // The final model's held-out rows against its cal rows, σ-free (Chow's
  // predictive test): the ratio of their mean squares (the held-out ones in
  // the metric of the prediction's covariance) and its F p-value; p < alpha
  // is structure, as above (0 / 1: no held-out rows).
  double held_out_ratio = 0, held_out_p = 1;
  // The held-out rows' mean leverage under the base model (their residual's
  // variance is σ²(1 + h) for a complete model; the verdict allows that).
  double test_leverage = 0;
  std::vector<CollinearPair> collinear;  // candidate pairs nearly collinear with each other (beyond the base)
  double noise_urad = 0;     // 6-UPS: orientation σ (µrad); its rows are scaled to the position σ
  std::string noise_urad_source;
  RoleRms rms;               // base model
  std::vector<ResidualGroup> by_layer, by_joint, by_region, by_covariate;
  std::vector<EffectTest> ranking;  // best first (first step's order), untestable at the end
  std::vector<std::string> accepted;
  std::vector<DiagnosisStep> steps;  // base, then after each accepted effect
  std::string verdict;               // consistent | explained | unexplained | noise-unknown
  RoleRms final_rms;
  std::vector<Hotspot> hotspots;
  std::vector<std::string> notes;    // what could not be done and why (bad input that still allowed a report)
  std::vector<NodeResidual> nodes;
  std::string base_model;            // what the base model is (e.g. "seed 001 42-parameter model")
  // Values of the accepted effects' parameters in the final fit, "scale:s1" → value.
  std::vector<std::pair<std::string, double>> accepted_parameters;
  // Measurement blunders: cal nodes inconsistent with the final model
  // (identify/outliers.hpp), with their statistics; left out unless kept.
  OutlierScreen outliers;
  // The final model's cal design (column-scaled) and residual at the
  // solution, row_node numbering `cal_nodes`: what the screen tests.
  LinearProblem final_problem;
  std::vector<NodeTest> cal_nodes;
  double seconds = 0;
};

Diagnosis diagnose(const Robot& robot, const PoseTable& data, const DiagnoseOptions& options = {});

// DIAG.json (GUIDE contract keys first, then the details).
std::string diagnosis_to_json(const Diagnosis& d);

// One self-contained HTML file with inline SVG (identify/src/diagnose/report.cpp).
std::string diagnosis_report_html(const Diagnosis& d);

}  // namespace kincal::identify
