// Robot descriptions: a built-in reference machine by name, or a JSON robot
// description file (schema: docs/formats.md). A Robot is a value holding one
// family's part (one of the core geometries with the host-side data only
// that family has, e.g. the hybrid's gauge size) plus the host-side data
// every family has (name, screw lead, bounds, targets, formula effects).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include <Eigen/Core>

#include "kincal/core/pose.hpp"
#include "kincal/core/status.hpp"
// A family's part of a Robot — core's geometry plus the host-side data only
// that family has, in the family's own header; Robot::family_data holds
// exactly one of them (the registry line of this layer, below).
#include "kincal/identify/hybrid_description.hpp"
#include "kincal/identify/rus6_description.hpp"
#include "kincal/identify/stewart_description.hpp"

namespace kincal::identify {

class FormulaCandidate;  // effects/formula_candidate.hpp

// A number a family offers its formula effects per joint (GUIDE "Effects
// written as formulas": "what the family offers"): `name` is this joint's in
// a joint-kind formula, name1..name6 any joint's.
struct FamilyFormulaVariable {
  std::string name;
  std::string description;  // what it is, in its unit (`kincal effects`)
};

struct Robot {
  std::string name;
  // The family's part: one alternative per family (the registry line of this
  // layer). Everything only one family has lives in its alternative (the
  // *Description structs of the family headers: the geometry, the hybrid's gauge radius and
  // source errors, the 6-UPS's leg offsets), never among the common members
  // below; stewart()/hybrid()/rus6() reach the geometry,
  // *_description() the whole part.
  std::variant<StewartDescription, HybridDescription, Rus6Description> family_data;
  // The common part: what every family has.
  // The `cyclic` effect's period in joint units (GUIDE): a screw's lead, mm
  // per revolution; the 6-RUS's crank angle per motor revolution, rad.
  double screw_lead = 5.0;
  // The largest correction the controller may apply per joint (mm for
  // prismatic, rad for revolute joints): the optional description key
  // `max_correction`. Unset = core's default_bounds (5 mm, 0.02 rad). A
  // machine before its first calibration may need more (issue #11 item 3).
  std::optional<Vec6<double>> max_correction;
  // The optional description keys capping the identified values a table may
  // carry (core/machine_limits.hpp, the table check `compensate` and `table`
  // apply): max_geometry_error (mm: 6-UPS joint centres, the hybrid's length
  // source errors), max_angle_error (rad: the hybrid's angular source
  // errors), max_scale (dimensionless), max_thermal (1/°C). Unset = core's
  // DefaultLimitCaps (10 mm, 0.1 rad, 0.01, 1e-3).
  std::optional<double> max_geometry_error;
  std::optional<double> max_angle_error;
  std::optional<double> max_scale;
  std::optional<double> max_thermal;
  // The optional description key `targets`: 1–3 nominal positions [x, y, z]
  // of tracker targets (SMRs) on the platform (6-UPS, platform frame) or the
  // tool (hybrid, tool frame), mm. Empty = none given; the hybrid is then
  // measured by seed 000's three-target gauge (HybridDescription::gauge_radius).
  std::vector<Vec3<double>> targets;
  // The optional key `effects` (GUIDE "Effects written as formulas"): the
  // description's formula effects, compiled, in the order written; their
  // numbers follow one another in core's user slot. `effects_json` is the
  // key as written (robot_to_json writes it back), `formula_inputs` every
  // effect's named measurement inputs in order of first appearance (the
  // columns the data and the NC stream carry for them).
  std::vector<std::shared_ptr<const FormulaCandidate>> formula_effects;
  std::string effects_json;
  std::vector<std::string> formula_inputs;
  // The optional key `payload` ({"weight": W, "com": [x, y, z]}): the load a
  // formula's `load` is the static joint load of — a weight W along the
  // weight direction at the centre of mass `com` (mm, in the frame of the
  // body the pose is of: the platform, the hybrid's tool). Default a unit
  // weight at the pose's origin (the `compliance` effect's load).
  double payload_weight = 1.0;
  Vec3<double> payload_com = Vec3<double>::Zero();
  bool has_payload = false;

