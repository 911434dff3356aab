// Formula effects (identify/formula_effect.hpp; GUIDE "Effects written as
// formulas"; issue #32). GiNaC parses a formula, differentiates it exactly
// along every parameter, and hands over its expression tree; this file turns
// that tree into a flat program over double slots (evaluated per node, and
// printed as the firmware's C++) and checks every rule of the contract with
// one-line errors. No GiNaC object outlives construction: GiNaC's reference
// counts are not atomic, so all GiNaC work happens under one mutex and the
// compiled effect holds plain numbers only (safe to share between threads).
#include "kincal/identify/formula_effect.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <mutex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <utility>

#include <ginac/ginac.h>

#include "families/description_reader.hpp"
#include "io/json_locator.hpp"
#include "kincal/identify/input_error.hpp"

// Functions the formulas may use that GiNaC lacks or defines unsuitably.
// GiNaC's own abs(x) differentiates to x/abs(x), which is 0/0 at x = 0; the
// parameters of a ramp max(0, q − q0)^2 sit exactly there when q0 starts at
// a commanded value. So abs, sign, min and max are ours:
//   d abs(u) = sign(u) du with sign(0) = 0 (the mean of the one-sided slopes),
//   d sign(u) = 0 (the jump is not differentiated; a fit cannot move it),
//   min(a, b) = (a + b − |a − b|)/2, max(a, b) = (a + b + |a − b|)/2,
// hence at a tie a = b each argument gets half the slope (d max/da = 1/2):
// the derivative at the kink is the average of the two sides, finite, and
// the same in the identification columns and anywhere else it is used.
namespace kincal::identify::formula_functions {

DECLARE_FUNCTION_1P(kincal_abs)
DECLARE_FUNCTION_1P(kincal_sign)
DECLARE_FUNCTION_2P(kincal_min)
DECLARE_FUNCTION_2P(kincal_max)

static GiNaC::ex abs_eval(const GiNaC::ex& u) {
  if (GiNaC::is_exactly_a<GiNaC::numeric>(u) && GiNaC::ex_to<GiNaC::numeric>(u).is_real())
    return GiNaC::abs(GiNaC::ex_to<GiNaC::numeric>(u));
  return kincal_abs(u).hold();
}
static GiNaC::ex abs_derivative(const GiNaC::ex& u, unsigned) { return kincal_sign(u); }
static GiNaC::ex sign_eval(const GiNaC::ex& u) {
  if (GiNaC::is_exactly_a<GiNaC::numeric>(u) && GiNaC::ex_to<GiNaC::numeric>(u).is_real()) {
    const GiNaC::numeric& n = GiNaC::ex_to<GiNaC::numeric>(u);
    return n.is_zero() ? 0 : (n.is_positive() ? 1 : -1);
  }
  return kincal_sign(u).hold();
}
static GiNaC::ex sign_derivative(const GiNaC::ex&, unsigned) { return 0; }
// min and max never survive: they become the abs forms above at once, so
// derivatives and printing need nothing of their own.
static GiNaC::ex min_eval(const GiNaC::ex& a, const GiNaC::ex& b) { return (a + b - kincal_abs(a - b)) / 2; }
static GiNaC::ex max_eval(const GiNaC::ex& a, const GiNaC::ex& b) { return (a + b + kincal_abs(a - b)) / 2; }

REGISTER_FUNCTION(kincal_abs, eval_func(abs_eval).derivative_func(abs_derivative))
REGISTER_FUNCTION(kincal_sign, eval_func(sign_eval).derivative_func(sign_derivative))
REGISTER_FUNCTION(kincal_min, eval_func(min_eval))
REGISTER_FUNCTION(kincal_max, eval_func(max_eval))

}  // namespace kincal::identify::formula_functions

