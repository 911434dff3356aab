// The controller's parameter table: everything the compensation of one
// machine reads (core/compensation.hpp), as a plain aggregate of numbers so a
// generated header (`kincal table`) can define it `constexpr` — it then lives
// in flash, costs no start-up code, and its CRC is checked by `static_assert`
// (libopencm3 / modm style generated tables).
//
// A table is for ONE machine family: CalibrationTable<StewartMachine<S>> or
// CalibrationTable<HybridMachine<S>>, so a firmware image for one machine
// carries no data or code of the other.
//
//   6-UPS (seed 001): the nominal geometry and the calibrated geometry (nominal
//     + the 42 identified B_i, P_i, l_i errors); compensation is the IK of the
//     calibrated geometry (seed 001 Section 5).
//   hybrid (seed 000): the nominal geometry, the total encoder offsets ξ̂
//     (coarse + fine, Eq. (15)) and the structural source errors Δχ̂ (156, in
//     identify's HybridErrorModel order, encoder entries 0) for the predicted
//     error twist $_t = B·Δχ̂ of Eq. (16); `up_split` is e = |A44 A64| of seed
//     000 Table 1, where the wrist's first error frame sits.
//   both: the identified physical effects (core/effects.hpp) and the bounds the
//     controller enforces (largest correction |q − q_nominal| per joint, joint
//     command limits).
//
// Canonical value list. Every number of a table except `version`, `family` and
// `crc` is a Scalar; for_each_value() visits them in declaration order (the
// order of the members below, arrays element by element, matrices
// column-major). `kincal table` may emit the aggregate directly or a flat
// `double` array for table_from_values().
//
// CRC. CRC-32 (IEEE 802.3: reflected, polynomial 0xEDB88320, initial value and
// final XOR 0xFFFFFFFF; crc32("123456789") = 0xCBF43926) over the byte stream
//   version (u32 LE) | family (u8) | sizeof(Scalar) (u8) | value count (u32 LE)
//   | each value's IEEE-754 bit pattern in the table's Scalar (u32 or u64, LE)
// so it covers every bit of every stored number, is computable at compile time
// (table_crc is constexpr: `static_assert(kincal::table_crc(kTable) ==
// kTable.crc)`) and at run time (validate_table), and a float table has its own
// CRC (of the values rounded to float), which a generator gets by
// table_cast<float>() then seal_table().
#pragma once

#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "kincal/core/compensation_status.hpp"
#include "kincal/core/effects.hpp"
#include "kincal/core/hybrid.hpp"
#include "kincal/core/stewart.hpp"

#if defined(__has_builtin)
#if !__has_builtin(__builtin_bit_cast)
#error "kincal/core/calibration_table.hpp needs __builtin_bit_cast (GCC >= 11, Clang >= 9, MSVC >= 19.27)"
#endif
#endif

