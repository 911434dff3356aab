// One identification of a robot from its measurements: what `kincal
// identify` runs, orchestrated here once so that the command line only reads
// the files, prints and writes (issue #33: the identification was
// orchestrated twice, per family in the CLI and in the library).
//
// Tracker targets (or full poses of a family whose own pipeline does not read
// them) go to the target fit, every family (target_calibration.hpp); the
// family's own measurement to its own pipeline where it has one (the 6-UPS's
// seed 001 iterated least squares, the hybrid's seed 000 gauge stages). Each
// writes its narrative — the stages, the outlier screen, what is not
// identifiable — to the stream it is given, as the command line prints it.
// `kincal identify --effects` is effect_calibration.hpp's.
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "kincal/identify/csv.hpp"
#include "kincal/identify/estimators.hpp"
#include "kincal/identify/model.hpp"
#include "kincal/identify/outliers.hpp"
#include "kincal/identify/pose_errors.hpp"
#include "kincal/identify/robot.hpp"

namespace kincal::identify {

struct IdentifyOptions {
  std::string data_file;          // for messages (FILE:LINE of flagged nodes) and MODEL.json
  std::string estimator;          // "" the family's default (6-UPS ols; hybrid: the Gauss–Newton base)
  std::string ridge_k;            // --estimator ridge: "" or "gcv" (default), "hkb", or a number ≥ 0
  Eigen::Index pcr_components = 0;       // --estimator pcr: 0 = by GCV
  std::vector<long long> coarse_layers;  // hybrid: the coarse stage's layers (default: the cal rows)
  bool keep_outliers = false;
  bool instrument_frame = false;  // the targets were measured in the instrument's frame
  bool summary = false;           // fill Identification::summary (SUMMARY.json's own fields)
};

struct Identification {
  CalibrationModel model;
  OutlierScreen screen;
  std::vector<NodeTest> node_tests;
  // The residuals before calibration (how the nominal model is compared:
  // `nominal`) and after (test rows were never fitted).
  PoseErrorReport before, after;
  std::string nominal;
  // SUMMARY.json's fields of this identification (empty unless asked for):
  // the caller adds the robot, the data, the screen and the residuals.
  nlohmann::json summary;
  // One line each, in order, for the user's terminal (the table `compensate`
  // would refuse, rows whose residual could not be evaluated).
  std::vector<std::string> warnings;
};

// The options the command line cannot check alone, for `robot`'s family,
// before its data are read (an option its pipeline refuses). Also run by
// identify().
void check_identify_options(const Robot& robot, const IdentifyOptions& options);

Identification identify(const Robot& robot, const PoseTable& data, const IdentifyOptions& options,
                        std::ostream& narrative);

// --estimator with --ridge-k / --pcr-components as the estimators' options
// (InputError where one does not apply to the estimator).
EstimatorOptions estimator_options(const IdentifyOptions& options, const std::string& estimator);
// "ridge, k = 4.3e-4 (GCV)", "pcr, 32 of 42 components (GCV)", "liu, d = 0.68 (Eq. (14))", "ols".
std::string describe_estimate(const Estimate& e, const EstimatorOptions& o);

}  // namespace kincal::identify