namespace kincal::identify {

namespace {

namespace fx = formula_functions;
using detail::join;

std::mutex& ginac_mutex() {
  static std::mutex m;
  return m;
}

constexpr const char* kPoseComponents[6] = {"dx", "dy", "dz", "drx", "dry", "drz"};
constexpr const char* kPoseVariables[6] = {"x", "y", "z", "rx", "ry", "rz"};
constexpr const char* kFunctions[] = {"sin", "cos", "tan", "asin", "acos", "atan", "atan2", "exp",
                                      "log", "sqrt", "abs", "sign", "min", "max"};
// GiNaC's parser reads these as its own constants, whatever the symbol table says.
constexpr const char* kParserLiterals[] = {"I", "Pi", "Euler", "Catalan"};
// A formula is a line a user writes; the caps keep the parser's recursion
// and the fuzzer's inputs bounded.
constexpr std::size_t kMaxFormulaLength = 4000;
constexpr int kMaxNesting = 64;

// ---------------------------------------------------------------- names

bool is_identifier(const std::string& s) {
  if (s.empty() || !(std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_')) return false;
  for (char c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) return false;
  return true;
}

bool is_function_name(const std::string& s) {
  for (const char* f : kFunctions)
    if (s == f) return true;
  return false;
}

std::string in_quotes(const std::string& s) { return "'" + s + "'"; }

// The program: what a formula and its derivatives compile to.
enum class Code : std::uint8_t {
  Const, Load, Add, Sub, Mul, Div, Neg, PowInt, Pow, Sqrt, Sin, Cos, Tan, Asin, Acos, Atan, Atan2, Exp, Log, Abs, Sign
};
struct Op {
  Code code = Code::Const;
  int a = 0, b = 0;  // operand slots (Load: the symbol; PowInt: b = the exponent)
  double c = 0;      // Const
};

// Where a symbol of the formula takes its number from at one output.
struct SymbolSource {
  enum Kind { PerJoint, Shared, ThisJoint, Var } kind = Var;
  int index = 0;  // PerJoint: base b; Shared: s; ThisJoint: layout offset of joint 1; Var: layout index
  std::string name;
};

// Integer powers up to this exponent are written out as products (the same
// left-to-right product in the evaluator and in the generated C++, so both
// round alike); larger ones go through pow.
constexpr int kMaxUnrolledPower = 8;

}  // namespace

struct FormulaEffect::Impl {
  FormulaEffectSpec spec;
  FormulaLayout layout;
  std::vector<int> joints;
  std::vector<std::string> parameter_names;
  std::vector<double> start;
  int bases = 0, shared = 0;  // per_joint bases, shared parameters
  std::vector<SymbolSource> symbols;
  std::vector<Op> ops;
  std::size_t value_ops = 0;                     // ops [0, value_ops) compute the values
  std::vector<int> value_slot;                   // per component (1 or 6)
  std::vector<std::vector<int>> derivative_slot; // [component][base…, shared…]: slot, −1 = identically 0
  bool temperature = false, time = false, direction = false, load = false, pose_variables = false;
  bool family = false;  // reads a family variable
  std::vector<bool> input_used;

  [[noreturn]] void fail(const std::string& key, const std::string& message) const {
    FormulaWhere w;
    auto it = spec.where.find(key);
    if (it == spec.where.end()) it = spec.where.find("");
    if (it != spec.where.end()) w = it->second;
    throw InputError(spec.file, w.line, w.column,
                     "effect " + in_quotes(spec.name.empty() ? std::string("?") : spec.name) + ": " + message);
  }

  int outputs() const { return spec.kind == FormulaKind::Joint ? static_cast<int>(joints.size()) : 6; }

  double load_symbol(const SymbolSource& s, int k, const double* vars, const double* params) const {
    switch (s.kind) {
      case SymbolSource::PerJoint: return params[s.index * static_cast<int>(joints.size()) + k];
      case SymbolSource::Shared: return params[bases * static_cast<int>(joints.size()) + s.index];
      case SymbolSource::ThisJoint: return vars[s.index + joints[static_cast<std::size_t>(k)] - 1];
      case SymbolSource::Var: break;
    }
    return vars[s.index];
  }

  // Runs ops [0, end) for output k into ws.
  void run(std::size_t end, int k, const double* vars, const double* params, FormulaWorkspace& ws) const {
    if (ws.slots.size() < ops.size()) ws.slots.resize(ops.size());
    double* t = ws.slots.data();
    for (std::size_t i = 0; i < end; ++i) {
      const Op& o = ops[i];
      switch (o.code) {
        case Code::Const: t[i] = o.c; break;
        case Code::Load: t[i] = load_symbol(symbols[static_cast<std::size_t>(o.a)], k, vars, params); break;
        case Code::Add: t[i] = t[o.a] + t[o.b]; break;
        case Code::Sub: t[i] = t[o.a] - t[o.b]; break;
        case Code::Mul: t[i] = t[o.a] * t[o.b]; break;
        case Code::Div: t[i] = t[o.a] / t[o.b]; break;
        case Code::Neg: t[i] = -t[o.a]; break;
        case Code::PowInt: {
          double r = t[o.a];
          for (int n = 1; n < o.b; ++n) r *= t[o.a];
          t[i] = r;
          break;
        }
        case Code::Pow: t[i] = std::pow(t[o.a], t[o.b]); break;
        case Code::Sqrt: t[i] = std::sqrt(t[o.a]); break;
        case Code::Sin: t[i] = std::sin(t[o.a]); break;
        case Code::Cos: t[i] = std::cos(t[o.a]); break;
        case Code::Tan: t[i] = std::tan(t[o.a]); break;
        case Code::Asin: t[i] = std::asin(t[o.a]); break;
        case Code::Acos: t[i] = std::acos(t[o.a]); break;
        case Code::Atan: t[i] = std::atan(t[o.a]); break;
        case Code::Atan2: t[i] = std::atan2(t[o.a], t[o.b]); break;
        case Code::Exp: t[i] = std::exp(t[o.a]); break;
        case Code::Log: t[i] = std::log(t[o.a]); break;
        case Code::Abs: t[i] = std::abs(t[o.a]); break;
        // sign(NaN) stays NaN (NaN · 0), so a non-finite argument is not hidden.
        case Code::Sign: t[i] = t[o.a] > 0 ? 1.0 : (t[o.a] < 0 ? -1.0 : t[o.a] * 0.0); break;
      }
    }
  }

  int component_of(int output) const { return spec.kind == FormulaKind::Joint ? 0 : output; }
  int joint_of(int output) const { return spec.kind == FormulaKind::Joint ? output : 0; }

  void check_output(int output) const {
    if (output < 0 || output >= outputs())
      throw std::out_of_range("formula effect " + in_quotes(spec.name) + ": output " + std::to_string(output) +
                              " of " + std::to_string(outputs()));
  }

  void scatter_gradient(int output, const FormulaWorkspace& ws, double* dparams) const {
    const int J = static_cast<int>(joints.size());
    const int k = joint_of(output);
    std::fill(dparams, dparams + parameter_names.size(), 0.0);
    const auto& d = derivative_slot[static_cast<std::size_t>(component_of(output))];
    for (int b = 0; b < bases; ++b)
      if (d[static_cast<std::size_t>(b)] >= 0) dparams[b * J + k] = ws.slots[static_cast<std::size_t>(d[static_cast<std::size_t>(b)])];
    for (int s = 0; s < shared; ++s)
      if (d[static_cast<std::size_t>(bases + s)] >= 0)
        dparams[bases * J + s] = ws.slots[static_cast<std::size_t>(d[static_cast<std::size_t>(bases + s)])];
  }
};

namespace {

// ---------------------------------------------------------------- lexing
//
// GiNaC's parser builds the tree, but it reports every syntax error at
// "line 0, column 0" (GiNaC 1.8.6, measured) and names no unknown symbol's
// place. This lexer only classifies characters into tokens with their
// offsets: it names a bad character, a bad number, an unknown symbol or
// function where they stand, and it fixes how numbers reach GiNaC (below).

struct Token {
  enum Kind { Number, Identifier, Operator, Open, Close, Comma } kind;
  std::size_t begin, end;  // offsets in the formula
  std::string text;
};

struct FormulaText {
  std::string ginac;                 // what GiNaC parses
  std::vector<std::size_t> token_end; // per token: its end offset in `ginac`
  std::vector<Token> tokens;
};

// Numbers: GiNaC computes with exact rationals, and an exact integer power
// is computed in full: 9^(9^9) would take hours and gigabytes (and
// "1e999999999" ran for minutes inside CLN's reader). So every literal reaches
// GiNaC as a floating-point number (CLN floats, ~17 digits: bounded work, the
// same rounding as double to well below a nanometre), except a small
// integer or ratio written directly as an exponent (x^2, x^-3, x^(1/3)):
// those stay exact, so x^2 differentiates to 2x and the program writes
// x·x, not pow(x, 2.0).
FormulaText lex(const std::string& f, const std::function<void(std::size_t, const std::string&)>& fail) {
  FormulaText out;
  if (f.size() > kMaxFormulaLength)
    fail(std::string::npos, "is " + std::to_string(f.size()) + " characters long (at most " + std::to_string(kMaxFormulaLength) + ")");
  std::size_t i = 0;
  int depth = 0;
  while (i < f.size()) {
    const char c = f[i];
    if (c == ' ' || c == '\t') {
      ++i;
      continue;
    }
    const std::size_t begin = i;
    if (std::isdigit(static_cast<unsigned char>(c)) || (c == '.' && i + 1 < f.size() && std::isdigit(static_cast<unsigned char>(f[i + 1])))) {
      while (i < f.size() && std::isdigit(static_cast<unsigned char>(f[i]))) ++i;
      if (i < f.size() && f[i] == '.') {
        ++i;
        while (i < f.size() && std::isdigit(static_cast<unsigned char>(f[i]))) ++i;
      }
      if (i < f.size() && (f[i] == 'e' || f[i] == 'E')) {
        std::size_t j = i + 1;
        if (j < f.size() && (f[j] == '+' || f[j] == '-')) ++j;
        const std::size_t digits = j;
        while (j < f.size() && std::isdigit(static_cast<unsigned char>(f[j]))) ++j;
        if (j > digits) {
          if (j - digits > 3) fail(begin, "the number '" + f.substr(begin, j - begin) + "' is out of range");
          i = j;
        }
      }
      const std::string text = f.substr(begin, i - begin);
      if (text.size() > 40) fail(begin, "the number '" + text + "' has too many digits");
      const double v = std::strtod(text.c_str(), nullptr);
      if (!std::isfinite(v)) fail(begin, "the number '" + text + "' does not fit a double");
      out.tokens.push_back({Token::Number, begin, i, text});
    } else if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
      while (i < f.size() && (std::isalnum(static_cast<unsigned char>(f[i])) || f[i] == '_')) ++i;
      out.tokens.push_back({Token::Identifier, begin, i, f.substr(begin, i - begin)});
    } else if (c == '+' || c == '-' || c == '*' || c == '/' || c == '^') {
      ++i;
      out.tokens.push_back({Token::Operator, begin, i, std::string(1, c)});
    } else if (c == '(') {
      if (++depth > kMaxNesting) fail(begin, "nests parentheses deeper than " + std::to_string(kMaxNesting));
      ++i;
      out.tokens.push_back({Token::Open, begin, i, "("});
    } else if (c == ')') {
      --depth;
      ++i;
      out.tokens.push_back({Token::Close, begin, i, ")"});
    } else if (c == ',') {
      ++i;
      out.tokens.push_back({Token::Comma, begin, i, ","});
    } else {
      const unsigned char u = static_cast<unsigned char>(c);
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02X", u);
      fail(begin, std::string("unexpected character ") +
                      (u >= 0x20 && u < 0x7F ? "'" + std::string(1, c) + "'" : std::string(buf)) +
                      " (a formula has numbers, names, + - * / ^, parentheses and commas)");
    }
  }
  if (out.tokens.empty()) fail(std::string::npos, "is empty (write 0 for no effect)");

  // Which number tokens stay exact: an integer of at most 6 digits right after
  // '^', '^-', '^(' or '^(-', and the denominator of such a '^(n/m)'.
  const auto& t = out.tokens;
  const auto op = [&](std::size_t k, const char* s) { return k < t.size() && t[k].text == s && t[k].kind != Token::Number; };
  std::vector<bool> exact(t.size(), false);
  for (std::size_t k = 0; k < t.size(); ++k) {
    if (t[k].kind != Token::Number || t[k].text.find_first_not_of("0123456789") != std::string::npos ||
        t[k].text.size() > 6)
      continue;
    const auto before = [&](std::size_t back, const char* s) { return k >= back && op(k - back, s); };
    bool in_paren = false;
    if (before(1, "^") || (before(1, "-") && before(2, "^")))
      exact[k] = true;
    else if ((before(1, "(") && before(2, "^")) || (before(1, "-") && before(2, "(") && before(3, "^")))
      exact[k] = in_paren = true;
    else if (before(1, "/") && k >= 2 && exact[k - 2] && (before(3, "(") || (before(3, "-") && before(4, "("))) &&
             op(k + 1, ")"))
      exact[k] = true;
    // "^(2 + x)": only a whole exponent "(n)" or "(n/m)" is kept exact.
    if (in_paren && !(op(k + 1, ")") || op(k + 1, "/"))) exact[k] = false;
  }
  std::size_t previous_end = 0;
  for (std::size_t k = 0; k < t.size(); ++k) {
    out.ginac += f.substr(previous_end, t[k].begin - previous_end);  // the blanks between tokens
    out.ginac += t[k].text;
    if (t[k].kind == Token::Number && !exact[k] && t[k].text.find_first_of(".eE") == std::string::npos) out.ginac += ".0";
    out.token_end.push_back(out.ginac.size());
    previous_end = t[k].end;
  }
  return out;
}

// ---------------------------------------------------------------- parsing

// GiNaC's parser table names a GiNaC function by its serial number, encoded
// as 2·serial + 1 (GiNaC 1.8 parse_context.h: "the map value … is
// internally treated as an unsigned"; odd values are serials, even ones
// reader functions). Checked once against GiNaC's own entry for abs.
GiNaC::reader_func function_entry(unsigned serial) {
  return reinterpret_cast<GiNaC::reader_func>(static_cast<std::uintptr_t>(serial) * 2 + 1);
}

const GiNaC::prototype_table& function_table() {
  static const GiNaC::prototype_table table = [] {
    const GiNaC::prototype_table& builtin = GiNaC::get_default_reader();
    const auto abs_entry = builtin.find(GiNaC::prototype("abs", 1));
    if (abs_entry == builtin.end() || abs_entry->second != function_entry(GiNaC::function::find_function("abs", 1)))
      throw std::logic_error("formula effects: this GiNaC encodes parser functions unlike GiNaC 1.8");
    GiNaC::prototype_table t;
    for (const auto& [name, args] : std::vector<std::pair<const char*, std::size_t>>{
             {"sin", 1}, {"cos", 1}, {"tan", 1}, {"asin", 1}, {"acos", 1}, {"atan", 1}, {"atan2", 2}, {"exp", 1}, {"log", 1}, {"sqrt", 1}}) {
      const auto it = builtin.find(GiNaC::prototype(name, args));
      if (it == builtin.end()) throw std::logic_error(std::string("formula effects: GiNaC's parser lacks ") + name);
      t.insert(*it);
    }
    t[GiNaC::prototype("abs", 1)] = function_entry(fx::kincal_abs_SERIAL::serial);
    t[GiNaC::prototype("sign", 1)] = function_entry(fx::kincal_sign_SERIAL::serial);
    t[GiNaC::prototype("min", 2)] = function_entry(fx::kincal_min_SERIAL::serial);
    t[GiNaC::prototype("max", 2)] = function_entry(fx::kincal_max_SERIAL::serial);
    return t;
  }();
  return table;
}

std::string first_line(const std::string& s) { return s.substr(0, s.find('\n')); }

// GiNaC's message without its "GiNaC: parse error at line 0, column 0: " head.
std::string ginac_message(const std::exception& e) {
  std::string m = first_line(e.what());
  const std::size_t head = m.find("column ");
  if (m.rfind("GiNaC: parse error", 0) == 0 && head != std::string::npos) {
    const std::size_t colon = m.find(": ", head);
    if (colon != std::string::npos) m = m.substr(colon + 2);
  }
  if (m.find("power should have exactly 2 operands") != std::string::npos)
    m = "a^b^c needs parentheses: write a^(b^c) or (a^b)^c";
  return m;
}

// GiNaC's abs and csgn may come back from its own simplifications (e.g. of
// sqrt(x^2)); they become ours so that the kink's derivative is the one
// documented above.
GiNaC::ex ours(const GiNaC::ex& e) {
  GiNaC::exmap m;
  m[GiNaC::abs(GiNaC::wild(0))] = fx::kincal_abs(GiNaC::wild(0));
  m[GiNaC::csgn(GiNaC::wild(0))] = fx::kincal_sign(GiNaC::wild(0));
  return e.subs(m, GiNaC::subs_options::subs_algebraic);
}

// ---------------------------------------------------------------- compiling

class Compiler {
 public:
  Compiler(std::vector<Op>& ops, const std::map<std::string, int>& symbol_index,
           const std::function<void(const std::string&)>& fail)
      : ops_(ops), symbol_index_(symbol_index), fail_(fail) {}

  int operator()(const GiNaC::ex& e) {
    const auto it = memo_.find(e);
    if (it != memo_.end()) return it->second;
    const int slot = compile(e);
    memo_.emplace(e, slot);
    return slot;
  }

 private:
  int emit(Code code, int a = 0, int b = 0, double c = 0) {
    ops_.push_back({code, a, b, c});
    return static_cast<int>(ops_.size()) - 1;
  }
  int constant(double v) {
    if (!std::isfinite(v)) fail_("a constant of the formula is not finite");
    std::uint64_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    const auto it = constants_.find(bits);
    if (it != constants_.end()) return it->second;
    const int slot = emit(Code::Const, 0, 0, v);
    constants_.emplace(bits, slot);
    return slot;
  }
  double number(const GiNaC::ex& e) {
    const GiNaC::ex v = e.evalf();
    if (!GiNaC::is_a<GiNaC::numeric>(v) || !GiNaC::ex_to<GiNaC::numeric>(v).is_real())
      fail_("a constant of the formula is not a real number");
    return GiNaC::ex_to<GiNaC::numeric>(v).to_double();
  }
  static bool integral(const GiNaC::numeric& n, long& value) {
    if (!n.is_real()) return false;
    if (n.is_integer()) {
      if (GiNaC::abs(n).compare(GiNaC::numeric(1000000)) > 0) return false;
      value = n.to_long();
      return true;
    }
    const double d = n.to_double();
    if (std::isfinite(d) && std::abs(d) <= 1e6 && d == std::floor(d)) {
      value = static_cast<long>(d);
      return true;
    }
    return false;
  }
  // base^n for an integer n ≠ 0.
  int integer_power(int base, long n) {
    const long m = n < 0 ? -n : n;
    int p = m == 1 ? base
                   : (m <= kMaxUnrolledPower ? emit(Code::PowInt, base, static_cast<int>(m))
                                             : emit(Code::Pow, base, constant(static_cast<double>(m))));
    return n < 0 ? emit(Code::Div, constant(1.0), p) : p;
  }
  // A product's numeric coefficient, if negative (for a − b instead of a + (−1)·b).
  static bool negative_coefficient(const GiNaC::ex& term) {
    if (GiNaC::is_a<GiNaC::numeric>(term)) return GiNaC::ex_to<GiNaC::numeric>(term).is_real() && GiNaC::ex_to<GiNaC::numeric>(term).is_negative();
    if (!GiNaC::is_a<GiNaC::mul>(term)) return false;
    for (std::size_t i = 0; i < term.nops(); ++i)
      if (GiNaC::is_a<GiNaC::numeric>(term.op(i)))
        return GiNaC::ex_to<GiNaC::numeric>(term.op(i)).is_real() && GiNaC::ex_to<GiNaC::numeric>(term.op(i)).is_negative();
    return false;
  }

  int compile(const GiNaC::ex& e) {
    using namespace GiNaC;
    if (is_a<numeric>(e) || is_a<GiNaC::constant>(e)) return constant(number(e));
    if (is_a<symbol>(e)) {
      const auto it = symbol_index_.find(ex_to<symbol>(e).get_name());
      if (it == symbol_index_.end()) {
        fail_("internal: symbol " + ex_to<symbol>(e).get_name() + " has no source");
        throw std::logic_error("unreachable");
      }
      return emit(Code::Load, it->second);
    }
    if (is_a<add>(e)) {
      int sum = -1;
      for (std::size_t i = 0; i < e.nops(); ++i) {
        const ex term = e.op(i);
        const bool negative = negative_coefficient(term);
        const int s = (*this)(negative ? ex(-term) : term);
        if (sum < 0)
          sum = negative ? emit(Code::Neg, s) : s;
        else
          sum = emit(negative ? Code::Sub : Code::Add, sum, s);
      }
      return sum;
    }
    if (is_a<mul>(e)) {
      double coefficient = 1;
      std::vector<int> numerator, denominator;
      for (std::size_t i = 0; i < e.nops(); ++i) {
        const ex f = e.op(i);
        if (is_a<numeric>(f)) {
          coefficient *= number(f);
        } else if (is_a<power>(f) && is_a<numeric>(f.op(1)) && ex_to<numeric>(f.op(1)).is_real() &&
                   ex_to<numeric>(f.op(1)).is_negative()) {
          denominator.push_back((*this)(pow(f.op(0), -f.op(1))));
        } else {
          numerator.push_back((*this)(f));
        }
      }
      int p = -1;
      if (coefficient != 1 && coefficient != -1) p = constant(coefficient);
      for (int n : numerator) p = p < 0 ? n : emit(Code::Mul, p, n);
      if (p < 0) p = constant(1.0);
      for (int d : denominator) p = emit(Code::Div, p, d);
      return coefficient == -1 ? emit(Code::Neg, p) : p;
    }
    if (is_a<power>(e)) {
      const ex base = e.op(0), exponent = e.op(1);
      if (is_a<numeric>(exponent)) {
        const numeric& n = ex_to<numeric>(exponent);
        long whole = 0;
        if (integral(n, whole)) return whole == 0 ? constant(1.0) : integer_power((*this)(base), whole);
        if (n.is_equal(numeric(1, 2))) return emit(Code::Sqrt, (*this)(base));
        if (n.is_equal(numeric(-1, 2))) return emit(Code::Div, constant(1.0), emit(Code::Sqrt, (*this)(base)));
        return emit(Code::Pow, (*this)(base), constant(number(n)));
      }
      return emit(Code::Pow, (*this)(base), (*this)(exponent));
    }
    if (is_a<function>(e)) {
      const unsigned serial = ex_to<function>(e).get_serial();
      const auto one = [&](Code c) { return emit(c, (*this)(e.op(0))); };
      if (serial == sin_SERIAL::serial) return one(Code::Sin);
      if (serial == cos_SERIAL::serial) return one(Code::Cos);
      if (serial == tan_SERIAL::serial) return one(Code::Tan);
      if (serial == asin_SERIAL::serial) return one(Code::Asin);
      if (serial == acos_SERIAL::serial) return one(Code::Acos);
      if (serial == atan_SERIAL::serial) return one(Code::Atan);
      if (serial == exp_SERIAL::serial) return one(Code::Exp);
      if (serial == log_SERIAL::serial) return one(Code::Log);
      if (serial == fx::kincal_abs_SERIAL::serial || serial == abs_SERIAL::serial) return one(Code::Abs);
      if (serial == fx::kincal_sign_SERIAL::serial || serial == csgn_SERIAL::serial) return one(Code::Sign);
      if (serial == atan2_SERIAL::serial) {
        const int y = (*this)(e.op(0));
        return emit(Code::Atan2, y, (*this)(e.op(1)));
      }
      fail_("the formula uses " + ex_to<function>(e).get_name() + ", which kincal cannot evaluate");
      throw std::logic_error("unreachable");
    }
    std::ostringstream text;
    text << e;
    fail_("internal: cannot compile the term " + text.str());
    throw std::logic_error("unreachable");
  }

  std::vector<Op>& ops_;
  const std::map<std::string, int>& symbol_index_;
  const std::function<void(const std::string&)>& fail_;
  std::map<GiNaC::ex, int, GiNaC::ex_is_less> memo_;
  std::map<std::uint64_t, int> constants_;
};

std::string range_name(const std::string& base, int n) { return base + "1.." + base + std::to_string(n); }

}  // namespace

// ---------------------------------------------------------------- construction

FormulaEffect::FormulaEffect(const FormulaEffectSpec& spec, const FormulaContext& context)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.spec = spec;
  const FormulaEffectSpec& s = m.spec;
  const int N = context.joint_count;
  if (N < 1 || N > 64) throw std::invalid_argument("FormulaContext::joint_count must be 1..64");
  const bool joint_kind = s.kind == FormulaKind::Joint;