namespace kincal {

// Bumped whenever the layout or the meaning of a table value changes.
inline constexpr std::uint32_t kCalibrationTableVersion = 4;  // 2: effects.user; 3: the 6-UPS leg_offset_sq; 4: 16 user numbers (formula effects)

enum class MachineFamily : std::uint8_t {
  Stewart6Ups = 1,  // stewart-6ups (seed 001)
  Hybrid = 2,       // hybrid-3ups-up-3r (seed 000)
  Rus6 = 3,         // rus6 (core/rus6_machine.hpp)
};

// Size of Δχ of the hybrid (seed 000 Eq. (7)): 6 encoder offsets + 144
// structural errors (identify/hybrid_error_model.hpp).
inline constexpr int kHybridSourceErrorCount = 156;  // HybridErrorLayout: seed 000's 150 + the tool frame's 6

namespace table_detail {
template <class A, class F> constexpr void each(A& array, F& f) {
  for (auto& x : array) f(x);
}
}  // namespace table_detail

// ---- geometry ----------------------------------------------------------------

// StewartGeometry as numbers. Matrices column-major: base[3*i + k] is
// coordinate k of B_i.
template <class Scalar> struct StewartGeometryTable {
  Scalar base[18];           // B_i, base frame, mm
  Scalar platform[18];       // P_i, platform frame, mm
  Scalar length_offset[6];   // l_i − q_i, mm
  Scalar leg_offset_sq[6];   // s_i, mm²: l_i = √(|L_i|² − s_i) (core/stewart.hpp)
  Scalar min_length[6];      // stroke on q, mm
  Scalar max_length[6];
  Scalar home_rotation[9];   // FK's default start pose, R column-major
  Scalar home_position[3];   // mm
  Scalar characteristic_length;  // mm per rad in singularity tests

  template <class Self, class F> static constexpr void visit(Self& s, F& f) {
    using table_detail::each;
    each(s.base, f);
    each(s.platform, f);
    each(s.length_offset, f);
    each(s.leg_offset_sq, f);
    each(s.min_length, f);
    each(s.max_length, f);
    each(s.home_rotation, f);
    each(s.home_position, f);
    f(s.characteristic_length);
  }
};

// HybridGeometry as numbers (core/hybrid.hpp names and units).
template <class Scalar> struct HybridGeometryTable {
  Scalar base_joints[9];      // A1i in {R0}, columns, mm
  Scalar platform_joints[9];  // a_i in the platform frame, columns, mm
  Scalar platform_to_wrist;   // |A64 Q|, mm
  Scalar wrist_link;          // |Q P0|, mm
  Scalar tool_length;         // |P0 P|, mm
  Scalar workpiece_rotation[9];  // wR0, column-major
  Scalar workpiece_origin[3];    // origin of {R} in {R0}, mm
  Scalar tool_offset[9];         // C, column-major
  Scalar joint_offset[6];        // physical − commanded (nominal machine)
  Scalar min_joint[6];
  Scalar max_joint[6];
  Scalar min_extension;
  Scalar max_extension;
  Scalar home[3];  // θ1, θ2 (rad), c (mm)
  Scalar characteristic_length;

  template <class Self, class F> static constexpr void visit(Self& s, F& f) {
    using table_detail::each;
    each(s.base_joints, f);
    each(s.platform_joints, f);
    f(s.platform_to_wrist);
    f(s.wrist_link);
    f(s.tool_length);
    each(s.workpiece_rotation, f);
    each(s.workpiece_origin, f);
    each(s.tool_offset, f);
    each(s.joint_offset, f);
    each(s.min_joint, f);
    each(s.max_joint, f);
    f(s.min_extension);
    f(s.max_extension);
    each(s.home, f);
    f(s.characteristic_length);
  }
};

// EffectParameters (core/effects.hpp) as numbers; screw_joints is the bit
// mask as a value (an integer 0..63).
template <class Scalar> struct EffectTable {
  Scalar scale[6];
  Scalar backlash[6];
  Scalar compliance[6];
  Scalar cyclic_sin[6];
  Scalar cyclic_cos[6];
  Scalar thermal;  // c, 1/°C
  Scalar screw_lead;
  Scalar screw_joints;
  Scalar load_direction[3];
  Scalar thermal_origin[3];
  Scalar reference_temperature;
  Scalar user[kUserEffectParameters];  // the user joint effect's numbers (its function is code)

  template <class Self, class F> static constexpr void visit(Self& s, F& f) {
    using table_detail::each;
    each(s.scale, f);
    each(s.backlash, f);
    each(s.compliance, f);
    each(s.cyclic_sin, f);
    each(s.cyclic_cos, f);
    f(s.thermal);
    f(s.screw_lead);
    f(s.screw_joints);
    each(s.load_direction, f);
    each(s.thermal_origin, f);
    f(s.reference_temperature);
    each(s.user, f);
  }
};

// What the controller enforces on every command (joint units: mm, rad).
template <class Scalar> struct TableBounds {
  // Largest |command − nominal IK command| per joint: the whole correction
  // (geometry, encoder offsets, effects) of one NC point. A larger one means
  // the model or the input is wrong: OversizedCorrection.
  Scalar max_correction[6];
  Scalar min_joint[6];  // command limits (OutOfLimits outside)
  Scalar max_joint[6];

  template <class Self, class F> static constexpr void visit(Self& s, F& f) {
    using table_detail::each;
    each(s.max_correction, f);
    each(s.min_joint, f);
    each(s.max_joint, f);
  }
};

// ---- machines ----------------------------------------------------------------

// A machine is the family's part of a table: its numbers (visit lists them
// in the canonical order), `Rebind<Other>` (the same machine in another
// scalar: table_cast), encoder_offset(i) (the coarse calibration's zero of
// joint i, in joint units: the controller's drive registers) and its names
// in C++ and the header that defines it (`kincal table` writes them into
// the generated header), revolute(i) (joint i in rad rather than mm: the
// drives' register scaling). The
// compensator's half of a family is compensation_detail::Model<Machine>.
template <class S> struct StewartMachine {
  using Scalar = S;
  template <class Other> using Rebind = StewartMachine<Other>;
  static constexpr MachineFamily family = MachineFamily::Stewart6Ups;
  static constexpr const char* type_name = "StewartMachine";
  static constexpr const char* family_name = "Stewart6Ups";
  static constexpr const char* header = "kincal/core/calibration_table.hpp";  // what a generated table includes
  static constexpr bool revolute(int) { return false; }  // six legs, mm
  StewartGeometryTable<S> nominal;     // nominal IK: the reference of the correction bound
  StewartGeometryTable<S> calibrated;  // seed 001: IK of this geometry is the compensation

  // seed 001: l_i = q_i + dl_i, the leg's encoder zero error.
  S encoder_offset(int i) const { return calibrated.length_offset[i] - nominal.length_offset[i]; }

  template <class Self, class F> static constexpr void visit(Self& s, F& f) {
    StewartGeometryTable<S>::visit(s.nominal, f);
    StewartGeometryTable<S>::visit(s.calibrated, f);
  }
};

template <class S> struct HybridMachine {
  using Scalar = S;
  template <class Other> using Rebind = HybridMachine<Other>;
  static constexpr MachineFamily family = MachineFamily::Hybrid;
  static constexpr const char* type_name = "HybridMachine";
  static constexpr const char* family_name = "Hybrid";
  static constexpr const char* header = "kincal/core/calibration_table.hpp";  // what a generated table includes
  static constexpr bool revolute(int i) { return i >= 3; }  // three UPS legs (mm), the wrist (rad)
  HybridGeometryTable<S> nominal;  // the nominal machine (B is evaluated on it)
  S up_split;                      // e = |A44 A64|, mm (seed 000 Table 1: 345)
  S encoder_offsets[6];            // ξ̂, added to nominal.joint_offset in the IK
  S source_errors[kHybridSourceErrorCount];  // Δχ̂; entries 0..5 (encoders) must be 0

  S encoder_offset(int i) const { return encoder_offsets[i]; }

  template <class Self, class F> static constexpr void visit(Self& s, F& f) {
    HybridGeometryTable<S>::visit(s.nominal, f);
    f(s.up_split);
    table_detail::each(s.encoder_offsets, f);
    table_detail::each(s.source_errors, f);
  }
};

// ---- the table -----------------------------------------------------------------

template <class Machine> struct CalibrationTable {
  using Scalar = typename Machine::Scalar;
  using MachineType = Machine;
  std::uint32_t version;  // kCalibrationTableVersion
  MachineFamily family;   // Machine::family
  Machine machine;
  EffectTable<Scalar> effects;
  TableBounds<Scalar> bounds;
  std::uint32_t crc;  // table_crc() of the above

  template <class Self, class F> static constexpr void visit(Self& s, F& f) {
    Machine::visit(s.machine, f);
    EffectTable<Scalar>::visit(s.effects, f);
    TableBounds<Scalar>::visit(s.bounds, f);
  }
};

template <class S> using StewartCalibrationTable = CalibrationTable<StewartMachine<S>>;
template <class S> using HybridCalibrationTable = CalibrationTable<HybridMachine<S>>;
using StewartCalibrationTabled = StewartCalibrationTable<double>;
using StewartCalibrationTablef = StewartCalibrationTable<float>;
using HybridCalibrationTabled = HybridCalibrationTable<double>;
using HybridCalibrationTablef = HybridCalibrationTable<float>;

// Visits every Scalar of the table in canonical order: f(Scalar&) (or
// f(const Scalar&) for a const table).
template <class Machine, class F> constexpr void for_each_value(CalibrationTable<Machine>& t, F&& f) {
  CalibrationTable<Machine>::visit(t, f);
}
template <class Machine, class F> constexpr void for_each_value(const CalibrationTable<Machine>& t, F&& f) {
  CalibrationTable<Machine>::visit(t, f);
}

// Number of values in the canonical list (Stewart 192, hybrid 281).
template <class Machine> constexpr std::size_t table_value_count() {
  CalibrationTable<Machine> t{};
  std::size_t n = 0;
  for_each_value(t, [&n](auto&) { ++n; });
  return n;
}

// ---- CRC ---------------------------------------------------------------------

struct Crc32 {
  std::uint32_t state = 0xFFFFFFFFu;
  constexpr void byte(std::uint8_t b) {
    state ^= b;
    for (int k = 0; k < 8; ++k) state = (state >> 1) ^ (0xEDB88320u & (0u - (state & 1u)));
  }
  template <class U> constexpr void little_endian(U v, int bytes) {
    for (int k = 0; k < bytes; ++k) byte(static_cast<std::uint8_t>((v >> (8 * k)) & 0xFFu));
  }
  constexpr std::uint32_t value() const { return ~state; }
};

// IEEE-754 bit pattern of a value (constexpr, C++17: the compiler builtin).
constexpr std::uint32_t value_bits(float x) { return __builtin_bit_cast(std::uint32_t, x); }
constexpr std::uint64_t value_bits(double x) { return __builtin_bit_cast(std::uint64_t, x); }

template <class Machine> constexpr std::uint32_t table_crc(const CalibrationTable<Machine>& t) {
  using Scalar = typename Machine::Scalar;
  static_assert(std::is_same<Scalar, float>::value || std::is_same<Scalar, double>::value,
                "tables hold float or double");
  Crc32 crc;
  crc.little_endian(t.version, 4);
  crc.byte(static_cast<std::uint8_t>(t.family));
  crc.byte(static_cast<std::uint8_t>(sizeof(Scalar)));
  crc.little_endian(static_cast<std::uint32_t>(table_value_count<Machine>()), 4);
  for_each_value(t, [&crc](const Scalar& x) { crc.little_endian(value_bits(x), static_cast<int>(sizeof(Scalar))); });
  return crc.value();
}

// Sets version, family and crc of a filled table (generators, tests), in
// place: no copy of the table on a controller's stack.
template <class Machine> constexpr void seal(CalibrationTable<Machine>& t) {
  t.version = kCalibrationTableVersion;
  t.family = Machine::family;
  t.crc = table_crc(t);
}

// The same on a copy (constexpr expressions, host code).
template <class Machine> constexpr CalibrationTable<Machine> seal_table(CalibrationTable<Machine> t) {
  seal(t);
  return t;
}

// A table from the canonical value list (each converted to the table's
// Scalar), with the given CRC (not recomputed: the CRC is the generator's
// promise, checked by static_assert / validate_table). constexpr, so a
// generated header can write
//   constexpr double kValues[] = {...};
//   constexpr auto kTable = kincal::table_from_values<kincal::HybridMachine<double>>(kValues, 0x...u);
//   static_assert(kincal::table_crc(kTable) == kTable.crc, "corrupt table");
template <class Machine, std::size_t N>
constexpr CalibrationTable<Machine> table_from_values(const double (&values)[N], std::uint32_t crc) {
  static_assert(N == table_value_count<Machine>(), "value list does not match the table layout");
  using Scalar = typename Machine::Scalar;
  CalibrationTable<Machine> t{};
  t.version = kCalibrationTableVersion;
  t.family = Machine::family;
  std::size_t k = 0;
  for_each_value(t, [&](Scalar& x) { x = static_cast<Scalar>(values[k++]); });
  t.crc = crc;
  return t;
}

// The canonical list as doubles (float values convert exactly); `out` must
// hold table_value_count<Machine>() entries.
template <class Machine> void table_to_values(const CalibrationTable<Machine>& t, double* out) {
  using Scalar = typename Machine::Scalar;
  std::size_t k = 0;
  for_each_value(t, [&](const Scalar& x) { out[k++] = static_cast<double>(x); });
}

// The same table in another Scalar (values rounded to nearest), resealed:
// the CRC of a float table is that of its float values.
template <class Other, class Machine> auto table_cast(const CalibrationTable<Machine>& t) {
  using OtherMachine = typename Machine::template Rebind<Other>;
  double values[table_value_count<Machine>()] = {};
  table_to_values(t, values);
  CalibrationTable<OtherMachine> out = table_from_values<OtherMachine>(values, 0u);
  seal(out);
  return out;
}

// ---- validation ----------------------------------------------------------------

namespace table_detail {

template <class Scalar> constexpr bool finite(Scalar x) { return x - x == Scalar(0); }
template <class Scalar> constexpr Scalar abs(Scalar x) { return x < Scalar(0) ? -x : x; }

// RᵀR = I within a tolerance fit for the scalar (a rotation's entries are
// stored to full precision, so 1e-6 / 1e-4 only catches corruption).
template <class Scalar> constexpr bool rotation(const Scalar (&r)[9]) {
  const Scalar tol = sizeof(Scalar) == 8 ? Scalar(1e-9) : Scalar(1e-4);
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      Scalar d(0);
      for (int k = 0; k < 3; ++k) d += r[3 * a + k] * r[3 * b + k];
      if (abs(d - (a == b ? Scalar(1) : Scalar(0))) > tol) return false;
    }
  return true;
}

template <class Scalar> constexpr bool ordered(const Scalar (&lo)[6], const Scalar (&hi)[6]) {
  for (int i = 0; i < 6; ++i)
    if (!(lo[i] < hi[i])) return false;
  return true;
}

template <class Scalar> constexpr bool values_ok(const StewartGeometryTable<Scalar>& g) {
  return rotation(g.home_rotation) && g.characteristic_length > Scalar(0) && ordered(g.min_length, g.max_length);
}

template <class Scalar> constexpr bool values_ok(const HybridGeometryTable<Scalar>& g) {
  return rotation(g.workpiece_rotation) && rotation(g.tool_offset) && g.platform_to_wrist > Scalar(0) &&
         g.wrist_link > Scalar(0) && g.tool_length > Scalar(0) && g.characteristic_length > Scalar(0) &&
         g.min_extension < g.max_extension && ordered(g.min_joint, g.max_joint);
}

}  // namespace table_detail

