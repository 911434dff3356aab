// The port's allocation-free text and queue building blocks, on the host:
// decimal parsing / formatting (port/include/kincal/port/number_text.hpp),
// the CSV pose reader and joint writer of the bare-metal NC stream
// (csv_stream.hpp), the ring buffer and the emulated registers and stream.
// The firmware example runs the very same code under qemu.
#include <gtest/gtest.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "kincal/port/csv_stream.hpp"
#include "kincal/port/emulator/encoder_registers.hpp"
#include "kincal/port/emulator/nc_stream.hpp"
#include "kincal/port/number_text.hpp"
#include "kincal/port/ring_buffer.hpp"

namespace {

using namespace kincal::port;

bool parse(const std::string& s, double& v) { return parse_decimal(s.data(), s.data() + s.size(), v); }

std::string format(double v) {
  char buf[40];
  const std::size_t n = format_decimal(v, buf);
  EXPECT_LE(n, 32u);
  return std::string(buf, n);
}

TEST(PortNumberText, ParsesWhatCsvFilesHold) {
  double v = 0;
  EXPECT_TRUE(parse("1.5", v));
  EXPECT_EQ(v, 1.5);
  EXPECT_TRUE(parse("-250.0000", v));
  EXPECT_EQ(v, -250.0);
  EXPECT_TRUE(parse("+3e2", v));
  EXPECT_EQ(v, 300.0);
  EXPECT_TRUE(parse(" 0.1 ", v));
  EXPECT_EQ(v, 0.1);
  EXPECT_TRUE(parse(".5", v));
  EXPECT_EQ(v, 0.5);
  EXPECT_TRUE(parse("3.", v));
  EXPECT_EQ(v, 3.0);
  EXPECT_TRUE(parse("1e-5", v));
  EXPECT_EQ(v, 1e-5);
  EXPECT_TRUE(parse("-0", v));
  EXPECT_TRUE(v == 0.0 && std::signbit(v));
  EXPECT_TRUE(parse("1e400", v));
  EXPECT_TRUE(std::isinf(v));
  EXPECT_TRUE(parse("nan", v));
  EXPECT_TRUE(std::isnan(v));
  EXPECT_TRUE(parse("-Inf", v));
  EXPECT_TRUE(std::isinf(v) && v < 0);
  EXPECT_TRUE(parse("INFINITY", v));
  EXPECT_TRUE(std::isinf(v) && v > 0);
  for (const char* bad : {"", " ", "abc", "1.2.3", "1e", "1e+", "--1", "1,5", "0x10", "1 2", "nanx", "."})
    EXPECT_FALSE(parse(bad, v)) << "'" << bad << "'";
}

// Every double written in its shortest form with at most 15 significant
// digits reads back exactly (Clinger's fast path: the NC poses and anything
// `kincal` writes with ≤ 15 digits); 16–17 digits within one ulp.
TEST(PortNumberText, ParseIsExactOnTheFastPathAndWithinAnUlpBeyond) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> mm(-1500.0, 1500.0);
  int exact_checked = 0;
  for (int k = 0; k < 200000; ++k) {
    double v = mm(rng);
    if (k % 2 == 0) {
      // A number as a person or a 15-digit printer writes it.
      char b[40];
      std::snprintf(b, sizeof b, "%.*g", 1 + k % 15, v);
      std::from_chars(b, b + std::strlen(b), v);
    }
    char s[40];
    const auto r = std::to_chars(s, s + sizeof s, v);
    double back = 0;
    ASSERT_TRUE(parse_decimal(s, r.ptr, back)) << s;
    const std::size_t digits = static_cast<std::size_t>(std::count_if(s, r.ptr, [](char c) { return c >= '0' && c <= '9'; }));
    if (digits <= 15) {
      ++exact_checked;
      ASSERT_EQ(back, v) << s;
    } else {
      ASSERT_LE(std::fabs(back - v), std::nextafter(std::fabs(v), 1e300) - std::fabs(v)) << s;
    }
  }
  EXPECT_GT(exact_checked, 100000);
}