  // Name of the effect: an identifier (it names a C++ function and appears in
  // `--effect NAME:PARAM=VALUE`), not a built-in effect's.
  if (!is_identifier(s.name))
    m.fail("name", "the name must be a letter or '_' followed by letters, digits or '_'");
  for (const auto& b : context.builtin_effects)
    if (s.name == b)
      m.fail("name", "the name clashes with the built-in effect " + in_quotes(b) + " (built-in: " + join(context.builtin_effects) + ")");

  // The variables, by name.
  std::vector<std::string> variables;  // for the "allowed" list
  std::map<std::string, SymbolSource> sources;
  // The inputs' slots: the robot's shared input list if the context gives
  // one (every effect of a machine reads one layout, as the controller
  // fills it), else this entry's own.
  const std::vector<std::string>& input_layout = context.input_layout.empty() ? s.inputs : context.input_layout;
  FormulaLayout lay{N, static_cast<int>(input_layout.size()), static_cast<int>(context.family_variables.size())};
  lay.input_capacity = context.max_inputs > 0 ? context.max_inputs : 0;
  lay.family_joint_count = static_cast<int>(context.family_joint_variables.size());
  m.layout = lay;
  std::set<std::string> reserved;  // every built-in variable name, whatever the kind
  for (const char* v : {"q", "dir", "load", "temp", "time", "pi"}) reserved.insert(v);
  for (const char* v : kPoseVariables) reserved.insert(v);
  for (int j = 1; j <= N; ++j)
    for (const char* b : {"q", "dir", "load"}) reserved.insert(b + std::to_string(j));
  for (const char* f : kFunctions) reserved.insert(f);
  for (const char* l : kParserLiterals) reserved.insert(l);

