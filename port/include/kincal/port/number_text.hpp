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
//   format: fixed point with 12 decimals (|v| < 1e9): error ≤ 0.5e-12 plus
//     one rounding, i.e. ≤ 1e-12 mm / rad; larger values in scientific form
//     with 16 decimals.
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
  double value;
  if (mantissa == 0) {
    value = 0.0;
  } else if (mantissa <= (std::uint64_t(1) << 53) && exponent10 >= -22 && exponent10 <= 22) {
    // Clinger's fast path: both operands exact, one rounding.
    const double m = static_cast<double>(mantissa);
    value = exponent10 >= 0 ? m * detail::kPow10[exponent10] : m / detail::kPow10[-exponent10];
  } else {
    value = detail::scale10(static_cast<double>(mantissa), exponent10);
  }
  out = negative ? -value : value;
  return true;
}

// Writes v into buf (no terminating NUL); returns the number of characters,
// at most 32. buf must have room for 32.
inline std::size_t format_decimal(double v, char* buf) {
  std::size_t n = 0;
  auto put = [&](char c) { buf[n++] = c; };
  auto put_uint = [&](std::uint64_t x, int min_digits) {
    char tmp[20];
    int k = 0;
    do {
      tmp[k++] = static_cast<char>('0' + static_cast<int>(x % 10u));
      x /= 10u;
    } while (x != 0u || k < min_digits);
    while (k > 0) put(tmp[--k]);
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
    // exact in double, the fraction times 10^12 is rounded once.
    double ip = std::floor(a);
    double fraction = std::nearbyint((a - ip) * 1e12);
    if (fraction >= 1e12) {
      fraction -= 1e12;
      ip += 1.0;
    }
    put_uint(static_cast<std::uint64_t>(ip), 1);
    put('.');
    put_uint(static_cast<std::uint64_t>(fraction), 12);
    return n;
  }
  // Scientific, 17 significant digits: d.dddddddddddddddde±XXX.
  int e = static_cast<int>(std::floor(std::log10(a)));
  double scaled = detail::scale10(a, 16 - e);
  if (scaled >= 1e17) {
    ++e;
    scaled = detail::scale10(a, 16 - e);
  }
  std::uint64_t m = static_cast<std::uint64_t>(std::nearbyint(scaled));
  if (m >= 100000000000000000ull) {  // rounding carried into an 18th digit
    m /= 10u;
    ++e;
  }
  char digits[17];
  for (int k = 16; k >= 0; --k) {
    digits[k] = static_cast<char>('0' + static_cast<int>(m % 10u));
    m /= 10u;
  }
  put(digits[0]);
  put('.');
  for (int k = 1; k < 17; ++k) put(digits[k]);
  put('e');
  put(e < 0 ? '-' : '+');
  put_uint(static_cast<std::uint64_t>(e < 0 ? -e : e), 2);
  return n;
}

}  // namespace kincal::port
