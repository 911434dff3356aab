// Allocation-free CSV for the NC stream of the bare-metal backend: poses in
// (the GUIDE's poses-file columns), joint commands out (the JOINTS.csv shape
// `kincal compensate` writes, so host tools read the firmware's output).
// Independent of any I/O: the backend hands in lines and takes out text, and
// the host tests drive the same code with strings.
//
// In:  a header row, then one row per point; '#' lines and blank lines are
//      skipped; a UTF-8 BOM is skipped. Columns by name, any order:
//        x, y, z, rx, ry, rz   required
//        id                    optional, echoed to the output (≤ 31 chars kept)
//        seq                   optional sequence number; default: 1, 2, 3, …
//                              in row order
//        temp                  optional structure temperature, °C
//      other columns are ignored. A row that cannot be parsed still becomes
//      a point (valid = false) with its sequence number, so the controller
//      answers it with a status instead of losing it.
// Out: id,x,y,z,rx,ry,rz,q1,…,q6,status,seq,flags
#pragma once

#include <cstddef>
#include <cstdint>

#include "kincal/port/nc_stream.hpp"
#include "kincal/port/number_text.hpp"

namespace kincal::port {

constexpr std::size_t kCsvIdCapacity = 32;   // id text incl. NUL
constexpr std::size_t kCsvMaxFields = 64;    // columns of an input row
constexpr std::size_t kCsvLineCapacity = 512;  // longest output line (≤ 423 B: see format())

struct CsvId {
  char text[kCsvIdCapacity] = {};
  std::size_t size = 0;
};

// One input row split into fields, in place: quotes removed, "" -> ".
// Returns the number of fields, or -1 for a malformed quoted field.
inline int csv_split(char* line, std::size_t size, char* (&begin)[kCsvMaxFields], char* (&end)[kCsvMaxFields]) {
  int n = 0;
  std::size_t i = 0;
  for (;;) {
    if (n == static_cast<int>(kCsvMaxFields)) return -1;
    while (i < size && (line[i] == ' ' || line[i] == '\t')) ++i;
    if (i < size && line[i] == '"') {
      ++i;
      char* out = line + i;
      begin[n] = out;
      for (;;) {
        if (i >= size) return -1;  // unterminated
        if (line[i] == '"') {
          if (i + 1 < size && line[i + 1] == '"') {
            *out++ = '"';
            i += 2;
            continue;
          }
          ++i;
          break;
        }
        *out++ = line[i++];
      }
      end[n] = out;
      while (i < size && (line[i] == ' ' || line[i] == '\t')) ++i;
      if (i < size && line[i] != ',') return -1;
    } else {
      begin[n] = line + i;
      while (i < size && line[i] != ',') ++i;
      char* e = line + i;
      while (e != begin[n] && (e[-1] == ' ' || e[-1] == '\t' || e[-1] == '\r')) --e;
      end[n] = e;
    }
    ++n;
    if (i >= size) return n;
    ++i;  // the comma
  }
}

template <class Scalar> class PoseCsvReader {
 public:
  enum class LineResult : std::uint8_t {
    Skipped,      // comment, blank line or the header: nothing to deliver
    Point,        // `point` (and `id`) written; point.valid says whether it parsed
    BadHeader,    // the header lacks a required column (or has too many / a bad quote)
  };

  // `line` (without its line end) may be modified (fields are unquoted in place).
  LineResult feed(char* line, std::size_t size, NcInput<Scalar>& point, CsvId& id) {
    if (!bom_checked_) {
      bom_checked_ = true;
      if (size >= 3 && static_cast<unsigned char>(line[0]) == 0xEF && static_cast<unsigned char>(line[1]) == 0xBB &&
          static_cast<unsigned char>(line[2]) == 0xBF) {
        line += 3;
        size -= 3;
      }
    }
    while (size > 0 && (line[size - 1] == '\r')) --size;
    std::size_t first = 0;
    while (first < size && (line[first] == ' ' || line[first] == '\t')) ++first;
    if (first == size || line[0] == '#') return LineResult::Skipped;
    char* b[kCsvMaxFields];
    char* e[kCsvMaxFields];
    const int n = csv_split(line, size, b, e);
    if (!have_header_) return read_header(n, b, e);

    ++rows_;
    point = NcInput<Scalar>();
    id = CsvId();
    point.sequence = rows_;  // default; replaced by a seq column
    bool ok = n == fields_;
    if (id_col_ >= 0 && id_col_ < n) {
      const std::size_t len = static_cast<std::size_t>(e[id_col_] - b[id_col_]);
      id.size = len < kCsvIdCapacity - 1 ? len : kCsvIdCapacity - 1;
      for (std::size_t k = 0; k < id.size; ++k) id.text[k] = b[id_col_][k];
    }
    if (seq_col_ >= 0) {
      double s = 0;
      if (seq_col_ < n && parse_decimal(b[seq_col_], e[seq_col_], s) && s >= 0 && s < 4294967296.0 &&
          s == static_cast<double>(static_cast<std::uint32_t>(s))) {
        point.sequence = static_cast<std::uint32_t>(s);
      } else {
        ok = false;
        point.sequence = last_sequence_ + 1;  // keep the count going
      }
    }
    last_sequence_ = point.sequence;
    for (int k = 0; k < 6; ++k) {
      double v = 0;
      if (pose_col_[k] < n && parse_decimal(b[pose_col_[k]], e[pose_col_[k]], v)) {
        point.pose(k) = Scalar(v);
      } else {
        ok = false;
        point.pose(k) = Scalar(0);
      }
    }
    if (temp_col_ >= 0) {
      double t = 0;
      if (temp_col_ < n && parse_decimal(b[temp_col_], e[temp_col_], t)) {
        point.temperature = Scalar(t);
        point.has_temperature = true;
      } else {
        ok = false;
      }
    }
    point.valid = ok;
    return LineResult::Point;
  }

  // A row the backend could not even split (too long for its line buffer):
  // still a point, flagged, with the next sequence number.
  void malformed_row(NcInput<Scalar>& point, CsvId& id) {
    ++rows_;
    point = NcInput<Scalar>();
    id = CsvId();
    point.sequence = seq_col_ >= 0 ? last_sequence_ + 1 : rows_;
    last_sequence_ = point.sequence;
    point.valid = false;
  }

  bool have_header() const { return have_header_; }
  std::uint32_t rows() const { return rows_; }

 private:
  static bool is(const char* b, const char* e, const char* name) {
    for (; b != e && *name != '\0'; ++b, ++name)
      if (*b != *name) return false;
    return b == e && *name == '\0';
  }

  LineResult read_header(int n, char* const* b, char* const* e) {
    if (n < 0) return LineResult::BadHeader;
    static constexpr const char* kPose[6] = {"x", "y", "z", "rx", "ry", "rz"};
    for (int k = 0; k < 6; ++k) pose_col_[k] = -1;
    for (int c = 0; c < n; ++c) {
      for (int k = 0; k < 6; ++k)
        if (is(b[c], e[c], kPose[k])) pose_col_[k] = c;
      if (is(b[c], e[c], "id")) id_col_ = c;
      if (is(b[c], e[c], "seq")) seq_col_ = c;
      if (is(b[c], e[c], "temp")) temp_col_ = c;
    }
    for (int k = 0; k < 6; ++k)
      if (pose_col_[k] < 0) return LineResult::BadHeader;
    fields_ = n;
    have_header_ = true;
    return LineResult::Skipped;
  }

  bool bom_checked_ = false;
  bool have_header_ = false;
  int fields_ = 0;
  int pose_col_[6] = {-1, -1, -1, -1, -1, -1};
  int id_col_ = -1, seq_col_ = -1, temp_col_ = -1;
  std::uint32_t rows_ = 0;
  std::uint32_t last_sequence_ = 0;
};

// Text of the CommandFlag bits, '|'-separated ("" for none).
inline std::size_t format_command_flags(std::uint8_t flags, char* buf) {
  static constexpr const char* kNames[4] = {"held", "nominal", "gap", "overrun"};
  std::size_t n = 0;
  for (int k = 0; k < 4; ++k) {
    if ((flags & (1u << k)) == 0) continue;
    if (n > 0) buf[n++] = '|';
    for (const char* s = kNames[k]; *s != '\0'; ++s) buf[n++] = *s;
  }
  return n;
}

class JointCsvWriter {
 public:
  static constexpr const char* header() { return "id,x,y,z,rx,ry,rz,q1,q2,q3,q4,q5,q6,status,seq,flags\n"; }