  if (joint_kind) {
    sources["q"] = {SymbolSource::ThisJoint, lay.q(1), "q"};
    sources["dir"] = {SymbolSource::ThisJoint, lay.dir(1), "dir"};
    sources["load"] = {SymbolSource::ThisJoint, lay.load(1), "load"};
    variables = {"q", range_name("q", N), "dir", range_name("dir", N), "load", range_name("load", N)};
  } else {
    variables = {range_name("q", N), range_name("dir", N), range_name("load", N)};
  }
  for (int j = 1; j <= N; ++j) {
    sources["q" + std::to_string(j)] = {SymbolSource::Var, lay.q(j), "q" + std::to_string(j)};
    sources["dir" + std::to_string(j)] = {SymbolSource::Var, lay.dir(j), "dir" + std::to_string(j)};
    sources["load" + std::to_string(j)] = {SymbolSource::Var, lay.load(j), "load" + std::to_string(j)};
  }
  sources["temp"] = {SymbolSource::Var, lay.temp(), "temp"};
  sources["time"] = {SymbolSource::Var, lay.time(), "time"};
  variables.insert(variables.end(), {"temp", "time"});
  if (!joint_kind)
    for (int c = 0; c < 6; ++c) {
      sources[kPoseVariables[c]] = {SymbolSource::Var, lay.pose(c), kPoseVariables[c]};
      variables.emplace_back(kPoseVariables[c]);
    }

