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
//        time                  optional time stamp, s (formula effects)
//        the machine's named   required when set_inputs() named them (the
//        formula inputs        generated header's kFormulaInputNames)
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
constexpr std::size_t kCsvLineCapacity = 512;  // longest output line (≤ 423 B: see format())

struct CsvId {
  char text[kCsvIdCapacity] = {};
  std::size_t size = 0;
};

// The fields of one input row, one at a time, unquoted in place ("" -> ");
// no array of fields, so a row of any width costs a few words of stack.
class CsvFieldCursor {
 public:
  CsvFieldCursor(char* line, std::size_t size) : line_(line), size_(size) {}

  // The next field as [begin, end); false when the row has no more fields
  // or a quoted field is malformed (then bad() is true).
  bool next(char*& begin, char*& end) {
    if (done_) return false;
    std::size_t i = pos_;
    while (i < size_ && (line_[i] == ' ' || line_[i] == '\t')) ++i;
    if (i < size_ && line_[i] == '"') {
      ++i;
      char* out = line_ + i;
      begin = out;
      for (;;) {
        if (i >= size_) return fail();  // unterminated
        if (line_[i] == '"') {
          if (i + 1 < size_ && line_[i + 1] == '"') {
            *out++ = '"';
            i += 2;
            continue;
          }
          ++i;
          break;
        }
        *out++ = line_[i++];
      }
      end = out;
      while (i < size_ && (line_[i] == ' ' || line_[i] == '\t')) ++i;
      if (i < size_ && line_[i] != ',') return fail();
    } else {
      begin = line_ + i;
      while (i < size_ && line_[i] != ',') ++i;
      char* e = line_ + i;
      while (e != begin && (e[-1] == ' ' || e[-1] == '\t' || e[-1] == '\r')) --e;
      end = e;
    }
    if (i >= size_)
      done_ = true;
    else
      pos_ = i + 1;  // past the comma
    return true;
  }
  bool bad() const { return bad_; }

 private:
  bool fail() {
    bad_ = done_ = true;
    return false;
  }
  char* line_;
  std::size_t size_;
  std::size_t pos_ = 0;
  bool done_ = false, bad_ = false;
};