TEST(PortNumberText, FormatRoundTripsToTwelveDecimals) {
  std::mt19937_64 rng(11);
  for (int k = 0; k < 200000; ++k) {
    const double v = std::ldexp(static_cast<double>(rng() >> 11), static_cast<int>(rng() % 80) - 70) * ((rng() & 1) ? -1 : 1);
    const std::string s = format(v);
    double back = 0;
    ASSERT_TRUE(parse(s, back)) << s;
    // Fixed point below 1e9: 12 decimals (or the double's own resolution);
    // scientific above: 15 significant digits.
    const double tol = std::fabs(v) < 1e9 ? std::max(1e-12, 4.5e-16 * std::fabs(v)) : 6e-15 * std::fabs(v);
    ASSERT_LE(std::fabs(back - v), tol) << v << " -> " << s;
  }
  EXPECT_EQ(format(1.5), "1.5");
  EXPECT_EQ(format(-0.001), "-0.001");
  EXPECT_EQ(format(876.4016663204561), "876.401666320456");
  EXPECT_EQ(format(0.0), "0.0");
  EXPECT_EQ(format(1e-13), "0.0");
  EXPECT_EQ(format(999999999.9999999), "999999999.999999880791");  // the double itself, to 12 decimals
  EXPECT_EQ(format(1e9), "1.00000000000000e+09");
  EXPECT_EQ(format(-2.5e300), "-2.50000000000000e+300");
  EXPECT_EQ(format(std::numeric_limits<double>::quiet_NaN()), "nan");
  EXPECT_EQ(format(-std::numeric_limits<double>::infinity()), "-inf");
}

// ---- CSV -----------------------------------------------------------------------

struct Row {
  PoseCsvReader<double>::LineResult result;
  NcInput<double> point;
  std::string id;
};

std::vector<Row> read_all(const std::string& text, const char* const* inputs = nullptr, int input_count = 0) {
  PoseCsvReader<double> reader;
  reader.set_inputs(inputs, input_count);
  std::vector<Row> rows;
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(pos, end - pos);
    pos = end + 1;
    Row r;
    CsvId id;
    r.result = reader.feed(line.data(), line.size(), r.point, id);
    r.id.assign(id.text, id.size);
    if (r.result != PoseCsvReader<double>::LineResult::Skipped) rows.push_back(r);
  }
  return rows;
}

using LR = PoseCsvReader<double>::LineResult;

TEST(PortCsv, ReadsPosesWithAnyColumnOrderAndSkipsComments) {
  const auto rows = read_all(
      "\xEF\xBB\xBF# a comment\n"
      "\n"
      "layer,id,rz,ry,rx,z,y,x,temp,q1\r\n"
      "2,\"A,1\",0.3,0.2,0.1,-60,2.5,1.25,21.5,999\n"
      "# another\n"
      "2,B2, 0 ,0,0,0,0,0,20,\n");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].result, LR::Point);
  EXPECT_TRUE(rows[0].point.valid);
  EXPECT_EQ(rows[0].id, "A,1");
  EXPECT_EQ(rows[0].point.sequence, 1u);
  EXPECT_EQ(rows[0].point.pose(0), 1.25);
  EXPECT_EQ(rows[0].point.pose(1), 2.5);
  EXPECT_EQ(rows[0].point.pose(2), -60);
  EXPECT_EQ(rows[0].point.pose(3), 0.1);
  EXPECT_EQ(rows[0].point.pose(5), 0.3);
  EXPECT_TRUE(rows[0].point.has_temperature);
  EXPECT_EQ(rows[0].point.temperature, 21.5);
  EXPECT_EQ(rows[1].point.sequence, 2u);
  EXPECT_TRUE(rows[1].point.valid);
}

TEST(PortCsv, UsesTheSeqColumnAndFlagsBadRowsWithoutLosingThem) {
  const auto rows = read_all(
      "seq,x,y,z,rx,ry,rz\n"
      "10,1,2,3,0,0,0\n"
      "11,1,two,3,0,0,0\n"    // not a number
      "12,1,2,3,0,0\n"        // a field short
      "x13,1,2,3,0,0,0\n"     // bad sequence number: counted on from the last
      "15,nan,2,3,0,0,inf\n"  // NaN / Inf parse: the controller rejects them
      "16,\"1,2,3,0,0,0\n");  // unterminated quote
  ASSERT_EQ(rows.size(), 6u);
  const std::uint32_t seq[6] = {10, 11, 12, 13, 15, 16};
  const bool valid[6] = {true, false, false, false, true, false};
  for (int k = 0; k < 6; ++k) {
    EXPECT_EQ(rows[k].result, LR::Point) << k;
    EXPECT_EQ(rows[k].point.sequence, seq[k]) << k;
    EXPECT_EQ(rows[k].point.valid, valid[k]) << k;
  }
  EXPECT_TRUE(std::isnan(rows[4].point.pose(0)));
  EXPECT_TRUE(std::isinf(rows[4].point.pose(5)));
}