  // Family variables, inputs, parameters: identifiers, distinct, none a built-in name.
  std::set<std::string> taken;
  for (std::size_t i = 0; i < context.family_variables.size(); ++i) {
    const std::string& v = context.family_variables[i];
    sources[v] = {SymbolSource::Var, lay.family(static_cast<int>(i)), v};
    variables.push_back(v);
    taken.insert(v);
  }
  for (std::size_t k = 0; k < context.family_joint_variables.size(); ++k) {
    const std::string& v = context.family_joint_variables[k];
    const int variable = static_cast<int>(k);
    if (joint_kind) {
      sources[v] = {SymbolSource::ThisJoint, lay.family_joint(variable, 1), v};
      variables.push_back(v);
    }
    variables.push_back(range_name(v, N));
    taken.insert(v);
    for (int j = 1; j <= N; ++j) {
      sources[v + std::to_string(j)] = {SymbolSource::Var, lay.family_joint(variable, j), v + std::to_string(j)};
      taken.insert(v + std::to_string(j));
    }
  }
  const auto check_name = [&](const std::string& key, const std::string& what, const std::string& n) {
    if (!is_identifier(n)) m.fail(key, what + " " + in_quotes(n) + " is not a name (a letter or '_', then letters, digits or '_')");
    if (reserved.count(n))
      m.fail(key, what + " " + in_quotes(n) + " clashes with a built-in variable or function of formulas");
    if (taken.count(n)) m.fail(key, what + " " + in_quotes(n) + " is used twice (or clashes with another name of the effect)");
    taken.insert(n);
  };
  for (std::size_t i = 0; i < s.inputs.size(); ++i) {
    check_name("inputs", "the input", s.inputs[i]);
    const auto at = std::find(input_layout.begin(), input_layout.end(), s.inputs[i]);
    if (at == input_layout.end()) m.fail("inputs", "the input " + in_quotes(s.inputs[i]) + " is not in the machine's input list");
    sources[s.inputs[i]] = {SymbolSource::Var, lay.input(static_cast<int>(at - input_layout.begin())), s.inputs[i]};
    variables.push_back(s.inputs[i]);
  }
  if (!joint_kind && !s.per_joint.empty())
    m.fail("per_joint", "a pose effect has no acting joint: its parameters are 'shared'");
  if (!joint_kind && !s.joints.empty()) m.fail("joints", "'joints' is for kind \"joint\" (a pose effect acts on the tool)");

  // Acting joints.
  if (joint_kind) {
    if (s.joints.empty()) {
      for (int j = 1; j <= N; ++j) m.joints.push_back(j);
    } else {
      std::set<int> seen;
      for (int j : s.joints) {
        if (j < 1 || j > N)
          m.fail("joints", "joint " + std::to_string(j) + " is out of range: joints are 1.." + std::to_string(N));
        if (!seen.insert(j).second) m.fail("joints", "joint " + std::to_string(j) + " is listed twice");
        m.joints.push_back(j);
      }
    }
  }
  const int J = static_cast<int>(m.joints.size());

  std::vector<std::string> parameter_symbols;  // bases then shared: what the formula names
  for (const auto& p : s.per_joint) {
    check_name("per_joint", "the per-joint parameter", p);
    if (std::isdigit(static_cast<unsigned char>(p.back())))
      m.fail("per_joint", "the per-joint parameter " + in_quotes(p) + " ends in a digit: its per-joint names (" + p + "1, …) would be ambiguous");
    sources[p] = {SymbolSource::PerJoint, m.bases++, p};
    parameter_symbols.push_back(p);
  }
  for (const auto& p : s.shared) {
    check_name("shared", "the shared parameter", p);
    sources[p] = {SymbolSource::Shared, m.shared++, p};
    parameter_symbols.push_back(p);
  }
  for (const auto& p : s.per_joint)
    for (int j : m.joints) m.parameter_names.push_back(p + std::to_string(j));
  for (const auto& p : s.shared) m.parameter_names.push_back(p);
  // A full per-joint name must not be another name of the effect (shared "a1" with per_joint "a").
  for (std::size_t i = 0; i < s.per_joint.size() * m.joints.size(); ++i)
    if (taken.count(m.parameter_names[i]))
      m.fail("per_joint", "the per-joint parameter " + in_quotes(m.parameter_names[i]) + " clashes with another name of the effect");
  if (m.parameter_names.empty()) m.fail("", "the effect has no parameter ('per_joint' and 'shared' are both empty)");

  // Start values: by full name, else by base name, else 0.
  for (const auto& [key, value] : s.start) {
    const bool known = std::find(m.parameter_names.begin(), m.parameter_names.end(), key) != m.parameter_names.end() ||
                       std::find(s.per_joint.begin(), s.per_joint.end(), key) != s.per_joint.end();
    if (!known) m.fail("start/" + key, "'start' names " + in_quotes(key) + ", which is no parameter (parameters: " + join(m.parameter_names) + ")");
    if (!std::isfinite(value)) m.fail("start/" + key, "the start value of " + in_quotes(key) + " is not finite");
  }
  for (int b = 0; b < m.bases; ++b)
    for (int k = 0; k < J; ++k) {
      const std::string& full = m.parameter_names[static_cast<std::size_t>(b * J + k)];
      auto it = s.start.find(full);
      if (it == s.start.end()) it = s.start.find(s.per_joint[static_cast<std::size_t>(b)]);
      m.start.push_back(it == s.start.end() ? 0.0 : it->second);
    }
  for (const auto& p : s.shared) {
    const auto it = s.start.find(p);
    m.start.push_back(it == s.start.end() ? 0.0 : it->second);
  }

  // The formulas.
  const std::size_t components = joint_kind ? 1 : 6;
  if (s.formulas.size() != components)
    m.fail("formula", joint_kind ? "a joint effect has one formula" : "a pose effect has six formulas (dx dy dz drx dry drz)");
  std::vector<std::string> allowed = parameter_symbols;
  allowed.insert(allowed.end(), variables.begin(), variables.end());
  allowed.emplace_back("pi");

  std::lock_guard<std::mutex> lock(ginac_mutex());
  GiNaC::symtab table;
  std::map<std::string, int> symbol_index;  // GiNaC symbol name → m.symbols index (assigned on use)
  std::map<std::string, GiNaC::realsymbol> ginac_symbols;
  for (const auto& entry : sources) {
    ginac_symbols.emplace(entry.first, GiNaC::realsymbol(entry.first));
    table[entry.first] = ginac_symbols.at(entry.first);
  }
  table["pi"] = GiNaC::Pi;