// A machine's own values check (validate_table's TableValues), one overload
// per family beside its machine type, found by argument-dependent lookup: a
// family's header (core/rus6_machine.hpp) adds its own without touching this
// file.
template <class Scalar> constexpr bool machine_values_ok(const StewartMachine<Scalar>& m, const TableBounds<Scalar>&) {
  using table_detail::values_ok;
  return values_ok(m.nominal) && values_ok(m.calibrated);
}

template <class Scalar> constexpr bool machine_values_ok(const HybridMachine<Scalar>& m, const TableBounds<Scalar>& b) {
  using namespace table_detail;
  if (!values_ok(m.nominal) || !(m.up_split > Scalar(0))) return false;
  for (int i = 0; i < 6; ++i) {
    // The encoder offsets live in encoder_offsets only (no double count in B·Δχ).
    if (m.source_errors[i] != Scalar(0)) return false;
    // An encoder offset is a correction at every point: one above the bound is
    // a corrupt table, not a bad NC point.
    if (!(abs(m.encoder_offsets[i]) <= b.max_correction[i])) return false;
  }
  return true;
}

namespace table_detail {

template <class Scalar> constexpr bool values_ok(const EffectTable<Scalar>& e) {
  const Scalar mask = e.screw_joints;
  if (!(mask >= Scalar(0) && mask <= Scalar(63)) || Scalar(static_cast<int>(mask)) != mask) return false;
  return e.screw_lead > Scalar(0);
}

template <class Scalar> constexpr bool values_ok(const TableBounds<Scalar>& b) {
  for (int i = 0; i < 6; ++i)
    if (!(b.max_correction[i] > Scalar(0))) return false;
  return ordered(b.min_joint, b.max_joint);
}

}  // namespace table_detail

