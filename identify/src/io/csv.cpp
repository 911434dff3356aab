#include "kincal/identify/csv.hpp"

#include "kincal/identify/files.hpp"
#include <sstream>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <ostream>
#include <system_error>

#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

// ---------------------------------------------------------------- generic CSV

int CsvDocument::column(std::string_view name) const {
  for (std::size_t i = 0; i < header.fields.size(); ++i)
    if (header.fields[i].text == name) return static_cast<int>(i);
  return -1;
}

namespace {

bool is_blank(char c) { return c == ' ' || c == '\t'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
  return s;
}

std::string quoted(const std::string& s) {
  // Keep messages one line and printable even for garbage input.
  std::string out = "'";
  for (char c : s.substr(0, 40)) {
    const unsigned char u = static_cast<unsigned char>(c);
    out += (u < 0x20 || u == 0x7f) ? '?' : c;
  }
  if (s.size() > 40) out += "...";
  return out + "'";
}

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& s : items) out += (out.empty() ? "" : ", ") + s;
  return out;
}

// Splits one physical line (no line end) into fields.
CsvRecord split_line(std::string_view line, std::size_t line_no, const std::string& file) {
  CsvRecord rec;
  rec.line = line_no;
  std::size_t i = 0;
  for (;;) {
    const std::size_t start = i;
    while (i < line.size() && is_blank(line[i])) ++i;
    CsvField f;
    if (i < line.size() && line[i] == '"') {
      f.column = i + 1;
      ++i;
      for (;;) {
        if (i >= line.size()) throw InputError(file, line_no, f.column, "unterminated quoted field");
        if (line[i] == '"') {
          if (i + 1 < line.size() && line[i + 1] == '"') {
            f.text += '"';
            i += 2;
            continue;
          }
          ++i;
          break;
        }
        f.text += line[i++];
      }
      while (i < line.size() && is_blank(line[i])) ++i;
      if (i < line.size() && line[i] != ',')
        throw InputError(file, line_no, i + 1, "unexpected character after a quoted field");
    } else {
      f.column = start + 1;
      std::size_t end = i;
      while (end < line.size() && line[end] != ',') {
        if (line[end] == '"') throw InputError(file, line_no, end + 1, "stray quote inside an unquoted field");
        ++end;
      }
      f.text = std::string(trim(line.substr(start, end - start)));
      i = end;
    }
    rec.fields.push_back(std::move(f));
    if (i >= line.size()) break;
    ++i;  // the comma
  }
  return rec;
}

}  // namespace