  std::vector<GiNaC::ex> parsed;
  for (std::size_t c = 0; c < components; ++c) {
    const std::string key = joint_kind ? "formula" : std::string("formula/") + kPoseComponents[c];
    const std::string& f = s.formulas[c];
    const std::string shown = "\"" + (f.size() > 80 ? f.substr(0, 77) + "..." : f) + "\"";
    const std::string label = joint_kind ? "formula " : std::string("formula ") + kPoseComponents[c] + " ";
    const auto fail_at = [&](std::size_t offset, const std::string& message) {
      m.fail(key, label + shown + ", character " + std::to_string(offset + 1) + ": " + message);
    };
    const FormulaText text = lex(f, [&](std::size_t offset, const std::string& message) {
      if (offset == std::string::npos)
        m.fail(key, label + shown + " " + message);
      fail_at(offset, message);
    });
    for (std::size_t k = 0; k < text.tokens.size(); ++k) {
      const Token& t = text.tokens[k];
      if (t.kind != Token::Identifier) continue;
      const bool call = k + 1 < text.tokens.size() && text.tokens[k + 1].kind == Token::Open;
      if (call && !is_function_name(t.text)) {
        if (sources.count(t.text) || t.text == "pi")
          fail_at(t.begin, in_quotes(t.text) + " is a variable, not a function");
        std::vector<std::string> fs(std::begin(kFunctions), std::end(kFunctions));
        fail_at(t.begin, "unknown function " + in_quotes(t.text) + " (functions: " + join(fs) + ")");
      }
      if (!call && is_function_name(t.text)) fail_at(t.begin, in_quotes(t.text) + " is a function: write " + t.text + "(…)");
      if (call) {
        // The arity, counted here: GiNaC's function table matches a call
        // with no argument to any arity ("tan()" reached tan's evaluation
        // with no argument and crashed, found by fuzzing).
        std::size_t arguments = text.tokens[k + 2 < text.tokens.size() ? k + 2 : k + 1].kind == Token::Close ? 0 : 1;
        int depth = 0;
        for (std::size_t i = k + 1; i < text.tokens.size(); ++i) {
          const Token::Kind kind_i = text.tokens[i].kind;
          if (kind_i == Token::Open) ++depth;
          if (kind_i == Token::Close && --depth == 0) break;
          if (kind_i == Token::Comma && depth == 1) ++arguments;
        }
        const std::size_t wanted = t.text == "atan2" || t.text == "min" || t.text == "max" ? 2 : 1;
        if (arguments != wanted)
          fail_at(t.begin, t.text + " takes " + std::to_string(wanted) + (wanted == 1 ? " argument" : " arguments") +
                               ", not " + std::to_string(arguments));
      }
      if (!call && !sources.count(t.text) && t.text != "pi")
        fail_at(t.begin, "unknown symbol " + in_quotes(t.text) + " (allowed: " + join(allowed) + ")");
    }
    const auto parse = [&](const std::string& prefix) { return GiNaC::parser(table, true, function_table())(prefix); };
    try {
      parsed.push_back(ours(parse(text.ginac)));
    } catch (const std::exception& whole) {
      // Where: the shortest token prefix that already fails for a reason
      // other than ending early ("got: EOF"). Parsing is left to right, so
      // failing is monotone in the prefix and a bisection finds it.
      const auto fails = [&](std::size_t k) {
        try {
          parse(text.ginac.substr(0, text.token_end[k]));
          return false;
        } catch (const std::exception& e) {
          return std::string(e.what()).find("EOF") == std::string::npos;
        }
      };
      std::size_t lo = 0, hi = text.tokens.size() - 1;
      // Only "ended early": the place is just after the last character.
      if (!fails(hi)) fail_at(f.size(), ginac_message(whole));
      while (lo < hi) {
        const std::size_t mid = lo + (hi - lo) / 2;
        if (fails(mid))
          hi = mid;
        else
          lo = mid + 1;
      }
      fail_at(text.tokens[hi].begin, ginac_message(whole));
    }
  }

  // Every parameter appears in some formula (after GiNaC's simplification:
  // "a*0" does not use a).
  for (const auto& p : parameter_symbols) {
    bool used = false;
    for (const auto& e : parsed) used = used || e.has(ginac_symbols.at(p));
    if (!used)
      m.fail(std::find(s.per_joint.begin(), s.per_joint.end(), p) != s.per_joint.end() ? "per_joint" : "shared",
             "the parameter " + in_quotes(p) + " is not used by the formula");
  }
  for (std::size_t i = 0; i < s.inputs.size(); ++i) {
    bool used = false;
    for (const auto& e : parsed) used = used || e.has(ginac_symbols.at(s.inputs[i]));
    m.input_used.push_back(used);
  }

  // Symbols the program loads: every one the formulas contain.
  for (const auto& entry : ginac_symbols) {
    bool used = false;
    for (const auto& e : parsed) used = used || e.has(entry.second);
    if (!used) continue;
    const SymbolSource& source = sources.at(entry.first);
    symbol_index[entry.first] = static_cast<int>(m.symbols.size());
    m.symbols.push_back(source);
    // What the node must provide, by where the number lives.
    if (source.kind == SymbolSource::ThisJoint || source.kind == SymbolSource::Var) {
      const int at = source.index;
      if (at == lay.temp()) m.temperature = true;
      if (at == lay.time()) m.time = true;
      if (at >= lay.dir(1) && at <= lay.dir(N)) m.direction = true;
      if (at >= lay.load(1) && at <= lay.load(N)) m.load = true;
      if (at >= lay.pose(0) && at <= lay.pose(5)) m.pose_variables = true;
      if (at >= lay.family(0) && at < lay.size()) m.family = true;
    }
  }