  bool is_stewart() const { return std::holds_alternative<StewartDescription>(family_data); }
  bool is_hybrid() const { return std::holds_alternative<HybridDescription>(family_data); }
  bool is_rus6() const { return std::holds_alternative<Rus6Description>(family_data); }
  // The family's part; std::bad_variant_access for another family.
  const StewartDescription& stewart_description() const { return std::get<StewartDescription>(family_data); }
  StewartDescription& stewart_description() { return std::get<StewartDescription>(family_data); }
  const HybridDescription& hybrid_description() const { return std::get<HybridDescription>(family_data); }
  HybridDescription& hybrid_description() { return std::get<HybridDescription>(family_data); }
  const Rus6Description& rus6_description() const { return std::get<Rus6Description>(family_data); }
  Rus6Description& rus6_description() { return std::get<Rus6Description>(family_data); }
  // The family's geometry.
  const StewartGeometry<double>& stewart() const { return stewart_description().geometry; }
  StewartGeometry<double>& stewart() { return stewart_description().geometry; }
  const HybridGeometry<double>& hybrid() const { return hybrid_description().geometry; }
  HybridGeometry<double>& hybrid() { return hybrid_description().geometry; }
  const Rus6Geometry<double>& rus6() const { return rus6_description().geometry; }
  Rus6Geometry<double>& rus6() { return rus6_description().geometry; }

  // What the robot's family answers (identify/src/families/family.hpp; the
  // switches on is_stewart()/is_hybrid() belong inside a family's folder).
  // The description's `family` value.
  const char* family() const;
  static constexpr int joint_count() { return 6; }
  // Joint j (0-based) is revolute (rad) rather than prismatic (mm).
  bool revolute(int joint) const;
  // The body tracker targets sit on: "platform" (6-UPS) or "tool" (hybrid).
  const char* target_body() const;
  // How the family's base error model reads in messages.
  const char* error_model() const;
  // The fewest nodes a deleted-node screen of the family's own fit leaves
  // (identify/outliers.hpp).
  Eigen::Index outlier_min_nodes() const;

  // The pose the machine starts from (stewart: `home`; hybrid: the reference
  // pose, the origin of the workpiece frame with the tool aligned to it).
  Pose<double> home_pose() const;
  // max_correction, or core's default_bounds where the description has none.
  Vec6<double> correction_bound() const;
  // The joint commands' limits (stewart: the stroke; hybrid: joint_limits).
  void joint_limits(Vec6<double>& lo, Vec6<double>& hi) const;
  // Nominal IK (commanded joints) for a pose, in the robot's pose frame.
  Status inverse(const Pose<double>& pose, Vec6<double>& q) const;
};

// Built-in names: "stewart-seed001", "hybrid-seed000", "rus6-ref". Anything else is read as
// a robot description file. Throws InputError (with file:line:column for
// files) on any problem.
Robot load_robot(const std::string& name_or_path);
bool is_builtin_robot(const std::string& name);
Robot builtin_robot(const std::string& name);  // throws InputError if unknown

// The numbers the robot's family offers its formula effects per joint (none
// for the 6-UPS and the hybrid; the 6-RUS's `rod` and `lever`), and their
// values at the nominal configuration of a commanded pose: values[k·6 + j]
// for variable k, joint j + 1 (core's rus6_formula_joint_values: the
// controller reads the same). False, `values` untouched, where the family's
// IK fails at the pose.
std::vector<FamilyFormulaVariable> family_formula_variables(const Robot& robot);
bool family_formula_values(const Robot& robot, const Pose<double>& pose, double* values);

// Parses a robot description from text; `file` names it in errors.
Robot parse_robot(const std::string& text, const std::string& file);

// The robot description (JSON text, 2-space indent, trailing newline) that
// parse_robot reads back to the same geometry.
std::string robot_to_json(const Robot& robot);

// A few human-readable lines: family, name, dimensions, home pose and its joints.
std::string robot_summary(const Robot& robot);

}  // namespace kincal::identify
