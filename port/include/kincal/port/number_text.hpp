// Decimal text <-> double without the heap, for the CSV streams of the
// bare-metal backend. newlib's strtod allocates big integers (_Balloc ->
// malloc), and its printf has no floating point in newlib-nano, so neither
// links into a no-heap firmware image (docs/firmware.md "No heap").
//
// Accuracy, which is what the end-to-end check (firmware = host to 1e-9 mm)
// rests on:
//   parse: correctly rounded when the significand has at most 19 digits, is
//     at most 2^53 and the decimal exponent is within ±22 (Clinger's fast
//     path: one exact integer times or over one exact power of ten, rounded
//     once) — every number `kincal` writes with up to 15-16 significant digits
//     and every hand-written pose. Otherwise within a few ulps.
//   format: fixed point with (up to) 12 decimals, trailing zeros dropped
//     (|v| < 1e9): error ≤ 0.5e-12 plus one rounding, i.e. ≤ 1e-12 mm / rad
//     where the double itself resolves that (|v| < 2^13); larger values in scientific form
//     with 15 significant digits.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

namespace kincal::port {

namespace detail {

// 10^k for k = 0..22: all exactly representable in double.
constexpr double kPow10[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                               1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

inline char lower(char c) { return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c; }

inline bool equals_nocase(const char* b, const char* e, const char* word) {
  for (; b != e && *word != '\0'; ++b, ++word)
    if (lower(*b) != *word) return false;
  return b == e && *word == '\0';
}

// x · 10^e for an exponent outside the exact table.
inline double scale10(double x, int e) {
  while (e > 22) {
    x *= 1e22;
    e -= 22;
  }
  while (e < -22) {
    x /= 1e22;
    e += 22;
  }
  return e >= 0 ? x * kPow10[e] : x / kPow10[-e];
}

}  // namespace detail

// Parses [begin, end) completely (surrounding blanks allowed): an optional
// sign, digits with an optional '.', an optional exponent; also "nan", "inf"
// and "infinity" (any case), which give NaN / ±Inf: the stream passes them on
// and the controller rejects the point with a status. Returns false for
// anything else (empty field, stray characters).
inline bool parse_decimal(const char* begin, const char* end, double& out) {
  while (begin != end && (*begin == ' ' || *begin == '\t')) ++begin;
  while (end != begin && (end[-1] == ' ' || end[-1] == '\t' || end[-1] == '\r')) --end;
  if (begin == end) return false;
  bool negative = false;
  if (*begin == '+' || *begin == '-') {
    negative = *begin == '-';
    ++begin;
  }
  if (detail::equals_nocase(begin, end, "nan")) {
    out = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  if (detail::equals_nocase(begin, end, "inf") || detail::equals_nocase(begin, end, "infinity")) {
    out = negative ? -std::numeric_limits<double>::infinity() : std::numeric_limits<double>::infinity();
    return true;
  }
  std::uint64_t mantissa = 0;
  int digits = 0;         // significant digits kept in `mantissa`
  int exponent10 = 0;     // decimal exponent of the last kept digit
  bool any_digit = false;
  bool seen_point = false;
  const char* p = begin;
  for (; p != end; ++p) {
    const char c = *p;
    if (c == '.') {
      if (seen_point) return false;
      seen_point = true;
      continue;
    }
    if (c < '0' || c > '9') break;
    any_digit = true;
    if (mantissa == 0 && c == '0') {
      if (seen_point) --exponent10;  // leading zeros after the point only shift
      continue;
    }
    if (digits < 19) {
      mantissa = mantissa * 10u + static_cast<std::uint64_t>(c - '0');
      ++digits;
      if (seen_point) --exponent10;
    } else if (!seen_point) {
      ++exponent10;  // dropped integer digit (beyond 19): only its magnitude counts
    }
  }
  if (!any_digit) return false;
  if (p != end) {
    if (*p != 'e' && *p != 'E') return false;
    ++p;
    bool negative_exponent = false;
    if (p != end && (*p == '+' || *p == '-')) {
      negative_exponent = *p == '-';
      ++p;
    }
    if (p == end) return false;
    int e = 0;
    for (; p != end; ++p) {
      if (*p < '0' || *p > '9') return false;
      if (e < 100000) e = e * 10 + (*p - '0');
    }
    exponent10 += negative_exponent ? -e : e;
  }
  // The significand as a double through two 32-bit halves: exact up to 2^53,
  // and on a Cortex-M it is two VFP conversions, where a 64-bit conversion
  // would pull in libgcc's software double arithmetic.
  const double m = static_cast<double>(static_cast<std::uint32_t>(mantissa >> 32)) * 4294967296.0 +
                   static_cast<double>(static_cast<std::uint32_t>(mantissa & 0xFFFFFFFFu));
  double value;
  if (mantissa == 0) {
    value = 0.0;
  } else if (mantissa <= (std::uint64_t(1) << 53) && exponent10 >= -22 && exponent10 <= 22) {
    // Clinger's fast path: both operands exact, one rounding.
    value = exponent10 >= 0 ? m * detail::kPow10[exponent10] : m / detail::kPow10[-exponent10];
  } else {
    value = detail::scale10(m, exponent10);
  }
  out = negative ? -value : value;
  return true;
}

// Writes v into buf (no terminating NUL); returns the number of characters,
// at most 32. buf must have room for 32. Only 32-bit integer arithmetic (no
// 64-bit division, no log10: each would add kilobytes of library code to a
// firmware image).
inline std::size_t format_decimal(double v, char* buf) {
  std::size_t n = 0;
  auto put = [&](char c) { buf[n++] = c; };
  // Exactly `digits` decimal digits of x < 10^digits (zero-padded).
  auto put_digits = [&](std::uint32_t x, int digits) {
    for (int k = digits - 1; k >= 0; --k) {
      buf[n + static_cast<std::size_t>(k)] = static_cast<char>('0' + static_cast<int>(x % 10u));
      x /= 10u;
    }
    n += static_cast<std::size_t>(digits);
  };
  auto put_uint = [&](std::uint32_t x) {
    int digits = 1;
    for (std::uint32_t t = x; t >= 10u; t /= 10u) ++digits;
    put_digits(x, digits);
  };
  if (v != v) {
    put('n'), put('a'), put('n');
    return n;
  }
  if (std::signbit(v)) put('-');
  const double a = std::fabs(v);
  if (a == std::numeric_limits<double>::infinity()) {
    put('i'), put('n'), put('f');
    return n;
  }
  if (a < 1e9) {
    // Fixed point, 12 decimals: the integer and the fractional part are both
    // exact in double, the fraction times 10^12 is rounded once; its two
    // 6-digit halves are exact too (integers below 2^53).
    double ip = std::floor(a);
    double fraction = std::nearbyint((a - ip) * 1e12);
    if (fraction >= 1e12) {
      fraction -= 1e12;
      ip += 1.0;
    }
    const double high = std::floor(fraction / 1e6);
    put_uint(static_cast<std::uint32_t>(ip));
    put('.');
    put_digits(static_cast<std::uint32_t>(high), 6);
    put_digits(static_cast<std::uint32_t>(fraction - high * 1e6), 6);
    // Trailing zeros say nothing, and without them our own parser reads the
    // text back on its exact path more often (fewer significant digits).
    while (buf[n - 1] == '0' && buf[n - 2] != '.') --n;
    return n;
  }
  // Scientific, 15 significant digits (an integer below 2^53, so exact in
  // double): d.dddddddddddddde±XXX. Joint commands and poses never get here.
  int e = 0;
  double scaled = a;
  while (scaled >= 1e15) {
    scaled /= 10.0;
    ++e;
  }
  while (scaled < 1e14) {
    scaled *= 10.0;
    --e;
  }
  scaled = detail::scale10(a, -e);  // one rounding from a, not a chain of them
  double m = std::nearbyint(scaled);
  if (m >= 1e15) {
    ++e;
    m = std::nearbyint(detail::scale10(a, -e));
  }
  e += 14;  // the exponent of the leading digit
  const double high = std::floor(m / 1e7);
  char digits[15];
  {
    std::uint32_t hi = static_cast<std::uint32_t>(high), lo = static_cast<std::uint32_t>(m - high * 1e7);
    for (int k = 14; k >= 8; --k, lo /= 10u) digits[k] = static_cast<char>('0' + static_cast<int>(lo % 10u));
    for (int k = 7; k >= 0; --k, hi /= 10u) digits[k] = static_cast<char>('0' + static_cast<int>(hi % 10u));
  }
  put(digits[0]);
  put('.');
  for (int k = 1; k < 15; ++k) put(digits[k]);
  put('e');
  put(e < 0 ? '-' : '+');
  const std::uint32_t ae = static_cast<std::uint32_t>(e < 0 ? -e : e);
  put_digits(ae, ae >= 100u ? 3 : 2);
  return n;
}

}  // namespace kincal::port
