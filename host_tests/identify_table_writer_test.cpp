// `kincal table` (identify/table_writer.hpp): the generated header carries the
// numbers `kincal compensate` runs on, bit for bit, its CRC and format
// version; the example's committed header is what the generator makes of the
// committed model; and the header compiles, with its static_asserts, here.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "kincal/core/calibration_table.hpp"
#include "kincal/core/compensation.hpp"
#include "kincal/identify/calibration_table.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/model.hpp"
#include "kincal/identify/robot.hpp"
#include "kincal/identify/table_writer.hpp"

// The example's committed header, compiled into this test: its static_asserts
// (CRC, validate_table, format version) are checked by this very build.
#include "../examples/firmware/calibration_table.hpp"

namespace {

namespace fs = std::filesystem;
namespace ki = kincal::identify;
using namespace kincal;

const std::string kSource = KINCAL_SOURCE_DIR;
const std::string kOut = std::string(KINCAL_BINARY_DIR) + "/table_writer_test_out";

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

// The numbers of one value array of a generated header, in order.
std::vector<double> values_of(const std::string& header, const std::string& array) {
  const std::size_t start = header.find("inline constexpr double " + array + "[");
  EXPECT_NE(start, std::string::npos) << array;
  if (start == std::string::npos) return {};
  const std::size_t open = header.find('{', start), close = header.find("};", start);
  std::istringstream body(header.substr(open + 1, close - open - 1));
  std::vector<double> out;
  for (std::string line; std::getline(body, line);) {
    line = line.substr(0, line.find("//"));
    std::istringstream items(line);
    for (std::string item; std::getline(items, item, ',');) {
      const std::size_t b = item.find_first_not_of(" \t");
      if (b == std::string::npos) continue;
      out.push_back(std::strtod(item.c_str() + b, nullptr));
    }
  }
  return out;
}

std::uint32_t crc_of(const std::string& header, const std::string& name) {
  const std::size_t p = header.find("inline constexpr std::uint32_t " + name + " = ");
  EXPECT_NE(p, std::string::npos) << name;
  return static_cast<std::uint32_t>(std::strtoul(header.c_str() + header.find("0x", p), nullptr, 16));
}

template <class Machine> std::vector<double> canonical(const CalibrationTable<Machine>& t) {
  std::vector<double> v(table_value_count<Machine>());
  table_to_values(t, v.data());
  return v;
}

void expect_same_bits(const std::vector<double>& a, const std::vector<double>& b, const std::string& what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  for (std::size_t k = 0; k < a.size(); ++k)
    ASSERT_EQ(value_bits(a[k]), value_bits(b[k])) << what << " value " << k << ": " << a[k] << " vs " << b[k];
}

ki::CalibrationModel example_model() { return ki::read_model_file(kSource + "/examples/firmware/model.json"); }

TEST(identifyTableWriter, HybridHeaderHoldsTheCompensateTableBitForBit) {
  const ki::CalibrationModel model = example_model();
  const std::string h = ki::calibration_table_header(model, "examples/firmware/model.json");
  const HybridCalibrationTabled table = ki::hybrid_calibration_table(model);
  EXPECT_NE(h.find("// Generated from examples/firmware/model.json by kincal "), std::string::npos);
  EXPECT_NE(h.find("static_assert(::kincal::kCalibrationTableVersion == " + std::to_string(kincal::kCalibrationTableVersion)),
            std::string::npos);
  EXPECT_NE(h.find("kFamily = ::kincal::MachineFamily::Hybrid"), std::string::npos);
  expect_same_bits(values_of(h, "kCalibrationValues_double"), canonical(table), "calibration (double)");
  EXPECT_EQ(crc_of(h, "kCalibrationCrc_double"), table.crc);
  EXPECT_EQ(crc_of(h, "kCalibrationCrc_double"), table_crc(table));
  // float: the values rounded to float, with their own CRC.
  const auto table_f = table_cast<float>(table);
  expect_same_bits(values_of(h, "kCalibrationValues_float"), canonical(table_f), "calibration (float)");
  EXPECT_EQ(crc_of(h, "kCalibrationCrc_float"), table_crc(table_f));
  // The nominal fallback: the model's nominal machine, nothing identified.
  const std::vector<double> nominal = values_of(h, "kNominalValues_double");
  constexpr std::size_t kCount = kincal::table_value_count<HybridMachine<double>>();
  ASSERT_EQ(nominal.size(), kCount);
  double nominal_values[kCount];
  std::copy(nominal.begin(), nominal.end(), nominal_values);
  const HybridCalibrationTabled nominal_table =
      table_from_values<HybridMachine<double>>(nominal_values, crc_of(h, "kNominalCrc_double"));
  EXPECT_EQ(validate_table(nominal_table), CompensationStatus::Ok);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(nominal_table.machine.encoder_offsets[i], 0.0);
  for (int k = 0; k < kHybridSourceErrorCount; ++k) EXPECT_EQ(nominal_table.machine.source_errors[k], 0.0);
  EXPECT_EQ(nominal_table.effects.screw_lead, table.effects.screw_lead);
  // Every source error is labelled with its name.
  EXPECT_NE(h.find("// dx_0_1 mm"), std::string::npos);
  EXPECT_NE(h.find("// dxi_6_4 rad"), std::string::npos);
}

// The committed example header is what the generator makes of the committed
// model: regenerate it (kincal table --model examples/firmware/model.json
// --out examples/firmware/calibration_table.hpp, from the source root) when
// either changes.
TEST(identifyTableWriter, CommittedExampleHeaderIsUpToDate) {
  const std::string want = ki::calibration_table_header(example_model(), "examples/firmware/model.json");
  EXPECT_TRUE(want == slurp(kSource + "/examples/firmware/calibration_table.hpp"))
      << "examples/firmware/calibration_table.hpp is stale: regenerate it from examples/firmware/model.json";
}

// The header compiled into this test is the table `kincal compensate` uses,
// and the compensator gives the same commands from either.
TEST(identifyTableWriter, CompiledHeaderCompensatesLikeTheHost) {
  const HybridCalibrationTabled host = ki::hybrid_calibration_table(example_model());
  const auto& compiled = generated::Tables<double>::calibration();
  expect_same_bits(canonical(compiled), canonical(host), "compiled table");
  EXPECT_EQ(compiled.crc, host.crc);
  EXPECT_EQ(validate_table(generated::Tables<float>::calibration()), CompensationStatus::Ok);
  EXPECT_EQ(validate_table(generated::Tables<float>::nominal()), CompensationStatus::Ok);
  const HybridCompensator<double> a(compiled, trust_table_bounds), b(host, trust_table_bounds);
  auto sa = a.start(Vec6<double>::Zero()), sb = b.start(Vec6<double>::Zero());
  for (int k = 0; k < 20; ++k) {
    const Pose<double> p = Pose<double>::from_xyz_rpy(-200 + 20 * k, 100 - 10 * k, -40 + 4 * k, 0.01 * k, -0.02, 0.005 * k);
    Vec6<double> qa, qb;
    ASSERT_EQ(a.compensate(sa, p, qa), CompensationStatus::Ok);
    ASSERT_EQ(b.compensate(sb, p, qb), CompensationStatus::Ok);
    EXPECT_EQ(qa, qb);
  }
}

TEST(identifyTableWriter, StewartHeader) {
  ki::CalibrationModel model;
  model.nominal = ki::load_robot("stewart-seed001");
  model.estimator = "ols";
  model.data_file = "grid.csv";
  const char* names[] = {"dXB1", "dl2", "dZP6", "dYB4"};
  for (int k = 0; k < 4; ++k) model.parameters.push_back({names[k], 0.01 * (k + 1) - 0.025, 1e-4, true});
  const std::string h = ki::calibration_table_header(model, "stewart model.json");
  const StewartCalibrationTabled table = ki::stewart_calibration_table(model);
  EXPECT_NE(h.find("kFamily = ::kincal::MachineFamily::Stewart6Ups"), std::string::npos);
  EXPECT_NE(h.find("kModelFile = \"stewart model.json\""), std::string::npos);
  const std::vector<double> v = values_of(h, "kCalibrationValues_double");
  EXPECT_EQ(v.size(), kincal::table_value_count<StewartMachine<double>>());
  expect_same_bits(v, canonical(table), "stewart calibration");
  EXPECT_EQ(crc_of(h, "kCalibrationCrc_double"), table.crc);
  EXPECT_EQ(crc_of(h, "kCalibrationCrc_float"), table_crc(table_cast<float>(table)));
}

// Issue #10 item 2: `kincal table` built a CRC-valid table from a hand-edited
// MODEL.json with absurd numbers and exited 0. The table is now checked
// against the machine limits of the model's nominal robot, and the error
// names the value.
TEST(identifyTableWriter, AModelOutsideTheMachineLimitsIsRefusedNamingTheValue) {
  ki::CalibrationModel model;
  model.nominal = ki::load_robot("stewart-seed001");
  model.estimator = "ols";
  model.parameters.push_back({"dXB2", 1e6, 1e-4, true});
  try {
    (void)ki::calibration_table_header(model, "edited.json");
    ADD_FAILURE() << "a source error of 1e6 mm made a table";
  } catch (const ki::InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("outside the machine limits"), std::string::npos) << m;
    EXPECT_NE(m.find("machine.calibrated.base - nominal[3] = 1e+06 above max_geometry_error 10"), std::string::npos) << m;
  }
  model.parameters = {{"dl3", 7.5, 1e-4, true}};  // a leg offset above the 5 mm bound
  try {
    (void)ki::calibration_table_header(model, "edited.json");
    ADD_FAILURE() << "a 7.5 mm leg offset made a table";
  } catch (const ki::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("leg offset dl3 = 7.5 above the correction bound 5"), std::string::npos)
        << e.what();
  }
}

