// Measurement planning (`kincal plan`, docs/plan.md): which poses to measure,
// chosen before the tracker is set up, so that the base model and the
// requested effects are identifiable, separable from one another, and
// identified with the smallest error the noise allows.
//
// The criterion is Bayesian D-optimality of the whitened identification
// Jacobian (Chaloner & Verdinelli 1995): maximise log det(AᵀA + Λ), A the
// design rows of the chosen poses divided by the measurement noise, Λ the
// precision of a weak prior that says every parameter moves the measured
// points by about `prior_mm` RMS over the workspace. Where the design has
// full rank this is plain D-optimality (det AᵀA, the volume of the confidence
// ellipsoid; Sun & Hollerbach's O1 index is its geometric mean); the prior
// only makes a rank-deficient start (the first poses of a greedy selection,
// the hybrid's 150 source errors) well defined, and lets one number rank a
// design that leaves some combination undetermined. Why D and not an
// observability index such as O2 (condition number) or O3 (smallest singular
// value): det is invariant to the parameters' units and scaling, it is
// additive over poses (each pose's gain has the closed form
// log det(I + A_c K⁻¹ A_cᵀ), so greedy and exchange steps are exact rank-r
// updates), and it weighs every direction, not only the weakest.
//
// Selection: a greedy start (the pose with the largest gain, N times) and
// exchange passes (Fedorov's exchange: remove a chosen pose, add the best
// unchosen one, keep the swap if it gains) until a pass changes nothing.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "kincal/identify/csv.hpp"
#include "kincal/identify/diagnosis.hpp"
#include "kincal/identify/robot.hpp"

namespace kincal::identify {

// What the instrument measures. Default: the family's usual instrument
// (6-UPS: the full platform pose; hybrid: seed 000's three-target gauge, or
// the robot's `targets`).
enum class PlanMeasure { Default, Pose, Targets };

struct PlanOptions {
  std::size_t count = 0;              // calibration poses to choose
  std::vector<std::string> effects;   // also make these identifiable and separable from the base
  PlanMeasure measure = PlanMeasure::Default;
  // The user's candidate poses (x..rz; other columns ignored): only those
  // reachable inside the limits with the margin are used. Empty table (no
  // rows): the workspace is sampled.
  PoseTable candidates;
  std::size_t sample_count = 5000;    // sampled candidates when none are given
  std::size_t test_count = 0;         // held-out poses spread over the workspace, chosen after the plan
  std::uint64_t seed = 1;
  // A usable pose keeps every joint (and the hybrid's UP extension) this
  // fraction of its range away from both limits, and its Jacobian's
  // condition number (angles × the robot's characteristic length) within
  // `singularity_factor` × the home pose's.
  double margin = 0.05;
  double singularity_factor = 10;
  double noise_mm = 0.005;  // σ of each measured coordinate, mm
  double noise_rad = 0;     // σ of each measured angle (pose measurement); 0: noise_mm / 200 mm
  double prior_mm = 1.0;    // the prior: each parameter moves the measured points by this, RMS over the workspace
  int max_exchange_passes = 20;
  bool compare = true;  // also assess the grid and a random design of the same size
  std::function<void(const std::string&)> progress;
};

struct PlanParameter {
  std::string name;           // base parameter or "effect.parameter"
  std::string unit;
  double standard_error = 0;  // predicted (posterior) standard deviation, the parameter's unit
  double prior = 0;           // the prior's standard deviation, same unit
  bool determined = true;     // standard_error < prior / 2: the data, not the prior, decide it
};

struct PlanConfounding {
  std::string effect;
  double share = 0;  // mean share of the effect's whitened column energy inside the base model's span (0–1)
};

// How good a design is, all predicted from the nominal model and the noise.
struct DesignAssessment {
  std::string name;  // "planned", "grid", "random"
  std::size_t poses = 0;
  Eigen::Index parameters = 0, rank = 0;  // of the whitened design, no prior
  double condition_number = 0;            // column-scaled whitened design (inf when rank-deficient)
  double log_det = 0;                     // the criterion, log det(AᵀA + Λ) − log det Λ
  std::vector<PlanParameter> parameter_errors;
  std::size_t undetermined = 0;           // parameters with determined == false
  std::vector<PlanConfounding> confounding;  // per requested effect
  // RMS position error (µm) of the identified model at the evaluation poses
  // from the estimate's covariance: √(mean_e trace(P_e·Cov·P_eᵀ)), P_e the
  // tool point's displacement per parameter — the compensated error the
  // noise leaves where the model is right.
  double predicted_test_um = 0;
};

struct MeasurementPlan {
  PoseTable poses;  // the plan: `count` cal rows and `test_count` test rows, in motion order
  PoseTable grid;   // the comparison grid of the same size (docs/plan.md says how it is laid out)
  DesignAssessment planned, grid_assessment, random_assessment;
  std::string measure;            // what the instrument measures, one phrase
  std::size_t rows_per_pose = 0;  // measured coordinates per pose
  std::vector<std::string> parameter_names;
  std::vector<std::string> effects;  // the effects in the criterion (thermal is never: notes)
  std::vector<std::string> notes;    // what the user should know (one line each)
  std::size_t candidates = 0, usable_candidates = 0;
  std::size_t evaluation_poses = 0;  // where predicted_test_um is evaluated
  int exchange_passes = 0, exchanges = 0;
  double path_length = 0;  // sum over moves of the largest joint move as a fraction of its range
  double seconds = 0;
};

// Throws InputError for: a count whose equations (count × rows_per_pose)
// are fewer than the parameters, an unknown effect, candidates of which
// fewer than `count` are usable (naming the first one rejected and why), a
// target measurement on a 6-UPS whose description has no `targets`, a home
// pose that is not usable.
MeasurementPlan plan_measurements(const Robot& robot, const PlanOptions& options);

// For a diagnosis: the effects more than 90 % confounded with the base on
// the measured poses (thermal excepted: no pose separates it) get what one
// quick plan of as many poses (at most 150) for all of them would leave —
// EffectTest::plan_confounded, plan_count, plan_effects; `kincal diagnose`
// prints it and the report shows it. A greedy plan on 300 workspace
// candidates, no exchange: an estimate of what `kincal plan` reaches.
void add_plan_hints(const Robot& robot, Diagnosis& diagnosis);

}  // namespace kincal::identify
