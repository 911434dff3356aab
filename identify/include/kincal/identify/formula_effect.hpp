// Effects written as formulas (GUIDE "Effects written as formulas", robot
// description key `effects`; issue #32). A user who sees `unexplained` in a
// diagnosis writes the missing physics as a formula instead of C++:
//
//   {"name": "ramp", "kind": "joint", "joints": [3, 6], "per_joint": ["g"],
//    "shared": ["q0"], "start": {"q0": 250}, "formula": "g * max(0, q - q0)^2"}
//
// This module reads such an entry, parses it with GiNaC (Debian
// libginac-dev: parser, exact symbolic derivatives and the tree a C++
// printer needs, in one well-kept library), and compiles the formula and its
// derivative along every parameter once into a flat program over double
// slots, so a node costs a few dozen arithmetic operations, not a walk over
// GiNaC's tree (the bar: diagnose with three formula effects at most
// 1.5x the time of three built-in ones). The same program prints as a C++
// function templated on the scalar for the firmware's generated table.
//
// GiNaC stays behind this header (pimpl): callers see names, numbers and
// std::string only.
//
// Thread safety: a FormulaEffect is immutable after construction; every
// const member may be called from several threads at once provided each
// thread passes its own FormulaWorkspace (the overloads without one use a
// thread_local workspace).
#pragma once

#include <cstddef>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace kincal::identify {

enum class FormulaKind {
  Joint,  // Δq_i per acting joint i, added to the command like scale/backlash
  Pose,   // a twist (dx, dy, dz, drx, dry, drz) of the tool frame in the base frame
};

// What the caller (a family, the robot description) offers a formula.
struct FormulaContext {
  int joint_count = 6;                        // N: q1..qN, dir1..dirN, load1..loadN
  std::vector<std::string> family_variables;  // extra numbers a family offers (`kincal effects --robot R`)
  // Numbers a family offers per joint (the 6-RUS's `rod`, `lever`: kincal
  // effects --robot R lists them): name (this joint's, in a joint-kind
  // formula) and name1..nameN, as q and load.
  std::vector<std::string> family_joint_variables;
  // Effect names a formula effect may not take (the built-in candidates;
  // the registry may pass its own list).
  std::vector<std::string> builtin_effects = {"scale", "backlash", "compliance", "thermal", "cyclic"};
  // The machine's named inputs in layout order (FormulaLayout::input): one
  // list for every effect of a machine, so one variable array serves them
  // all (the controller's). Empty: the entry's own `inputs`.
  // read_formula_effects fills it with every entry's inputs.
  std::vector<std::string> input_layout;
  // The most named inputs a machine may have (core's kFormulaInputs for a
  // robot description); negative: no limit.
  int max_inputs = -1;
};

// Where a key of the description is, for InputError (0 = not known).
struct FormulaWhere {
  std::size_t line = 0, column = 0;
};

// One entry of the `effects` array, as written (GUIDE contract).
struct FormulaEffectSpec {
  std::string name, description;
  FormulaKind kind = FormulaKind::Joint;
  std::vector<int> joints;              // 1-based acting joints; empty = every actuated joint (joint kind)
  std::vector<std::string> per_joint;   // base names: `a` becomes a1, a2, … (one per acting joint)
  std::vector<std::string> shared;      // one parameter each
  std::map<std::string, double> start;  // by base name (every joint) or full name (`g3`); default 0
  std::vector<std::string> inputs;      // extra numeric measurement columns the formula reads
  // joint kind: one formula; pose kind: six, in the order dx dy dz drx dry drz
  // ("0" for a component the entry leaves out).
  std::vector<std::string> formulas;
  // For errors: the description file and where each key sits, keyed by the
  // JSON key ("name", "joints", "formula", "formula/dz", …; "" = the entry).
  std::string file;
  std::map<std::string, FormulaWhere> where;
};

// The numbers a formula may read at one node, in one flat array (the same
// layout the generated C++ reads, so firmware and host agree by
// construction). N = FormulaContext::joint_count.
//   [0, N)        q1..qN     joint commands
//   [N, 2N)       dir1..dirN approach directions, ±1
//   [2N, 3N)      load1..loadN static loads (compliance's statics)
//   3N, 3N+1      temp (°C), time (s)
//   3N+2 .. 3N+7  x, y, z, rx, ry, rz  commanded pose
//   then the effect's inputs (spec order; a block of input_capacity slots
//   when the machine reserves more than it uses, as core's kFormulaInputs),
//   then the family variables (context order), then the family's per-joint
//   variables (context order, N slots each: core's FormulaSlot::family_joint
//   when the family variables are none and the capacity is kFormulaInputs).
struct FormulaLayout {
  int joints = 6;
  int input_count = 0, family_count = 0;
  int input_capacity = 0;        // slots reserved for inputs (at least input_count)
  int family_joint_count = 0;    // per-joint family variables
  int q(int joint) const { return joint - 1; }  // joint 1-based
  int dir(int joint) const { return joints + joint - 1; }
  int load(int joint) const { return 2 * joints + joint - 1; }
  int temp() const { return 3 * joints; }
  int time() const { return 3 * joints + 1; }
  int pose(int component) const { return 3 * joints + 2 + component; }  // 0..5 = x..rz
  int input(int i) const { return 3 * joints + 8 + i; }
  int input_slots() const { return input_count > input_capacity ? input_count : input_capacity; }
  int family(int i) const { return 3 * joints + 8 + input_slots() + i; }
  int family_joint(int variable, int joint) const { return family(family_count) + variable * joints + joint - 1; }
  int size() const { return family_joint(family_joint_count, 1); }
};

