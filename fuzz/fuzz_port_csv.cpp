// libFuzzer target: the firmware's NC-stream CSV reader
// (port/include/kincal/port/csv_stream.hpp PoseCsvReader), fed line by line
// as the bare-metal stream does, in double and float, and every point it
// delivers compensated by core's Compensator as the controller would. The
// reader passes NaN / Inf / values that overflow float on as numbers (by
// design: the compensation refuses them with InvalidInput, holds and counts
// them); the property is the controller's: the command that would leave is
// finite and inside the machine's limits, whatever the line said.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "kincal/core/compensation.hpp"
#include "kincal/core/reference_machines.hpp"
#include "kincal/port/csv_stream.hpp"

namespace {

template <class Scalar> void feed_all(const std::uint8_t* data, std::size_t size) {
  static const kincal::StewartCalibrationTable<Scalar> table = kincal::nominal_table(kincal::make_stewart_seed001<Scalar>());
  static const kincal::MachineLimits<Scalar> limits = kincal::limits_from_bounds(table.bounds);
  static const kincal::StewartCompensator<Scalar> compensator(table, limits);
  kincal::Vec6<Scalar> home;
  if (compensator.home_command(home) != kincal::CompensationStatus::Ok) std::abort();
  auto state = compensator.start(home);
  kincal::port::PoseCsvReader<Scalar> reader;
  // Formula effects' columns too: `time` and two named inputs.
  static constexpr const char* kInputs[2] = {"spindle_temp", "humidity"};
  reader.set_inputs(kInputs, 2);
  std::vector<char> line;
  kincal::port::NcInput<Scalar> point;
  kincal::port::CsvId id;
  auto flush = [&] {
    const auto r = reader.feed(line.data(), line.size(), point, id);
    line.clear();
    if (id.size >= kincal::port::kCsvIdCapacity) {
      std::fprintf(stderr, "fuzz contract broken: id longer than its buffer\n");
      std::abort();
    }
    if (r != kincal::port::PoseCsvReader<Scalar>::LineResult::Point) return;
    kincal::NcPoint<Scalar> p;
    if (point.valid) {
      p.pose = kincal::Pose<Scalar>::from_xyz_rpy(point.pose);
    } else {
      p.pose.p.setConstant(Scalar(NAN));  // as the controller hands over a malformed record
    }
    p.temperature = point.temperature;
    p.has_temperature = point.has_temperature;
    kincal::Vec6<Scalar> q;
    compensator.compensate(state, p, q);
    if (!kincal::command_inside(q, limits)) {
      std::fprintf(stderr, "fuzz contract broken: a command outside the limits or not finite\n");
      std::abort();
    }
  };
  for (std::size_t i = 0; i < size; ++i) {
    if (data[i] == '\n')
      flush();
    else
      line.push_back(char(data[i]));
  }
  if (!line.empty()) flush();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  feed_all<double>(data, size);
  feed_all<float>(data, size);
  return 0;
}