  // Compile: the values first (ops [0, value_ops) serve value() alone), then
  // every derivative, sharing common subexpressions with the values.
  std::string compile_key = joint_kind ? "formula" : "formula/dx";
  const std::function<void(const std::string&)> compile_fail = [&](const std::string& message) {
    m.fail(compile_key, message);
  };
  Compiler compile(m.ops, symbol_index, compile_fail);
  try {
    for (std::size_t c = 0; c < components; ++c) {
      compile_key = joint_kind ? "formula" : std::string("formula/") + kPoseComponents[c];
      m.value_slot.push_back(compile(parsed[c]));
    }
    m.value_ops = m.ops.size();
    for (std::size_t c = 0; c < components; ++c) {
      compile_key = joint_kind ? "formula" : std::string("formula/") + kPoseComponents[c];
      std::vector<int> slots;
      for (const auto& p : parameter_symbols) {
        const GiNaC::ex d = ours(parsed[c].diff(ginac_symbols.at(p)));
        slots.push_back(d.is_zero() ? -1 : compile(d));
      }
      m.derivative_slot.push_back(std::move(slots));
    }
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    // GiNaC's own refusals while differentiating or evaluating constants
    // (e.g. a pole of a constant subterm).
    m.fail(compile_key, "the formula cannot be differentiated: " + first_line(e.what()));
  }
}

FormulaEffect::~FormulaEffect() = default;
FormulaEffect::FormulaEffect(FormulaEffect&&) noexcept = default;
FormulaEffect& FormulaEffect::operator=(FormulaEffect&&) noexcept = default;

const FormulaEffectSpec& FormulaEffect::spec() const { return impl_->spec; }
const FormulaLayout& FormulaEffect::layout() const { return impl_->layout; }
const std::vector<int>& FormulaEffect::joints() const { return impl_->joints; }
const std::vector<std::string>& FormulaEffect::parameter_names() const { return impl_->parameter_names; }
std::vector<double> FormulaEffect::start_values() const { return impl_->start; }
int FormulaEffect::output_count() const { return impl_->outputs(); }
std::string FormulaEffect::output_name(int output) const {
  impl_->check_output(output);
  return kind() == FormulaKind::Joint ? "dq" + std::to_string(impl_->joints[static_cast<std::size_t>(output)])
                                      : kPoseComponents[output];
}
bool FormulaEffect::uses_temperature() const { return impl_->temperature; }
bool FormulaEffect::uses_time() const { return impl_->time; }
bool FormulaEffect::uses_direction() const { return impl_->direction; }
bool FormulaEffect::uses_load() const { return impl_->load; }
bool FormulaEffect::uses_pose() const { return impl_->pose_variables; }
bool FormulaEffect::uses_family() const { return impl_->family; }
bool FormulaEffect::uses_inputs() const {
  for (const bool used : impl_->input_used)
    if (used) return true;
  return false;
}
std::vector<std::string> FormulaEffect::required_columns() const {
  std::vector<std::string> out;
  if (impl_->temperature) out.emplace_back("temp");
  if (impl_->time) out.emplace_back("time");
  for (std::size_t i = 0; i < spec().inputs.size(); ++i)
    if (impl_->input_used[i]) out.push_back(spec().inputs[i]);
  return out;
}

// ---------------------------------------------------------------- evaluation

namespace {
// "nan", "inf", "-inf" or the number: glibc prints a NaN with its sign bit as "-nan".
std::string number_text(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}
FormulaWorkspace& local_workspace() {
  thread_local FormulaWorkspace ws;
  return ws;
}
}  // namespace

double FormulaEffect::value(int output, const double* vars, const double* params, FormulaWorkspace& ws) const {
  const Impl& m = *impl_;
  m.check_output(output);
  m.run(m.value_ops, m.joint_of(output), vars, params, ws);
  return ws.slots[static_cast<std::size_t>(m.value_slot[static_cast<std::size_t>(m.component_of(output))])];
}
double FormulaEffect::value(int output, const double* vars, const double* params) const {
  return value(output, vars, params, local_workspace());
}

void FormulaEffect::gradient(int output, const double* vars, const double* params, double* dparams,
                             FormulaWorkspace& ws) const {
  const Impl& m = *impl_;
  m.check_output(output);
  m.run(m.ops.size(), m.joint_of(output), vars, params, ws);
  m.scatter_gradient(output, ws, dparams);
}
void FormulaEffect::gradient(int output, const double* vars, const double* params, double* dparams) const {
  gradient(output, vars, params, dparams, local_workspace());
}

void FormulaEffect::evaluate(const double* vars, const double* params, double* values, double* jacobian,
                             const std::string& node, FormulaWorkspace& ws) const {
  const Impl& m = *impl_;
  const std::size_t P = m.parameter_names.size();
  for (int o = 0; o < m.outputs(); ++o) {
    // Joint kind runs the program once per acting joint; pose kind computes
    // all six components in one run (shared subexpressions), the first.
    const bool fresh = kind() == FormulaKind::Joint || o == 0;
    if (fresh) m.run(jacobian ? m.ops.size() : m.value_ops, m.joint_of(o), vars, params, ws);
    values[o] = ws.slots[static_cast<std::size_t>(m.value_slot[static_cast<std::size_t>(m.component_of(o))])];
    if (jacobian) m.scatter_gradient(o, ws, jacobian + static_cast<std::size_t>(o) * P);
    std::string bad;
    if (!std::isfinite(values[o])) {
      bad = output_name(o) + " = " + number_text(values[o]);
    } else if (jacobian) {
      for (std::size_t p = 0; p < P && bad.empty(); ++p)
        if (!std::isfinite(jacobian[static_cast<std::size_t>(o) * P + p]))
          bad = "d" + output_name(o) + "/d" + m.parameter_names[p] + " = " +
                number_text(jacobian[static_cast<std::size_t>(o) * P + p]);
    }
    if (bad.empty()) continue;
    // Name the numbers the formula read there.
    std::string read;
    for (const auto& s : m.symbols) {
      const double v = m.load_symbol(s, m.joint_of(o), vars, params);
      std::string label = s.name;
      if (s.kind == SymbolSource::PerJoint || s.kind == SymbolSource::ThisJoint)
        label += std::to_string(m.joints[static_cast<std::size_t>(m.joint_of(o))]);
      read += (read.empty() ? "" : ", ") + label + " = " + number_text(v);
    }
    const std::string& f = m.spec.formulas[static_cast<std::size_t>(m.component_of(o))];
    throw InputError("formula effect " + in_quotes(m.spec.name) + " is not finite at node " + node + ": " + bad +
                     " (formula \"" + (f.size() > 80 ? f.substr(0, 77) + "..." : f) + "\" with " + read + ")");
  }
}

// ---------------------------------------------------------------- C++

std::string FormulaEffect::cpp_function_name() const { return "kincal_formula_" + name(); }

std::string FormulaEffect::cpp_function(const std::string& function_name) const {
  const Impl& m = *impl_;
  const bool joint_kind = kind() == FormulaKind::Joint;
  const int J = static_cast<int>(m.joints.size());
  const auto slot = [](int i) { return "t" + std::to_string(i); };
  std::ostringstream o;
  o << "// Formula effect '" << name() << "'" << (m.spec.description.empty() ? "" : ": " + one_line(m.spec.description))
    << "\n";
  if (joint_kind) {
    o << "// dq_i = " << one_line(m.spec.formulas[0]) << "  for joints";
    for (int j : m.joints) o << " " << j;
    o << "\n";
  } else {
    for (int c = 0; c < 6; ++c) o << "// " << kPoseComponents[c] << " = " << one_line(m.spec.formulas[static_cast<std::size_t>(c)]) << "\n";
  }
  o << "// params: " << join(m.parameter_names) << "\n";
  o << "// vars: q1..q" << m.layout.joints << ", dir1.., load1.., temp, time, x, y, z, rx, ry, rz";
  for (const auto& i : m.spec.inputs) o << ", " << i;
  o << "\n";
  o << "template <class Scalar>\n"
    << "void " << function_name << "(const Scalar* params, const Scalar* vars, Scalar* out) {\n"
    << "  using std::abs; using std::acos; using std::asin; using std::atan; using std::atan2; using std::cos;\n"
    << "  using std::exp; using std::log; using std::pow; using std::sin; using std::sqrt; using std::tan;\n";
  std::string indent = "  ";
  if (joint_kind) {
    o << "  static constexpr int kJoints[" << J << "] = {";
    for (int k = 0; k < J; ++k) o << (k ? ", " : "") << m.joints[static_cast<std::size_t>(k)];
    o << "};\n  for (int k = 0; k < " << J << "; ++k) {\n    const int j = kJoints[k] - 1;\n    (void)j;\n";
    indent = "    ";
  }
  for (std::size_t i = 0; i < m.value_ops; ++i) {
    const Op& op = m.ops[i];
    const std::string a = slot(op.a), b = slot(op.b);
    std::string e;
    switch (op.code) {
      case Code::Const: {
        char buf[40];
        std::snprintf(buf, sizeof buf, "%.17g", op.c);
        e = std::string("Scalar(") + buf + ")";
        break;
      }
      case Code::Load: {
        const SymbolSource& s = m.symbols[static_cast<std::size_t>(op.a)];
        switch (s.kind) {
          case SymbolSource::PerJoint: e = "params[" + std::to_string(s.index * J) + " + k]"; break;
          case SymbolSource::Shared: e = "params[" + std::to_string(m.bases * J + s.index) + "]"; break;
          case SymbolSource::ThisJoint: e = "vars[" + std::to_string(s.index) + " + j]"; break;
          case SymbolSource::Var: e = "vars[" + std::to_string(s.index) + "]"; break;
        }
        e += ";  // " + s.name;
        break;
      }
      case Code::Add: e = a + " + " + b; break;
      case Code::Sub: e = a + " - " + b; break;
      case Code::Mul: e = a + " * " + b; break;
      case Code::Div: e = a + " / " + b; break;
      case Code::Neg: e = "-" + a; break;
      case Code::PowInt:
        e = a;
        for (int n = 1; n < op.b; ++n) e += " * " + a;
        break;
      case Code::Pow: e = "pow(" + a + ", " + b + ")"; break;
      case Code::Sqrt: e = "sqrt(" + a + ")"; break;
      case Code::Sin: e = "sin(" + a + ")"; break;
      case Code::Cos: e = "cos(" + a + ")"; break;
      case Code::Tan: e = "tan(" + a + ")"; break;
      case Code::Asin: e = "asin(" + a + ")"; break;
      case Code::Acos: e = "acos(" + a + ")"; break;
      case Code::Atan: e = "atan(" + a + ")"; break;
      case Code::Atan2: e = "atan2(" + a + ", " + b + ")"; break;
      case Code::Exp: e = "exp(" + a + ")"; break;
      case Code::Log: e = "log(" + a + ")"; break;
      case Code::Abs: e = "abs(" + a + ")"; break;
      case Code::Sign:
        e = "(" + a + " > Scalar(0) ? Scalar(1) : (" + a + " < Scalar(0) ? Scalar(-1) : " + a + " * Scalar(0)))";
        break;
    }
    if (op.code != Code::Load) e += ";";
    o << indent << "const Scalar " << slot(static_cast<int>(i)) << " = " << e << "\n";
  }
  if (joint_kind) {
    o << "    out[k] = " << slot(m.value_slot[0]) << ";\n  }\n";
  } else {
    for (int c = 0; c < 6; ++c) o << "  out[" << c << "] = " << slot(m.value_slot[static_cast<std::size_t>(c)]) << ";\n";
  }
  o << "}\n";
  return o.str();
}

// ---------------------------------------------------------------- JSON

std::vector<FormulaEffect> read_formula_effects(const std::string& text, const std::string& file,
                                                const FormulaContext& context) {
  const nlohmann::json doc = detail::parse_json_text(text, file);
  if (!doc.is_object() || !doc.contains("effects")) return {};
  const detail::DescriptionReader r(text, file);
  r.check_duplicates();
  const detail::JsonLocations loc = detail::locate_json(text);
  const auto where_of = [&](std::size_t offset) {
    const TextPosition p = position_of(text, offset);
    return FormulaWhere{p.line, p.column};
  };
  const nlohmann::json& list = doc["effects"];
  if (!list.is_array()) r.fail("/effects", "'effects' must be an array of effect objects, not " + std::string(detail::type_name(list)));

  std::vector<FormulaEffectSpec> specs;
  std::map<std::string, std::string> seen;  // name → its path
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string path = detail::child_path("/effects", i);
    const nlohmann::json& e = r.object(list[i], path, {"name", "kind", "formula"},
                                       {"description", "joints", "per_joint", "shared", "start", "inputs"});
    FormulaEffectSpec spec;
    spec.file = file;
    spec.where[""] = where_of(loc.value_offset(path));
    for (auto it = e.begin(); it != e.end(); ++it) spec.where[it.key()] = where_of(loc.key_offset(detail::child_path(path, it.key())));
    const auto key = [&](const char* k) { return detail::child_path(path, k); };
    spec.name = r.string(e["name"], key("name"));
    if (e.contains("description")) spec.description = r.string(e["description"], key("description"));
    const std::string kind = r.string(e["kind"], key("kind"));
    if (kind == "joint")
      spec.kind = FormulaKind::Joint;
    else if (kind == "pose")
      spec.kind = FormulaKind::Pose;
    else
      r.fail(key("kind"), "'kind' must be \"joint\" or \"pose\", not \"" + kind + "\"");
    const auto strings = [&](const char* k) {
      std::vector<std::string> v;
      if (!e.contains(k)) return v;
      const nlohmann::json& a = e[k];
      if (!a.is_array()) r.fail(key(k), detail::display(key(k)) + " must be an array of names, not " + detail::type_name(a));
      for (std::size_t n = 0; n < a.size(); ++n) v.push_back(r.string(a[n], detail::child_path(key(k), n)));
      return v;
    };
    spec.per_joint = strings("per_joint");
    spec.shared = strings("shared");
    spec.inputs = strings("inputs");
    if (e.contains("joints")) {
      const nlohmann::json& a = e["joints"];
      if (!a.is_array() || a.empty())
        r.fail(key("joints"), "'joints' must be a non-empty array of joint numbers (1-based)");
      for (std::size_t n = 0; n < a.size(); ++n) {
        if (!a[n].is_number_integer() || std::abs(a[n].get<long long>()) > 1000000)
          r.fail(detail::child_path(key("joints"), n), "'joints' entries must be whole joint numbers (1-based)");
        spec.joints.push_back(static_cast<int>(a[n].get<long long>()));
      }
    }
    if (e.contains("start")) {
      const nlohmann::json& s = e["start"];
      if (!s.is_object()) r.fail(key("start"), "'start' must be an object {\"name\": value}, not " + std::string(detail::type_name(s)));
      for (auto it = s.begin(); it != s.end(); ++it) {
        const std::string p = detail::child_path(key("start"), it.key());
        spec.start[it.key()] = r.number(it.value(), p);
        spec.where["start/" + it.key()] = where_of(loc.key_offset(p));
      }
    }
    const nlohmann::json& f = e["formula"];
    if (spec.kind == FormulaKind::Joint) {
      if (!f.is_string()) r.fail(key("formula"), "a joint effect's 'formula' must be a string, not " + std::string(detail::type_name(f)));
      spec.formulas.push_back(f.get<std::string>());
    } else {
      r.object(f, key("formula"), {}, {"dx", "dy", "dz", "drx", "dry", "drz"});
      if (f.empty()) r.fail(key("formula"), "a pose effect's 'formula' needs at least one of dx dy dz drx dry drz");
      for (const char* c : kPoseComponents) {
        const std::string p = detail::child_path(key("formula"), c);
        spec.formulas.push_back(f.contains(c) ? r.string(f[c], p) : "0");
        spec.where[std::string("formula/") + c] = where_of(f.contains(c) ? loc.key_offset(p) : loc.key_offset(key("formula")));
      }
    }
    const auto previous = seen.find(spec.name);
    if (previous != seen.end())
      r.fail(key("name"), "two effects are named '" + spec.name + "' (the other is " + detail::display(previous->second) + ")");
    seen.emplace(spec.name, path);
    specs.push_back(std::move(spec));
  }
  // One input layout for the machine: every entry's inputs, in order of
  // first appearance (the NC stream and the measurement columns carry them
  // once, whichever effects read them).
  FormulaContext shared = context;
  if (shared.input_layout.empty())
    for (const auto& spec : specs)
      for (const auto& in : spec.inputs)
        if (std::find(shared.input_layout.begin(), shared.input_layout.end(), in) == shared.input_layout.end())
          shared.input_layout.push_back(in);
  if (shared.max_inputs >= 0 && static_cast<int>(shared.input_layout.size()) > shared.max_inputs)
    r.fail("/effects", "the effects read " + std::to_string(shared.input_layout.size()) +
                           " named inputs; a machine may have at most " + std::to_string(shared.max_inputs));
  std::vector<FormulaEffect> out;
  for (const auto& spec : specs) out.emplace_back(spec, shared);
  return out;
}

}  // namespace kincal::identify