TEST(PortCsv, ReadsTheTimeAndTheFormulasNamedInputs) {
  // Formula effects (core/formula_effects.hpp): `time` and the machine's
  // named inputs, in the machine's order whatever the file's column order.
  static constexpr const char* kNames[2] = {"spindle_temp", "humidity"};
  const auto rows = read_all(
      "humidity,x,y,z,rx,ry,rz,time,spindle_temp,note\n"
      "0.45,1,2,3,0,0,0,12.5,31.25,a\n"
      "0.5,1,2,3,0,0,0,13,warm,b\n"  // an input that is not a number
      "0.55,1,2,3,0,0,0,,30,c\n",    // an empty time
      kNames, 2);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_TRUE(rows[0].point.valid);
  EXPECT_EQ(rows[0].point.time, 12.5);
  EXPECT_EQ(rows[0].point.inputs[0], 31.25);
  EXPECT_EQ(rows[0].point.inputs[1], 0.45);
  EXPECT_EQ(rows[0].point.inputs[2], 0.0);
  EXPECT_FALSE(rows[1].point.valid);
  EXPECT_FALSE(rows[2].point.valid);
  // Without time, 0; a named input the file lacks is a bad header.
  const auto plain = read_all("x,y,z,rx,ry,rz,spindle_temp\n1,2,3,0,0,0,30\n", kNames, 1);
  ASSERT_EQ(plain.size(), 1u);
  EXPECT_TRUE(plain[0].point.valid);
  EXPECT_EQ(plain[0].point.time, 0.0);
  EXPECT_EQ(plain[0].point.inputs[0], 30.0);
  EXPECT_EQ(read_all("x,y,z,rx,ry,rz,spindle_temp\n1,2,3,0,0,0,30\n", kNames, 2)[0].result, LR::BadHeader);
  // A reader told of no inputs ignores such columns.
  const auto none = read_all("x,y,z,rx,ry,rz,spindle_temp\n1,2,3,0,0,0,oops\n");
  EXPECT_TRUE(none[0].point.valid);
}

TEST(PortCsv, AHeaderWithoutThePoseColumnsIsRejected) {
  const auto rows = read_all("id,x,y,z,rx,ry\n1,0,0,0,0,0\n");
  ASSERT_FALSE(rows.empty());
  EXPECT_EQ(rows[0].result, LR::BadHeader);
  EXPECT_EQ(read_all("id,x,y,\"z,rx,ry,rz\n")[0].result, LR::BadHeader);
}

TEST(PortCsv, LongIdsAreCutAndMalformedRowsKeepTheCount) {
  PoseCsvReader<double> reader;
  std::string header = "id,x,y,z,rx,ry,rz";
  NcInput<double> p;
  CsvId id;
  EXPECT_EQ(reader.feed(header.data(), header.size(), p, id), LR::Skipped);
  std::string row = std::string(50, 'a') + ",0,0,0,0,0,0";
  EXPECT_EQ(reader.feed(row.data(), row.size(), p, id), LR::Point);
  EXPECT_EQ(id.size, kCsvIdCapacity - 1);
  reader.malformed_row(p, id);
  EXPECT_EQ(p.sequence, 2u);
  EXPECT_FALSE(p.valid);
}

TEST(PortCsv, WritesTheJointsCsvShapeOfKincalCompensate) {
  EXPECT_STREQ(JointCsvWriter::header(), "id,x,y,z,rx,ry,rz,q1,q2,q3,q4,q5,q6,status,seq,flags\n");
  NcInput<double> p;
  p.sequence = 42;
  p.pose << -250, 83.3333, 0, 0.05, -0.03, 0.08;
  CsvId id;
  const char* name = "L2 \"x\"";
  id.size = std::strlen(name);
  std::memcpy(id.text, name, id.size);
  kincal::Vec6<double> q;
  q << 860.0856784148923, 708.99, 823.5, -0.066963129408, 0.3275, 0.2039;
  char buf[kCsvLineCapacity];
  std::size_t n = JointCsvWriter::format(buf, id, p, q, "ok", kCommandHeld | kCommandSequenceGap);
  EXPECT_EQ(std::string(buf, n),
            "\"L2 \"\"x\"\"\",-250.0,83.3333,0.0,0.05,-0.03,0.08,860.085678414892,708.99,823.5,-0.066963129408,"
            "0.3275,0.2039,ok,42,held|gap\n");
  // The longest line fits the documented capacity.
  id.size = kCsvIdCapacity - 1;
  std::memset(id.text, '"', id.size);
  p.pose.setConstant(-1.234567890123e300);
  q.setConstant(-999999999.123456789);
  p.sequence = 4294967295u;
  n = JointCsvWriter::format(buf, id, p, q, "oversized correction", 0xFF);
  EXPECT_LE(n, 423u);
}

// ---- queues and the emulator ------------------------------------------------------