CsvDocument parse_csv(std::string_view text, const std::string& file) {
  CsvDocument doc;
  doc.file = file;
  if (text.size() >= 3 && text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
  bool have_header = false;
  std::size_t line_no = 0;
  std::size_t pos = 0;
  while (pos < text.size()) {
    ++line_no;
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (trim(line).empty() || line.front() == '#') continue;
    if (line.find('\0') != std::string_view::npos)
      throw InputError(file, line_no, line.find('\0') + 1, "NUL byte in a text file");
    CsvRecord rec = split_line(line, line_no, file);
    if (!have_header) {
      std::map<std::string, std::size_t> seen;
      for (const CsvField& f : rec.fields) {
        if (f.text.empty()) throw InputError(file, line_no, f.column, "empty column name in the header");
        const auto [it, fresh] = seen.emplace(f.text, f.column);
        if (!fresh)
          throw InputError(file, line_no, f.column,
                           "duplicate column " + quoted(f.text) + " (first at column " + std::to_string(it->second) + ")");
      }
      doc.header = std::move(rec);
      have_header = true;
      continue;
    }
    if (rec.fields.size() != doc.header.fields.size())
      throw InputError(file, line_no, rec.fields.size() > doc.header.fields.size() ? rec.fields[doc.header.fields.size()].column : 0,
                       "row has " + std::to_string(rec.fields.size()) + " fields, the header has " +
                           std::to_string(doc.header.fields.size()));
    doc.rows.push_back(std::move(rec));
  }
  // Where the header should have been: just past what the file has.
  if (!have_header)
    throw InputError(file, line_no + 1, 1,
                     line_no == 0 ? "empty file (expected a header row)"
                                  : "no header row (the file has only comments and blank lines)");
  return doc;
}

double parse_number(const CsvField& field, std::size_t line, const std::string& file, const std::string& column_name) {
  std::string_view s = field.text;
  if (s.empty()) throw InputError(file, line, field.column, "empty value in column '" + column_name + "'");
  // One optional sign: "+-5" is not −5 (from_chars would take the '-' after a
  // stripped '+').
  if (s.front() == '+') s.remove_prefix(1);
  if (!s.empty() && (s.front() == '+' || (field.text.front() == '+' && s.front() == '-')))
    throw InputError(file, line, field.column, "not a number: " + quoted(field.text) + " in column '" + column_name + "'");
  double v = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v, std::chars_format::general);
  if (ec == std::errc::result_out_of_range)
    throw InputError(file, line, field.column, "value " + quoted(field.text) + " in column '" + column_name + "' is out of range");
  if (ec != std::errc() || ptr != s.data() + s.size())
    throw InputError(file, line, field.column, "not a number: " + quoted(field.text) + " in column '" + column_name + "'");
  if (!std::isfinite(v))
    throw InputError(file, line, field.column,
                     "non-finite value " + quoted(field.text) + " in column '" + column_name + "' (NaN/Inf are rejected)");
  return v;
}

std::string format_number(double v) {
  std::array<char, 64> buf{};
  const auto [ptr, ec] = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  if (ec != std::errc()) return "nan";  // cannot happen for a 64-byte buffer
  return std::string(buf.data(), ptr);
}

// ---------------------------------------------------------------- pose tables

namespace {

long long parse_integer(const CsvField& field, std::size_t line, const std::string& file, const std::string& column_name) {
  std::string_view s = field.text;
  if (s.empty()) throw InputError(file, line, field.column, "empty value in column '" + column_name + "'");
  if (s.front() == '+') s.remove_prefix(1);
  if (!s.empty() && (s.front() == '+' || (field.text.front() == '+' && s.front() == '-')))
    throw InputError(file, line, field.column, "not an integer: " + quoted(field.text) + " in column '" + column_name + "'");
  long long v = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || ptr != s.data() + s.size())
    throw InputError(file, line, field.column, "not an integer: " + quoted(field.text) + " in column '" + column_name + "'");
  return v;
}

// A group of columns that must be present together (or not at all).
struct Group {
  explicit Group(std::vector<std::string> n) : names(std::move(n)) {}
  std::vector<std::string> names;
  std::vector<int> index;  // into the header; filled by resolve()
  bool present = false;

  void resolve(const CsvDocument& doc, const std::string& what, bool required) {
    std::vector<std::string> missing;
    for (const auto& n : names) {
      index.push_back(doc.column(n));
      if (index.back() < 0) missing.push_back(n);
    }
    present = missing.size() < names.size();
    if (required && !present) present = true;  // report all of them below
    if (present && !missing.empty())
      throw InputError(doc.file, doc.header.line, 0,
                       (required ? std::string("missing required columns: ") : "incomplete " + what + " columns, missing: ") + join(missing));
  }
  bool empty_in(const CsvRecord& r) const {
    return std::all_of(index.begin(), index.end(), [&](int i) { return r.fields[static_cast<std::size_t>(i)].text.empty(); });
  }
  std::vector<double> numbers(const CsvRecord& r, const std::string& file) const {
    std::vector<double> v;
    for (std::size_t k = 0; k < names.size(); ++k)
      v.push_back(parse_number(r.fields[static_cast<std::size_t>(index[k])], r.line, file, names[k]));
    return v;
  }
};

