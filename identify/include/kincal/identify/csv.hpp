// Measurement / poses CSV v1 (GUIDE "Measurement CSV"; docs/formats.md):
// a header row, free column order, unknown columns ignored and listed once as
// a warning, strict numbers (no NaN/Inf, whole field consumed), unique ids.
// Every error is an InputError naming file, line and column.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <functional>
#include <iosfwd>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "kincal/core/scalar.hpp"

namespace kincal::identify {

// ---------------------------------------------------------------- generic CSV

struct CsvField {
  std::string text;    // unquoted, surrounding blanks of unquoted fields trimmed
  std::size_t column;  // 1-based byte column where the field starts
};
struct CsvRecord {
  std::size_t line;  // 1-based
  std::vector<CsvField> fields;
};
struct CsvDocument {
  std::string file;
  CsvRecord header;
  std::vector<CsvRecord> rows;
  // Index of a header column, or -1.
  int column(std::string_view name) const;
};

// Splits CSV text: comma separated, optional "double quotes" with "" escapes,
// LF or CRLF line ends, a UTF-8 BOM skipped; blank lines and lines starting
// with '#' are ignored. Every row must have the header's field count. Throws
// InputError on an empty file, an unterminated quote, a stray quote, a
// duplicate or empty header name, or a wrong field count.
CsvDocument parse_csv(std::string_view text, const std::string& file);

// Strict number parsing for one field: the whole field must be a finite
// decimal number (a leading '+' is allowed, "nan"/"inf"/hex are not).
double parse_number(const CsvField& field, std::size_t line, const std::string& file, const std::string& column_name);

// Shortest text that reads back to the same double.
std::string format_number(double v);

// ---------------------------------------------------------------- pose tables

enum class Role { Cal, Test };

struct PoseRow {
  std::string id;
  std::size_t line = 0;  // source line (0 for rows not read from a file)
  std::optional<long long> layer;
  Role role = Role::Cal;
  Vec6<double> commanded = Vec6<double>::Zero();  // x, y, z, rx, ry, rz
  std::optional<Vec6<double>> measured;           // mx .. mrz
  std::optional<Eigen::Matrix<double, 3, 3>> targets;  // t1..tk as columns (k = PoseTable::target_count; the rest 0)
  std::optional<Eigen::VectorXd> q;               // q1..qN
  std::optional<double> temp, time;
  std::optional<Eigen::VectorXi> dir;             // dir1..dirN, each −1 or +1
  std::string status;  // "" when the file has no status column; "ok" or a failure
  // Named numeric inputs of formula effects (PoseTableOptions::input_columns
  // the file has), by column name.
  std::map<std::string, double> inputs;
};

struct PoseTable {
  std::string file;
  int joint_count = 6;
  std::vector<PoseRow> rows;
  // Which optional column groups the table has (all rows share them).
  bool has_layer = false, has_role = false, has_measured = false, has_targets = false, has_q = false,
       has_temp = false, has_time = false, has_dir = false, has_status = false;
  std::vector<std::string> ignored_columns;  // unknown columns, in file order
  std::vector<std::string> input_names;      // the input columns present (PoseTableOptions::input_columns order)
  // Laser-tracker targets per row: t1 .. t<target_count> (0–3; has_targets
  // when > 0). The hybrid's gauge has all three.
  int target_count = 0;
  // The number of targets: target_count, or the gauge's three for a table
  // built in code with has_targets alone (before target_count existed).
  int target_columns() const { return target_count > 0 ? target_count : (has_targets ? 3 : 0); }
  // The targets are in the instrument's own frame (`--instrument-frame`; not
  // a column: the user says it), its registration unknown.
  bool in_instrument_frame = false;
};

struct PoseTableOptions {
  int joint_count = 6;
  // Receives one line per warning, already formatted as "FILE:LINE: warning: ...".
  std::function<void(const std::string&)> warn;
  // Columns read as numbers into PoseRow::inputs when present: the robot's
  // formula inputs (Robot::formula_inputs), which are then not "unknown".
  std::vector<std::string> input_columns;
};

PoseTable parse_pose_table(std::string_view text, const std::string& file, const PoseTableOptions& options = {});
PoseTable read_pose_table(const std::string& path, const PoseTableOptions& options = {});

// Writes the table's columns in a fixed order: id, layer, role, x..rz, mx..mrz,
// t1x..t3z, q1..qN, temp, time, dir1..dirN, status (each group if present).
// Rows with a failure status get empty measured / target fields.
void write_pose_table(const PoseTable& table, std::ostream& out);
std::string pose_table_text(const PoseTable& table);
// Written atomically (files.hpp); refused if `path` is one of `inputs`.
void write_pose_table_file(const PoseTable& table, const std::string& path, const std::vector<std::string>& inputs = {});

}  // namespace kincal::identify