// Scratch of one evaluation (one double per program slot); reused, it makes
// evaluation allocation-free after the first call.
struct FormulaWorkspace {
  std::vector<double> slots;
};

class FormulaEffect {
 public:
  // Checks and compiles a spec (parse, every name, every derivative).
  // Throws InputError (file, line and column of the offending key when the
  // spec carries them; one line) for every rule of the GUIDE contract.
  FormulaEffect(const FormulaEffectSpec& spec, const FormulaContext& context);
  ~FormulaEffect();
  FormulaEffect(FormulaEffect&&) noexcept;
  FormulaEffect& operator=(FormulaEffect&&) noexcept;
  FormulaEffect(const FormulaEffect&) = delete;
  FormulaEffect& operator=(const FormulaEffect&) = delete;

  const FormulaEffectSpec& spec() const;
  const std::string& name() const { return spec().name; }
  FormulaKind kind() const { return spec().kind; }
  const FormulaLayout& layout() const;
  // The acting joints, 1-based (joint kind; empty for pose kind).
  const std::vector<int>& joints() const;
  // Full parameter names in vector order: each per_joint base for every
  // acting joint (a1, a2, …, then b1, …), then the shared names.
  const std::vector<std::string>& parameter_names() const;
  std::vector<double> start_values() const;
  // Outputs of one node: one per acting joint (joint kind) or 6 (pose kind).
  int output_count() const;
  // Output names for messages: "dq3" or "dz".
  std::string output_name(int output) const;
  // What the formula reads, for `kincal effects` and missing-column checks.
  bool uses_temperature() const;
  bool uses_time() const;
  bool uses_direction() const;
  bool uses_load() const;
  bool uses_pose() const;    // reads x, y, z, rx, ry or rz
  bool uses_inputs() const;  // reads one of its named inputs
  bool uses_family() const;  // reads a variable the family offers
  // Measurement columns the data must carry ("temp", "time", the inputs;
  // directions and loads have defaults and are not listed).
  std::vector<std::string> required_columns() const;

  // Output `output` at one node: `vars` in layout() order, `params` in
  // parameter_names() order. No finiteness check (the hot path).
  double value(int output, const double* vars, const double* params, FormulaWorkspace& ws) const;
  double value(int output, const double* vars, const double* params) const;
  // Exact derivative of output `output` along every parameter (symbolic
  // derivatives compiled like the value): dparams has parameter_names().size().
  void gradient(int output, const double* vars, const double* params, double* dparams, FormulaWorkspace& ws) const;
  void gradient(int output, const double* vars, const double* params, double* dparams) const;
  // Every output (values: output_count()) and optionally the Jacobian
  // (output_count() × parameters, row-major; nullptr to skip), checked:
  // a value or derivative that is not finite throws InputError naming the
  // effect, the node, the output and the numbers the formula read there.
  void evaluate(const double* vars, const double* params, double* values, double* jacobian, const std::string& node,
                FormulaWorkspace& ws) const;

  // The value part as C++ for the generated table: one function
  //   template <class Scalar>
  //   void <function_name>(const Scalar* params, const Scalar* vars, Scalar* out)
  // writing output_count() values, params and vars as above. Only <cmath>
  // functions newlib has (sin cos tan asin acos atan atan2 exp log sqrt
  // abs), called unqualified after `using std::…` so float picks the float
  // overloads and an automatic-differentiation scalar finds its own. No
  // heap, no recursion, a fixed number of locals: stack statically bounded.
  std::string cpp_function(const std::string& function_name) const;
  // A C++ identifier for this effect's function: "kincal_formula_" + name.
  std::string cpp_function_name() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Reads the `effects` key of a robot description (the whole JSON text; no
// key: no effects) and compiles every entry; `file` names the description
// in errors. Also refuses two entries with one name.
std::vector<FormulaEffect> read_formula_effects(const std::string& description_text, const std::string& file,
                                                const FormulaContext& context);

}  // namespace kincal::identify