// ---- the command line ---------------------------------------------------------

struct ToolRun {
  int code = -1;
  std::string err;
};

ToolRun run_tool(const std::string& args) {
  fs::create_directories(kOut);
  const std::string err = kOut + "/" + ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".stderr";
  const std::string cmd = std::string("\"") + KINCAL_TOOL + "\" " + args + " >/dev/null 2>\"" + err + "\"";
  const int status = std::system(cmd.c_str());
  ToolRun r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.err = slurp(err);
  return r;
}

// The tool writes the header and never reads its output (issue #10 item 7:
// it read an existing output first, so `--out /dev/stdout | cat` and a FIFO
// blocked forever). Rebuild avoidance is CMake's copy_if_different.
TEST(identifyTableWriter, CommandLineWritesTheHeaderAndNeverReadsIt) {
  const std::string out = kOut + "/calibration_table.hpp";
  fs::remove(out);
  const std::string model = kSource + "/examples/firmware/model.json";
  const std::string want = ki::calibration_table_header(ki::read_model_file(model), model);
  ToolRun r = run_tool("table --model \"" + model + "\" --out \"" + out + "\"");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_EQ(slurp(out), want);
  // To a pipe: /dev/stdout into cat, bounded by timeout so a hang fails.
  const std::string piped = kOut + "/piped.hpp";
  const std::string cmd = std::string("timeout 20 \"") + KINCAL_TOOL + "\" table --model \"" + model +
                          "\" --out /dev/stdout | cat > \"" + piped + "\"";
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << cmd;
  EXPECT_EQ(slurp(piped), want);
  // To a full device: an error, not a silent cut.
  r = run_tool("table --model \"" + model + "\" --out /dev/full");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("/dev/full: write failed"), std::string::npos) << r.err;
}

TEST(identifyTableWriter, CommandLineErrorsAreOneLine) {
  fs::create_directories(kOut);
  const std::string bad = kOut + "/bad_model.json";
  std::ofstream(bad) << "{\"format\": \"kincal-model\", \"version\": 1,\n \"robot\": ";
  for (const std::string& args : {"table --model \"" + bad + "\" --out " + kOut + "/x.hpp",
                                  "table --model " + kOut + "/missing.json --out " + kOut + "/x.hpp",
                                  "table --model \"" + kSource + "/examples/firmware/model.json\" --out /nonexistent/dir/x.hpp"}) {
    const ToolRun r = run_tool(args);
    EXPECT_EQ(r.code, 1) << args;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(r.err.rfind("kincal: ", 0), 0u) << r.err;
  }
  EXPECT_EQ(run_tool("table --model m.json").code, 2);  // --out missing: usage
}

}  // namespace