// Start-up check of a table (and `static_assert`-able in a generated header):
//   TableVersion  version ≠ kCalibrationTableVersion (checked first: another
//                 version may have another layout)
//   TableFamily   family ≠ Machine::family
//   TableCrc      crc ≠ table_crc(table)
//   TableValues   a non-finite value; bounds not positive / not ordered; a
//                 geometry that is not one (rotations not orthonormal, lengths
//                 ≤ 0, limits not ordered); the hybrid's encoder entries of
//                 source_errors not 0 or an encoder offset above its bound;
//                 screw mask not an integer in 0..63; screw lead ≤ 0
template <class Machine> constexpr CompensationStatus validate_table(const CalibrationTable<Machine>& t) {
  using Scalar = typename Machine::Scalar;
  if (t.version != kCalibrationTableVersion) return CompensationStatus::TableVersion;
  if (t.family != Machine::family) return CompensationStatus::TableFamily;
  if (t.crc != table_crc(t)) return CompensationStatus::TableCrc;
  bool finite = true;
  for_each_value(t, [&finite](const Scalar& x) { finite = finite && table_detail::finite(x); });
  if (!finite) return CompensationStatus::TableValues;
  if (!table_detail::values_ok(t.bounds) || !table_detail::values_ok(t.effects) ||
      !machine_values_ok(t.machine, t.bounds))
    return CompensationStatus::TableValues;
  return CompensationStatus::Ok;
}