// A pose's angles (the last three of x, y, z, rx, ry, rz) are radians of one
// turn at most: 1e30 rad parses, but its sine is rounding noise, and the
// identification then reported a rank-deficient design instead of the row.
// A value like 30 for rx is degrees given where radians belong.
void require_turn(const std::vector<double>& pose, const Group& g, const CsvRecord& r, const std::string& file) {
  constexpr double kTurn = 6.283185307179586;
  for (std::size_t k = 3; k < 6; ++k)
    if (!(std::abs(pose[k]) <= kTurn)) {
      const CsvField& f = r.fields[static_cast<std::size_t>(g.index[k])];
      throw InputError(file, r.line, f.column,
                       "angle " + quoted(f.text) + " in column '" + g.names[k] +
                           "' is more than a turn (2 pi rad): angles are in radians");
    }
}

std::vector<std::string> numbered(const std::string& prefix, int n, const std::string& suffix = "") {
  std::vector<std::string> out;
  for (int i = 1; i <= n; ++i) out.push_back(prefix + std::to_string(i) + suffix);
  return out;
}

}  // namespace

PoseTable parse_pose_table(std::string_view text, const std::string& file, const PoseTableOptions& options) {
  const CsvDocument doc = parse_csv(text, file);
  const int n = options.joint_count;
  PoseTable table;
  table.file = file;
  table.joint_count = n;

  Group id({"id"}), pose({"x", "y", "z", "rx", "ry", "rz"});
  Group measured({"mx", "my", "mz", "mrx", "mry", "mrz"});
  // One to three laser-tracker targets (t1 first): the hybrid's gauge uses all
  // three; tracker targets any leading ones (target_calibration.hpp).
  Group targets[3] = {Group({"t1x", "t1y", "t1z"}), Group({"t2x", "t2y", "t2z"}), Group({"t3x", "t3y", "t3z"})};
  Group q(numbered("q", n)), dir(numbered("dir", n));
  Group layer({"layer"}), role({"role"}), temp({"temp"}), time({"time"}), status({"status"});
  {
    // Required columns first, all missing ones named in one message.
    Group required({"id", "x", "y", "z", "rx", "ry", "rz"});
    required.resolve(doc, "required", true);
  }
  id.resolve(doc, "id", true);
  pose.resolve(doc, "commanded pose", true);
  measured.resolve(doc, "measured pose", false);
  for (int k = 0; k < 3; ++k) {
    targets[k].resolve(doc, "target t" + std::to_string(k + 1), false);
    if (targets[k].present) {
      if (k > table.target_count)
        throw InputError(file, doc.header.line, 0,
                         "target columns t" + std::to_string(k + 1) + "x.. without t" + std::to_string(k) +
                             "x..: number the targets from 1");
      table.target_count = k + 1;
    }
  }
  q.resolve(doc, "joint command", false);
  dir.resolve(doc, "approach direction", false);
  layer.resolve(doc, "layer", false);
  role.resolve(doc, "role", false);
  temp.resolve(doc, "temperature", false);
  time.resolve(doc, "time", false);
  status.resolve(doc, "status", false);
  table.has_measured = measured.present;
  table.has_targets = table.target_count > 0;
  table.has_q = q.present;
  table.has_dir = dir.present;
  table.has_layer = layer.present;
  table.has_role = role.present;
  table.has_temp = temp.present;
  table.has_time = time.present;
  table.has_status = status.present;

  std::vector<Group> inputs;
  for (const std::string& name : options.input_columns) {
    inputs.push_back(Group({name}));
    inputs.back().resolve(doc, "input " + name, false);
    if (inputs.back().present) table.input_names.push_back(name);
  }
  std::vector<bool> known(doc.header.fields.size(), false);
  for (const Group& g : inputs)
    for (int i : g.index)
      if (i >= 0) known[static_cast<std::size_t>(i)] = true;
  for (const Group* g : {&id, &pose, &measured, &targets[0], &targets[1], &targets[2], &q, &dir, &layer, &role, &temp,
                         &time, &status})
    for (int i : g->index)
      if (i >= 0) known[static_cast<std::size_t>(i)] = true;
  for (std::size_t i = 0; i < known.size(); ++i)
    if (!known[i]) table.ignored_columns.push_back(doc.header.fields[i].text);
  if (!table.ignored_columns.empty() && options.warn) {
    std::vector<std::string> names;
    for (const auto& c : table.ignored_columns) names.push_back(quoted(c));
    options.warn(format_location(file, doc.header.line, 0) + ": warning: unknown column" +
                 (names.size() == 1 ? " " : "s ") + join(names) + " ignored");
  }

  if (doc.rows.empty()) throw InputError(file, doc.header.line, 0, "no data rows after the header");

  std::map<std::string, std::size_t> ids;
  for (const CsvRecord& r : doc.rows) {
    PoseRow row;
    row.line = r.line;
    const CsvField& idf = r.fields[static_cast<std::size_t>(id.index[0])];
    if (idf.text.empty()) throw InputError(file, r.line, idf.column, "empty id");
    const auto [it, fresh] = ids.emplace(idf.text, r.line);
    if (!fresh)
      throw InputError(file, r.line, idf.column,
                       "duplicate id " + quoted(idf.text) + " (first at line " + std::to_string(it->second) + ")");
    row.id = idf.text;
    const std::vector<double> c = pose.numbers(r, file);
    require_turn(c, pose, r, file);
    row.commanded = Eigen::Map<const Vec6<double>>(c.data());
    if (status.present) {
      row.status = r.fields[static_cast<std::size_t>(status.index[0])].text;
      if (row.status.empty()) row.status = "ok";
    }
    // A row whose status says it failed (a simulate output) has no measurement.
    const bool failed = status.present && row.status != "ok";
    if (measured.present && !(failed && measured.empty_in(r))) {
      const std::vector<double> m = measured.numbers(r, file);
      require_turn(m, measured, r, file);
      row.measured = Eigen::Map<const Vec6<double>>(m.data());
    }
    if (table.target_count > 0 && !(failed && targets[0].empty_in(r))) {
      Eigen::Matrix<double, 3, 3> t = Eigen::Matrix<double, 3, 3>::Zero();
      for (int k = 0; k < table.target_count; ++k) {
        const std::vector<double> v = targets[k].numbers(r, file);
        t.col(k) = Eigen::Map<const Vec3<double>>(v.data());
      }
      row.targets = t;
    }
    if (q.present) {
      const std::vector<double> v = q.numbers(r, file);
      row.q = Eigen::Map<const Eigen::VectorXd>(v.data(), n);
    }
    if (dir.present) {
      Eigen::VectorXi d(n);
      for (int k = 0; k < n; ++k) {
        const CsvField& f = r.fields[static_cast<std::size_t>(dir.index[static_cast<std::size_t>(k)])];
        const long long v = parse_integer(f, r.line, file, dir.names[static_cast<std::size_t>(k)]);
        if (v != 1 && v != -1)
          throw InputError(file, r.line, f.column,
                           "approach direction must be -1 or +1, not " + quoted(f.text) + " in column '" +
                               dir.names[static_cast<std::size_t>(k)] + "'");
        d(k) = static_cast<int>(v);
      }
      row.dir = d;
    }
    if (layer.present) row.layer = parse_integer(r.fields[static_cast<std::size_t>(layer.index[0])], r.line, file, "layer");
    if (role.present) {
      const CsvField& f = r.fields[static_cast<std::size_t>(role.index[0])];
      if (f.text == "test")
        row.role = Role::Test;
      else if (f.text == "cal" || f.text.empty())
        row.role = Role::Cal;
      else
        throw InputError(file, r.line, f.column, "role must be 'cal' or 'test', not " + quoted(f.text));
    }
    if (temp.present) row.temp = parse_number(r.fields[static_cast<std::size_t>(temp.index[0])], r.line, file, "temp");
    if (time.present) row.time = parse_number(r.fields[static_cast<std::size_t>(time.index[0])], r.line, file, "time");
    for (const Group& g : inputs)
      if (g.present)
        row.inputs[g.names[0]] = parse_number(r.fields[static_cast<std::size_t>(g.index[0])], r.line, file, g.names[0]);
    table.rows.push_back(std::move(row));
  }
  return table;
}

