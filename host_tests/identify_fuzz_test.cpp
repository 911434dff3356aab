// Fuzz-style robustness: thousands of random mutations of a valid measurement
// CSV, parameter file and robot description. Each must either parse or throw
// InputError — no other exception, no crash, no hang (GUIDE "Bars": parsers
// are fuzzed). Deterministic seeds, so a failure reproduces.
#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "kincal/identify/csv.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/parameters.hpp"
#include "kincal/identify/robot.hpp"
#include "kincal/identify/simulate.hpp"

namespace ki = kincal::identify;

namespace {

std::string mutate(std::string s, std::mt19937_64& rng) {
  static const std::vector<std::string> inserts = {",", "\"", "nan", "NaN", "inf", "-inf", "1e999", "\n", "\r\n",
                                                   "{", "}", "[", "]", ":", "-", "0x1p3", "\\", "\xef\xbb\xbf",
                                                   std::string(1, '\0'), "\xff", "#", "  ", "1e-400", "\"\""};
  const int edits = 1 + static_cast<int>(rng() % 4);
  for (int e = 0; e < edits && !s.empty(); ++e) {
    const std::size_t at = rng() % s.size();
    switch (rng() % 6) {
      case 0: s[at] = static_cast<char>(rng() % 256); break;  // byte flip
      case 1: s.resize(at); break;                            // truncation
      case 2: s.insert(at, inserts[rng() % inserts.size()]); break;
      case 3: s.erase(at, 1 + rng() % 8); break;
      case 4: {  // duplicate a slice (repeated lines, keys, columns)
        const std::size_t n = 1 + rng() % 40;
        s.insert(at, s.substr(at, n));
        break;
      }
      default: s[at] = "0123456789.,-+e\"\n"[rng() % 17]; break;
    }
  }
  return s;
}

// Parses with `parse`; returns 1 if it parsed, 0 if it threw InputError —
// whose message must be one line naming `file` (issue #10: the replay never
// checked that) — and fails the test on anything else.
template <class F> int outcome(F&& parse, const std::string& input, const std::string& file) {
  try {
    parse(input);
    return 1;
  } catch (const ki::InputError& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.find('\n'), std::string::npos) << "not one line: " << m;
    EXPECT_EQ(m.rfind(file, 0), 0u) << "does not name " << file << ": " << m;
    return 0;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "unexpected exception " << e.what() << " for input:\n" << input;
  } catch (...) {
    ADD_FAILURE() << "unexpected non-std exception for input:\n" << input;
  }
  return 0;
}

}  // namespace

TEST(identifyFuzz, PoseCsvMutations) {
  const std::string valid =
      "id,layer,role,x,y,z,rx,ry,rz,mx,my,mz,mrx,mry,mrz,t1x,t1y,t1z,t2x,t2y,t2z,t3x,t3y,t3z,temp,time,"
      "dir1,dir2,dir3,dir4,dir5,dir6,status\n"
      "A1,0,cal,10,0,200,0.0174,0.0349,0.0523,10.03,-0.04,199.99,0.0178,0.0347,0.0518,1,2,3,4,5,6,7,8,9,20.5,0,"
      "1,-1,1,-1,1,-1,ok\n"
      "\"A,2\",1,test,0,10,200,0,0,0,,,,,,,,,,,,,,,,21,1.5,1,1,1,1,1,1,out of limits\n"
      "A3,2,cal,-10,0,210,-0.01,0.01,0.02,-9.9,0.01,210.01,0,0,0,1,2,3,4,5,6,7,8,9,22,3,-1,-1,-1,-1,-1,-1,ok\n";
  ASSERT_EQ(ki::parse_pose_table(valid, "f.csv").rows.size(), 3u);
  const ki::Robot robot = ki::builtin_robot("stewart-seed001");
  std::mt19937_64 rng(20240601);
  int parsed = 0;
  for (int i = 0; i < 3000; ++i) {
    parsed += outcome(
        [&](const std::string& s) {
          const ki::PoseTable t = ki::parse_pose_table(s, "f.csv");
          // Whatever parses must also be safe to simulate (NaN cannot get in).
          for (const ki::PoseRow& r : t.rows) ASSERT_TRUE(kincal::all_finite(r.commanded));
          ki::SimulateReport rep;
          ki::simulate(robot, robot, t, {}, rep);
        },
        mutate(valid, rng), "f.csv");
  }
  EXPECT_GT(parsed, 0);  // the mutations are not all fatal: both paths are exercised
  EXPECT_LT(parsed, 3000);
}

TEST(identifyFuzz, ParameterCsvMutations) {
  const std::string valid = "name,value\ndXB1,0.02\ndYB1,0.03\ndl1,-0.02\n\"dZP6\",0.04\n";
  const ki::Robot robot = ki::builtin_robot("stewart-seed001");
  ASSERT_EQ(ki::parse_parameters(valid, "p.csv", robot).values.size(), 4u);
  std::mt19937_64 rng(7);
  int parsed = 0;
  for (int i = 0; i < 2000; ++i)
    parsed += outcome([&](const std::string& s) { ki::apply_parameters(robot, ki::parse_parameters(s, "p.csv", robot)); },
                      mutate(valid, rng), "p.csv");
  EXPECT_GT(parsed, 0);
}

TEST(identifyFuzz, RobotJsonMutations) {
  for (const char* name : {"stewart-seed001", "hybrid-seed000"}) {
    const std::string valid = ki::robot_to_json(ki::builtin_robot(name));
    std::mt19937_64 rng(99);
    int parsed = 0;
    for (int i = 0; i < 2000; ++i)
      parsed += outcome(
          [&](const std::string& s) {
            const ki::Robot r = ki::parse_robot(s, "r.json");
            kincal::Vec6<double> q;
            (void)r.inverse(r.home_pose(), q);
            (void)ki::robot_to_json(r);
          },
          mutate(valid, rng), "r.json");
    EXPECT_GT(parsed, 0) << name;
    EXPECT_LT(parsed, 2000) << name;
  }
}

TEST(identifyFuzz, PathologicalInputs) {
  const std::vector<std::string> inputs = {std::string(100000, '['), std::string(5000, '{') + "\"a\":",
                                           std::string(1, '\0'), "\xef\xbb\xbf", "\"", "{\"format\":}", "null",
                                           std::string(10000, ','), "id\n" + std::string(3000, '\n')};
  for (const std::string& s : inputs) {
    outcome([](const std::string& t) { ki::parse_robot(t, "r.json"); }, s, "r.json");
    outcome([](const std::string& t) { ki::parse_pose_table(t, "f.csv"); }, s, "f.csv");
  }
}