// ---- conversions to and from core's types (run time) ---------------------------

namespace table_detail {
template <class Scalar, int R, int C> void put(const Eigen::Matrix<Scalar, R, C>& m, Scalar* out) {
  Eigen::Map<Eigen::Matrix<Scalar, R, C>> dst(out);
  dst = m;
}
template <class Scalar, int R, int C> Eigen::Matrix<Scalar, R, C> get(const Scalar* in) {
  return Eigen::Map<const Eigen::Matrix<Scalar, R, C>>(in);
}
}  // namespace table_detail

template <class Scalar> StewartGeometry<Scalar> to_core(const StewartGeometryTable<Scalar>& t) {
  using namespace table_detail;
  StewartGeometry<Scalar> g;
  g.base = get<Scalar, 3, 6>(t.base);
  g.platform = get<Scalar, 3, 6>(t.platform);
  g.length_offset = get<Scalar, 6, 1>(t.length_offset);
  g.leg_offset_sq = get<Scalar, 6, 1>(t.leg_offset_sq);
  g.min_length = get<Scalar, 6, 1>(t.min_length);
  g.max_length = get<Scalar, 6, 1>(t.max_length);
  g.home.R = get<Scalar, 3, 3>(t.home_rotation);
  g.home.p = get<Scalar, 3, 1>(t.home_position);
  g.characteristic_length = t.characteristic_length;
  return g;
}

