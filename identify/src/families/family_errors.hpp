// A machine family's error parameters as the family-free fits and plans see
// them (private to identify/; docs/architecture.md; FamilyErrorModel::errors gives
// them):
//   (a) the machine's pose for its error parameters and a node's commands,
//   (b) the pose error twist per error parameter at that pose,
//   (c) the convention rows that close what target positions cannot fix, and
//   (d) the columns a pose set can identify at all (kincal plan).
// The laser-tracker target fit (target_calibration.cpp) runs on (a)–(c):
// registration, targets, the descent, rank, covariance, node tests and the
// residual reports are the fit's, the same for every family. kincal plan's
// design rows are (b) at the nominal machine over (d)'s columns.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "kincal/core/hybrid.hpp"
#include "kincal/core/pose.hpp"
#include "kincal/identify/robot.hpp"

namespace kincal::identify::detail {

// Where a node's pose was last found: the start of its next evaluation.
struct NodeGuess {
  Pose<double> pose;              // the commanded pose at first, then the pose last found
  HybridPassive<double> passive;  // hybrid: the UP limb's passive joints
};

// The full parameter vector x of a target fit: the family's errors, then the
// registration twist (instrument frame only), then 3 per target.
struct TargetLayout {
  int family = 0;
  int targets = 0;
  bool registration = false;
  int registration_at() const { return family; }
  int targets_at() const { return family + (registration ? 6 : 0); }
  int size() const { return targets_at() + 3 * targets; }
};

class FamilyErrors {
 public:
  virtual ~FamilyErrors() = default;
  // The family's error parameters (6-UPS: seed 001's 42; hybrid: seed 000's 150).
  virtual int size() const = 0;
  virtual std::vector<std::string> names() const = 0;
  virtual std::vector<std::string> units() const = 0;  // "mm" or "rad" per parameter
  // The first guess of a node commanded to `commanded` (its nominal IK's
  // passive joints for the hybrid).
  virtual NodeGuess start(const Pose<double>& commanded) const = 0;
  // (a) The pose for `errors` at commands q from `guess`; on success `guess`
  // is updated (guess.pose = pose).
  virtual bool pose(const Eigen::VectorXd& errors, const Vec6<double>& q, NodeGuess& guess, Pose<double>& pose) const = 0;
  // (b) The twist (v at the pose's origin, ω; base axes) per error parameter, 6 × size().
  virtual Eigen::MatrixXd twist_columns(const Eigen::VectorXd& errors, const Pose<double>& pose) const = 0;
  // (b) at the nominal machine (no errors), for a plan: false where it
  // cannot be evaluated.
  virtual bool nominal_twist_columns(const Pose<double>& pose, Eigen::MatrixXd& T) const = 0;
  // (c) Rows over x (layout.size() columns) the fit holds at zero, given the
  // design over x (at the start: nominal machine, starting registration)
  // and the RMS residual of a fit by the rows given for an unknown one
  // (+∞: the fit has not run yet). A family whose rows depend on it (the
  // hybrid keeps nearly dependent columns only where the data carry no
  // noise to send the estimate along them) gets asked again after the fit,
  // and the fit reruns if the rows change.
  virtual Eigen::MatrixXd convention_rows(const TargetLayout& layout, const Eigen::MatrixXd& design,
                                          double residual_rms) const = 0;
  // How the convention reads (the identify line and docs).
  virtual std::string convention() const = 0;
  // (d) Whether the parameters outnumber what any pose set determines, so
  // that a plan must choose its columns (the hybrid's 150; the 6-UPS's 42
  // are all identifiable from full poses).
  virtual bool selects_columns() const { return false; }
  // The identifiable columns (positions in H's columns, ascending) from
  // design rows H over all parameters at some poses.
  virtual std::vector<Eigen::Index> identifiable_columns(const Eigen::MatrixXd& H) const {
    std::vector<Eigen::Index> all(std::size_t(H.cols()));
    for (Eigen::Index j = 0; j < H.cols(); ++j) all[std::size_t(j)] = j;
    return all;
  }
};

// The error parameters of `robot`'s family (limits removed: the machine was
// where it was measured).
std::unique_ptr<FamilyErrors> family_errors(const Robot& robot);

}  // namespace kincal::identify::detail