  // One output row into `buf` (room for kCsvLineCapacity); returns its length.
  // `pose` is echoed as the point's commanded pose; `q` is the joint command
  // in the frame the file documents (see the backend).
  template <class Scalar>
  static std::size_t format(char* buf, const CsvId& id, const NcInput<Scalar>& point, const Vec6<Scalar>& q,
                            const char* status, std::uint8_t flags) {
    std::size_t n = 0;
    const bool quote = needs_quotes(id);
    if (quote) buf[n++] = '"';
    for (std::size_t k = 0; k < id.size; ++k) {
      if (id.text[k] == '"') buf[n++] = '"';
      buf[n++] = id.text[k];
    }
    if (quote) buf[n++] = '"';
    for (int k = 0; k < 6; ++k) {
      buf[n++] = ',';
      n += format_decimal(static_cast<double>(point.pose(k)), buf + n);
    }
    for (int k = 0; k < 6; ++k) {
      buf[n++] = ',';
      n += format_decimal(static_cast<double>(q(k)), buf + n);
    }
    buf[n++] = ',';
    for (const char* s = status; *s != '\0'; ++s) buf[n++] = *s;
    buf[n++] = ',';
    n += format_uint(point.sequence, buf + n);
    buf[n++] = ',';
    n += format_command_flags(flags, buf + n);
    buf[n++] = '\n';
    return n;
  }

  static std::size_t format_uint(std::uint32_t v, char* buf) {
    char tmp[10];
    int k = 0;
    do {
      tmp[k++] = static_cast<char>('0' + static_cast<int>(v % 10u));
      v /= 10u;
    } while (v != 0u);
    std::size_t n = 0;
    while (k > 0) buf[n++] = tmp[--k];
    return n;
  }

 private:
  static bool needs_quotes(const CsvId& id) {
    for (std::size_t k = 0; k < id.size; ++k)
      if (id.text[k] == ',' || id.text[k] == '"' || id.text[k] == ' ') return true;
    return false;
  }
};

}  // namespace kincal::port