template <class Scalar> StewartGeometryTable<Scalar> to_table(const StewartGeometry<Scalar>& g) {
  using namespace table_detail;
  StewartGeometryTable<Scalar> t{};
  put(g.base, t.base);
  put(g.platform, t.platform);
  put(g.length_offset, t.length_offset);
  put(g.leg_offset_sq, t.leg_offset_sq);
  put(g.min_length, t.min_length);
  put(g.max_length, t.max_length);
  put(g.home.R, t.home_rotation);
  put(g.home.p, t.home_position);
  t.characteristic_length = g.characteristic_length;
  return t;
}

template <class Scalar> HybridGeometry<Scalar> to_core(const HybridGeometryTable<Scalar>& t) {
  using namespace table_detail;
  HybridGeometry<Scalar> g;
  g.base_joints = get<Scalar, 3, 3>(t.base_joints);
  g.platform_joints = get<Scalar, 3, 3>(t.platform_joints);
  g.platform_to_wrist = t.platform_to_wrist;
  g.wrist_link = t.wrist_link;
  g.tool_length = t.tool_length;
  g.workpiece_rotation = get<Scalar, 3, 3>(t.workpiece_rotation);
  g.workpiece_origin = get<Scalar, 3, 1>(t.workpiece_origin);
  g.tool_offset = get<Scalar, 3, 3>(t.tool_offset);
  g.joint_offset = get<Scalar, 6, 1>(t.joint_offset);
  g.min_joint = get<Scalar, 6, 1>(t.min_joint);
  g.max_joint = get<Scalar, 6, 1>(t.max_joint);
  g.min_extension = t.min_extension;
  g.max_extension = t.max_extension;
  g.home.theta1 = t.home[0];
  g.home.theta2 = t.home[1];
  g.home.extension = t.home[2];
  g.characteristic_length = t.characteristic_length;
  return g;
}