TEST(PortRingBuffer, FixedCapacityFifoThatRefusesWhenFull) {
  RingBuffer<int, 3> q;
  int v = 0;
  EXPECT_FALSE(q.pop(v));
  for (int round = 0; round < 5; ++round) {  // wraps around
    EXPECT_TRUE(q.push(3 * round));
    EXPECT_TRUE(q.push(3 * round + 1));
    EXPECT_TRUE(q.push(3 * round + 2));
    EXPECT_TRUE(q.full());
    EXPECT_FALSE(q.push(-1));
    for (int k = 0; k < 3; ++k) {
      ASSERT_TRUE(q.pop(v));
      EXPECT_EQ(v, 3 * round + k);
    }
    EXPECT_TRUE(q.empty());
  }
}

TEST(PortEmulator, RegistersFailOnDemand) {
  emulator::EncoderRegisters r;
  std::int32_t v = 0;
  EXPECT_EQ(r.write(6, 1), PortStatus::InvalidChannel);
  EXPECT_EQ(r.read(-1, v), PortStatus::InvalidChannel);
  EXPECT_EQ(r.write_verified(0, 1234, v), PortStatus::Ok);
  EXPECT_EQ(v, 1234);
  r.fail_writes(1, 2);
  EXPECT_EQ(r.write_verified(1, 5, v), PortStatus::WriteFailed);
  EXPECT_EQ(r.write_verified(1, 5, v), PortStatus::WriteFailed);
  EXPECT_EQ(r.write_verified(1, 5, v), PortStatus::Ok);
  r.fail_reads(2, 1);
  EXPECT_EQ(r.write_verified(2, 7, v), PortStatus::ReadFailed);
  EXPECT_EQ(r.value(2), 7);  // the write itself went through
  r.lose_writes(3, 1);
  EXPECT_EQ(r.write_verified(3, 9, v), PortStatus::ReadBackMismatch);
  EXPECT_EQ(v, 0);
  r.stick_bits(4, 0x80000000u, 0);  // sign bit stuck at 0
  EXPECT_EQ(r.write_verified(4, -3, v), PortStatus::ReadBackMismatch);
  EXPECT_EQ(r.write_verified(4, 3, v), PortStatus::Ok);
  EncoderOffsetScaling<double> s = EncoderOffsetScaling<double>::hybrid_default();
  std::int32_t c = 0;
  EXPECT_EQ(s.to_counts(3, 4e-4, c), PortStatus::Ok);
  EXPECT_EQ(c, 40000);
  EXPECT_EQ(s.to_counts(0, -0.3104, c), PortStatus::Ok);
  EXPECT_EQ(c, -310400);
  EXPECT_EQ(s.to_counts(0, 3000.0, c), PortStatus::OutOfRange);
  EXPECT_EQ(s.to_counts(0, std::numeric_limits<double>::quiet_NaN(), c), PortStatus::OutOfRange);
  EncoderOffsetScaling<float> sf = EncoderOffsetScaling<float>::hybrid_default();
  EXPECT_EQ(sf.to_counts(3, 21.5f, c), PortStatus::OutOfRange);  // 2.15e9 counts
}

TEST(PortEmulator, StreamUnderrunsOverrunsAndEnds) {
  emulator::NcStream<double, 2, 1> s;
  NcInput<double> p;
  EXPECT_EQ(s.receive(p), PortStatus::Underrun);
  p.sequence = 1;
  EXPECT_EQ(s.push(p), PortStatus::Ok);
  p.sequence = 2;
  EXPECT_EQ(s.push(p), PortStatus::Ok);
  p.sequence = 3;
  EXPECT_EQ(s.push(p), PortStatus::Overrun);
  EXPECT_EQ(s.push(p), PortStatus::Overrun);
  NcInput<double> got;
  EXPECT_EQ(s.receive(got), PortStatus::Ok);
  EXPECT_EQ(got.sequence, 1u);
  EXPECT_EQ(got.producer_overruns, 0);
  EXPECT_EQ(s.push(p), PortStatus::Ok);  // the kept point, now taken
  s.end();
  EXPECT_EQ(s.receive(got), PortStatus::Ok);
  EXPECT_EQ(got.sequence, 2u);
  EXPECT_EQ(s.receive(got), PortStatus::Ok);
  EXPECT_EQ(got.sequence, 3u);
  EXPECT_EQ(got.producer_overruns, 2);  // reported with the point it delayed
  EXPECT_EQ(s.receive(got), PortStatus::EndOfStream);
  JointCommand<double> c;
  EXPECT_EQ(s.send(c), PortStatus::Ok);
  EXPECT_EQ(s.send(c), PortStatus::Overrun);
  EXPECT_TRUE(s.pop(c));
  EXPECT_EQ(s.send(c), PortStatus::Ok);
  EXPECT_EQ(s.underruns(), 1);
  EXPECT_EQ(s.producer_overruns(), 2);
  EXPECT_EQ(s.send_overruns(), 1);
}

}  // namespace