// `FormulaColumns`: read `time` and the named inputs (set_inputs) for a
// machine with formula effects; without, those columns are ignored like any
// other and their code is not in the image (the firmware's flash bar).
template <class Scalar, bool FormulaColumns = true> class PoseCsvReader {
 public:
  enum class LineResult : std::uint8_t {
    Skipped,      // comment, blank line or the header: nothing to deliver
    Point,        // `point` (and `id`) written; point.valid says whether it parsed
    BadHeader,    // the header lacks a required column (or has too many / a bad quote)
  };

  // The named inputs of the machine's formula effects, in its input order
  // (at most kFormulaInputs; `names` must outlive the reader): each is a
  // required column. Call before the header is read.
  void set_inputs(const char* const* names, int count) {
    static_assert(FormulaColumns, "a reader without formula columns reads no inputs");
    input_names_ = names;
    input_count_ = count < 0 ? 0 : (count > kFormulaInputs ? kFormulaInputs : count);
  }

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
    CsvFieldCursor cursor(line, size);
    if (!have_header_) return read_header(cursor);

    ++rows_;
    reset(point);
    id = CsvId();
    point.sequence = rows_;  // default; replaced by a seq column
    bool ok = true, seq_ok = seq_col_ < 0;
    int seen = 0;  // pose, temperature and sequence fields found
    char* b = nullptr;
    char* e = nullptr;
    int c = 0;
    for (; cursor.next(b, e); ++c) {
      if (c == id_col_) {
        const std::size_t len = static_cast<std::size_t>(e - b);
        id.size = len < kCsvIdCapacity - 1 ? len : kCsvIdCapacity - 1;
        for (std::size_t k = 0; k < id.size; ++k) id.text[k] = b[k];
        continue;
      }
      double v = 0;
      if (c == seq_col_) {
        ++seen;
        if (parse_decimal(b, e, v) && v >= 0 && v < 4294967296.0 &&
            v == static_cast<double>(static_cast<std::uint32_t>(v))) {
          point.sequence = static_cast<std::uint32_t>(v);
          seq_ok = true;
        }
        continue;
      }
      if (c == temp_col_) {
        ++seen;
        if (parse_decimal(b, e, v)) {
          point.temperature = Scalar(v);
          point.has_temperature = true;
        } else {
          ok = false;
        }
        continue;
      }
      if constexpr (FormulaColumns) {
        if (c == time_col_) {
          ++seen;
          if (parse_decimal(b, e, v))
            point.time = Scalar(v);
          else
            ok = false;
          continue;
        }
        for (int k = 0; k < input_count_; ++k) {
          if (c != input_col_[k]) continue;
          ++seen;
          if (parse_decimal(b, e, v))
            point.inputs[k] = Scalar(v);
          else
            ok = false;
        }
      }
      for (int k = 0; k < 6; ++k) {
        if (c != pose_col_[k]) continue;
        ++seen;
        if (parse_decimal(b, e, v))
          point.pose(k) = Scalar(v);
        else
          ok = false;
      }
    }
    if (!seq_ok) point.sequence = last_sequence_ + 1;  // keep the count going
    last_sequence_ = point.sequence;
    int wanted = 6 + (seq_col_ >= 0 ? 1 : 0) + (temp_col_ >= 0 ? 1 : 0);
    if constexpr (FormulaColumns) wanted += (time_col_ >= 0 ? 1 : 0) + input_count_;
    if (cursor.bad() || c != fields_ || seen != wanted || !seq_ok) ok = false;
    point.valid = ok;
    return LineResult::Point;
  }

  // A row the backend could not even split (too long for its line buffer):
  // still a point, flagged, with the next sequence number.
  void malformed_row(NcInput<Scalar>& point, CsvId& id) {
    ++rows_;
    reset(point);
    id = CsvId();
    point.sequence = seq_col_ >= 0 ? last_sequence_ + 1 : rows_;
    last_sequence_ = point.sequence;
    point.valid = false;
  }

  bool have_header() const { return have_header_; }

  // A fresh point: only the fields this reader writes (without formula
  // columns, time and inputs are not the controller's to read; leaving
  // them saves the firmware the stores).
  static void reset(NcInput<Scalar>& p) {
    p.sequence = 0;
    p.pose.setZero();
    p.temperature = Scalar(20);
    p.has_temperature = false;
    p.valid = true;
    p.producer_overruns = 0;
    if constexpr (FormulaColumns) {
      p.time = Scalar(0);
      for (Scalar& v : p.inputs) v = Scalar(0);
    }
  }
  std::uint32_t rows() const { return rows_; }

 private:
  static bool is(const char* b, const char* e, const char* name) {
    for (; b != e && *name != '\0'; ++b, ++name)
      if (*b != *name) return false;
    return b == e && *name == '\0';
  }

  LineResult read_header(CsvFieldCursor& cursor) {
    static constexpr const char* kPose[6] = {"x", "y", "z", "rx", "ry", "rz"};
    for (int k = 0; k < 6; ++k) pose_col_[k] = -1;
    if constexpr (FormulaColumns)
      for (int k = 0; k < kFormulaInputs; ++k) input_col_[k] = -1;
    char* b = nullptr;
    char* e = nullptr;
    int c = 0;
    for (; cursor.next(b, e); ++c) {
      for (int k = 0; k < 6; ++k)
        if (is(b, e, kPose[k])) pose_col_[k] = c;
      if (is(b, e, "id")) id_col_ = c;
      if (is(b, e, "seq")) seq_col_ = c;
      if (is(b, e, "temp")) temp_col_ = c;
      if constexpr (FormulaColumns) {
        if (is(b, e, "time")) time_col_ = c;
        for (int k = 0; k < input_count_; ++k)
          if (is(b, e, input_names_[k])) input_col_[k] = c;
      }
    }
    if (cursor.bad()) return LineResult::BadHeader;
    for (int k = 0; k < 6; ++k)
      if (pose_col_[k] < 0) return LineResult::BadHeader;
    if constexpr (FormulaColumns)
      for (int k = 0; k < input_count_; ++k)
        if (input_col_[k] < 0) return LineResult::BadHeader;
    fields_ = c;
    have_header_ = true;
    return LineResult::Skipped;
  }

  bool bom_checked_ = false;
  bool have_header_ = false;
  int fields_ = 0;
  int pose_col_[6] = {-1, -1, -1, -1, -1, -1};
  int id_col_ = -1, seq_col_ = -1, temp_col_ = -1, time_col_ = -1;
  const char* const* input_names_ = nullptr;
  int input_count_ = 0;
  int input_col_[kFormulaInputs] = {};  // set by read_header
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