PoseTable read_pose_table(const std::string& path, const PoseTableOptions& options) {
  return parse_pose_table(read_text_file(path), path, options);
}

namespace {

std::string csv_text(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos && trim(s) == s) return s;
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

}  // namespace

void write_pose_table(const PoseTable& t, std::ostream& out) {
  const int n = t.joint_count;
  std::vector<std::string> header{"id"};
  if (t.has_layer) header.push_back("layer");
  if (t.has_role) header.push_back("role");
  for (const char* c : {"x", "y", "z", "rx", "ry", "rz"}) header.push_back(c);
  if (t.has_measured)
    for (const char* c : {"mx", "my", "mz", "mrx", "mry", "mrz"}) header.push_back(c);
  for (int k = 1; k <= t.target_columns(); ++k)
    for (const char* c : {"x", "y", "z"}) header.push_back("t" + std::to_string(k) + c);
  if (t.has_q)
    for (const auto& c : numbered("q", n)) header.push_back(c);
  if (t.has_temp) header.push_back("temp");
  if (t.has_time) header.push_back("time");
  if (t.has_dir)
    for (const auto& c : numbered("dir", n)) header.push_back(c);
  if (t.has_status) header.push_back("status");
  for (const auto& name : t.input_names) header.push_back(name);
  for (std::size_t i = 0; i < header.size(); ++i) out << (i ? "," : "") << header[i];
  out << "\n";

  for (const PoseRow& r : t.rows) {
    std::vector<std::string> f{csv_text(r.id)};
    if (t.has_layer) f.push_back(r.layer ? std::to_string(*r.layer) : "");
    if (t.has_role) f.push_back(r.role == Role::Test ? "test" : "cal");
    for (int k = 0; k < 6; ++k) f.push_back(format_number(r.commanded(k)));
    if (t.has_measured)
      for (int k = 0; k < 6; ++k) f.push_back(r.measured ? format_number((*r.measured)(k)) : "");
    for (int k = 0; k < 3 * t.target_columns(); ++k) f.push_back(r.targets ? format_number(r.targets->data()[k]) : "");
    if (t.has_q)
      for (int k = 0; k < n; ++k) f.push_back(r.q ? format_number((*r.q)(k)) : "");
    if (t.has_temp) f.push_back(r.temp ? format_number(*r.temp) : "");
    if (t.has_time) f.push_back(r.time ? format_number(*r.time) : "");
    if (t.has_dir)
      for (int k = 0; k < n; ++k) f.push_back(r.dir ? ((*r.dir)(k) > 0 ? "1" : "-1") : "");
    if (t.has_status) f.push_back(csv_text(r.status.empty() ? "ok" : r.status));
    for (const auto& name : t.input_names) {
      const auto it = r.inputs.find(name);
      f.push_back(it != r.inputs.end() ? format_number(it->second) : "");
    }
    for (std::size_t i = 0; i < f.size(); ++i) out << (i ? "," : "") << f[i];
    out << "\n";
  }
}

std::string pose_table_text(const PoseTable& table) {
  std::ostringstream out;
  write_pose_table(table, out);
  return out.str();
}

void write_pose_table_file(const PoseTable& table, const std::string& path, const std::vector<std::string>& inputs) {
  write_output_file(path, pose_table_text(table), inputs);
}

}  // namespace kincal::identify