template <class Scalar> HybridGeometryTable<Scalar> to_table(const HybridGeometry<Scalar>& g) {
  using namespace table_detail;
  HybridGeometryTable<Scalar> t{};
  put(g.base_joints, t.base_joints);
  put(g.platform_joints, t.platform_joints);
  t.platform_to_wrist = g.platform_to_wrist;
  t.wrist_link = g.wrist_link;
  t.tool_length = g.tool_length;
  put(g.workpiece_rotation, t.workpiece_rotation);
  put(g.workpiece_origin, t.workpiece_origin);
  put(g.tool_offset, t.tool_offset);
  put(g.joint_offset, t.joint_offset);
  put(g.min_joint, t.min_joint);
  put(g.max_joint, t.max_joint);
  t.min_extension = g.min_extension;
  t.max_extension = g.max_extension;
  t.home[0] = g.home.theta1;
  t.home[1] = g.home.theta2;
  t.home[2] = g.home.extension;
  t.characteristic_length = g.characteristic_length;
  return t;
}

template <class Scalar> EffectParameters<Scalar> to_core(const EffectTable<Scalar>& t) {
  using namespace table_detail;
  EffectParameters<Scalar> e;
  e.scale = get<Scalar, 6, 1>(t.scale);
  e.backlash = get<Scalar, 6, 1>(t.backlash);
  e.compliance = get<Scalar, 6, 1>(t.compliance);
  e.cyclic_sin = get<Scalar, 6, 1>(t.cyclic_sin);
  e.cyclic_cos = get<Scalar, 6, 1>(t.cyclic_cos);
  e.thermal = t.thermal;
  e.screw_lead = t.screw_lead;
  e.screw_joints = static_cast<std::uint8_t>(static_cast<int>(t.screw_joints));
  e.load_direction = get<Scalar, 3, 1>(t.load_direction);
  e.thermal_origin = get<Scalar, 3, 1>(t.thermal_origin);
  e.reference_temperature = t.reference_temperature;
  e.user = get<Scalar, kUserEffectParameters, 1>(t.user);
  return e;
}

template <class Scalar> EffectTable<Scalar> to_table(const EffectParameters<Scalar>& e) {
  using namespace table_detail;
  EffectTable<Scalar> t{};
  put(e.scale, t.scale);
  put(e.backlash, t.backlash);
  put(e.compliance, t.compliance);
  put(e.cyclic_sin, t.cyclic_sin);
  put(e.cyclic_cos, t.cyclic_cos);
  t.thermal = e.thermal;
  t.screw_lead = e.screw_lead;
  t.screw_joints = Scalar(e.screw_joints);
  put(e.load_direction, t.load_direction);
  put(e.thermal_origin, t.thermal_origin);
  t.reference_temperature = e.reference_temperature;
  put(e.user, t.user);
  return t;
}

}  // namespace kincal
