// Measurement / poses CSV v1: parsing, strict numbers, every rejected input
// with its file:line:column, warnings for unknown columns, and a write/read
// round trip.
#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <vector>

#include "kincal/identify/csv.hpp"
#include "kincal/identify/input_error.hpp"

namespace ki = kincal::identify;

namespace {

ki::InputError table_error(const std::string& text) {
  try {
    ki::parse_pose_table(text, "m.csv");
  } catch (const ki::InputError& e) {
    return e;
  }
  ADD_FAILURE() << "no InputError for:\n" << text;
  return ki::InputError("none");
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

TEST(identifyCsv, ParsesFreeColumnOrderAndOptionalGroups) {
  const std::string text =
      "# a comment line\n"
      "rz,ry,rx,z,y,x,id,layer,role,temp,time,mx,my,mz,mrx,mry,mrz,dir1,dir2,dir3,dir4,dir5,dir6\r\n"
      "0.03,0.02,0.01,200,2,1,A1,0,cal,20.5,0.0,1.1,2.1,200.1,0.011,0.021,0.031,1,-1,1,-1,1,+1\r\n"
      "\n"
      "0,0,0,210,0,0,\"B,2\",1,test,21,1.5,0,0,210,0,0,0,-1,-1,-1,-1,-1,-1\n";
  const ki::PoseTable t = ki::parse_pose_table(text, "m.csv");
  ASSERT_EQ(t.rows.size(), 2u);
  EXPECT_TRUE(t.has_measured && t.has_layer && t.has_role && t.has_temp && t.has_time && t.has_dir);
  EXPECT_FALSE(t.has_targets || t.has_q || t.has_status);
  const ki::PoseRow& a = t.rows[0];
  EXPECT_EQ(a.id, "A1");
  EXPECT_EQ(a.line, 3u);
  EXPECT_EQ(a.commanded, (kincal::Vec6<double>() << 1, 2, 200, 0.01, 0.02, 0.03).finished());
  ASSERT_TRUE(a.measured.has_value());
  EXPECT_EQ((*a.measured)(2), 200.1);
  EXPECT_EQ(*a.layer, 0);
  EXPECT_EQ(a.role, ki::Role::Cal);
  EXPECT_EQ(*a.temp, 20.5);
  EXPECT_EQ((*a.dir)(1), -1);
  EXPECT_EQ((*a.dir)(5), 1);
  const ki::PoseRow& b = t.rows[1];
  EXPECT_EQ(b.id, "B,2");
  EXPECT_EQ(b.line, 5u);
  EXPECT_EQ(b.role, ki::Role::Test);
}

TEST(identifyCsv, GaugeTargetsAndJointCommands) {
  std::string header = "id,x,y,z,rx,ry,rz,t1x,t1y,t1z,t2x,t2y,t2z,t3x,t3y,t3z,q1,q2,q3,q4,q5,q6\n";
  std::string row = "n1,0,0,0,0,0,0,1,2,3,4,5,6,7,8,9,10,11,12,13,14,15\n";
  const ki::PoseTable t = ki::parse_pose_table(header + row, "m.csv");
  ASSERT_TRUE(t.rows[0].targets.has_value());
  EXPECT_EQ((*t.rows[0].targets)(0, 1), 4.0);  // t2x
  EXPECT_EQ((*t.rows[0].targets)(2, 2), 9.0);  // t3z
  EXPECT_EQ((*t.rows[0].q)(5), 15.0);
}

TEST(identifyCsv, UnknownColumnsAreListedOnceAsAWarning) {
  std::vector<std::string> warnings;
  ki::PoseTableOptions opt;
  opt.warn = [&](const std::string& w) { warnings.push_back(w); };
  const ki::PoseTable t =
      ki::parse_pose_table("id,x,y,z,rx,ry,rz,operator,humidity\na,0,0,0,0,0,0,bob,40\nb,0,0,0,0,0,0,amy,41\n", "m.csv", opt);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], "m.csv:1: warning: unknown columns 'operator', 'humidity' ignored");
  EXPECT_EQ(t.ignored_columns, (std::vector<std::string>{"operator", "humidity"}));
}

TEST(identifyCsv, NanAndInfAreRejectedWithPosition) {
  {
    const ki::InputError e = table_error("id,x,y,z,rx,ry,rz\na,0,0,0,0,0,0\nb,1,NaN,0,0,0,0\n");
    EXPECT_EQ(std::string(e.what()), "m.csv:3:5: non-finite value 'NaN' in column 'y' (NaN/Inf are rejected)");
  }
  {
    const ki::InputError e = table_error("id,x,y,z,rx,ry,rz\na,0,0,-inf,0,0,0\n");
    EXPECT_EQ(e.line(), 2u);
    EXPECT_EQ(e.column(), 7u);
    EXPECT_TRUE(contains(e.message(), "non-finite value '-inf' in column 'z'")) << e.what();
  }
  {
    const ki::InputError e = table_error("id,x,y,z,rx,ry,rz\na,0,0,1e999,0,0,0\n");
    EXPECT_TRUE(contains(e.message(), "out of range")) << e.what();
  }
  for (const std::string bad : {"1.5x", "0x10", "1,5", "--1", " ", "1 2"}) {
    const ki::InputError e = table_error("id,x,y,z,rx,ry,rz\na,0,0," + bad + ",0,0,0\n");
    EXPECT_EQ(e.line(), 2u) << bad;
  }
}

TEST(identifyCsv, MissingRequiredColumnsAreNamed) {
  const ki::InputError e = table_error("id,x,y,rx,ry\na,0,0,0,0\n");
  EXPECT_EQ(std::string(e.what()), "m.csv:1: missing required columns: z, rz");
  const ki::InputError m = table_error("id,x,y,z,rx,ry,rz,mx,my,mz\na,0,0,0,0,0,0,0,0,0\n");
  EXPECT_TRUE(contains(m.message(), "incomplete measured pose columns, missing: mrx, mry, mrz")) << m.what();
  const ki::InputError q = table_error("id,x,y,z,rx,ry,rz,q1,q2\na,0,0,0,0,0,0,0,0\n");
  EXPECT_TRUE(contains(q.message(), "missing: q3, q4, q5, q6")) << q.what();
}

TEST(identifyCsv, DuplicateIdsAreRejected) {
  const ki::InputError e = table_error("id,x,y,z,rx,ry,rz\nA1,0,0,0,0,0,0\nA2,0,0,0,0,0,0\nA1,1,0,0,0,0,0\n");
  EXPECT_EQ(std::string(e.what()), "m.csv:4:1: duplicate id 'A1' (first at line 2)");
}

TEST(identifyCsv, StructuralErrors) {
  EXPECT_EQ(std::string(table_error("").what()), "m.csv:1:1: empty file (expected a header row)");
  EXPECT_EQ(std::string(table_error("# only a comment\n\n").what()),
            "m.csv:3:1: no header row (the file has only comments and blank lines)");
  EXPECT_EQ(std::string(table_error("id,x,y,z,rx,ry,rz\n").what()), "m.csv:1: no data rows after the header");
  {
    const ki::InputError e = table_error("id,x,y,z,rx,ry,rz\na,0,0,0,0,0\n");
    EXPECT_TRUE(contains(e.what(), "m.csv:2: row has 6 fields, the header has 7")) << e.what();
  }
  {
    const ki::InputError e = table_error("id,x,y,z,rx,ry,rz\na,0,0,0,0,0,0,9\n");
    EXPECT_TRUE(contains(e.what(), "m.csv:2:15: row has 8 fields")) << e.what();
  }
  {
    const ki::InputError e = table_error("id,x,y,z,rx,ry,rz\n\"a,0,0,0,0,0,0\n");
    EXPECT_EQ(std::string(e.what()), "m.csv:2:1: unterminated quoted field");
  }
  {
    const ki::InputError e = table_error("id,x,y,z,rx,ry,rz\na\"b,0,0,0,0,0,0\n");
    EXPECT_EQ(std::string(e.what()), "m.csv:2:2: stray quote inside an unquoted field");
  }
  {
    const ki::InputError e = table_error("id,x,y,z,x,ry,rz\na,0,0,0,0,0,0\n");
    EXPECT_EQ(std::string(e.what()), "m.csv:1:10: duplicate column 'x' (first at column 4)");
  }
  {
    const ki::InputError e = table_error("id,x,y,z,rx,ry,rz\n,0,0,0,0,0,0\n");
    EXPECT_EQ(std::string(e.what()), "m.csv:2:1: empty id");
  }
  {
    const ki::InputError e = table_error("id,x,y,z,rx,ry,rz,role\na,0,0,0,0,0,0,train\n");
    EXPECT_EQ(std::string(e.what()), "m.csv:2:15: role must be 'cal' or 'test', not 'train'");
  }
  {
    const ki::InputError e =
        table_error("id,x,y,z,rx,ry,rz,dir1,dir2,dir3,dir4,dir5,dir6\na,0,0,0,0,0,0,1,1,0,1,1,1\n");
    EXPECT_TRUE(contains(e.what(), "approach direction must be -1 or +1, not '0' in column 'dir3'")) << e.what();
  }
  {
    const ki::InputError e = table_error("id,x,y,z,rx,ry,rz,layer\na,0,0,0,0,0,0,1.5\n");
    EXPECT_TRUE(contains(e.what(), "not an integer: '1.5' in column 'layer'")) << e.what();
  }
}

TEST(identifyCsv, WriteThenReadRoundTrip) {
  ki::PoseTable t;
  t.file = "x.csv";
  t.has_measured = t.has_role = t.has_temp = t.has_status = true;
  ki::PoseRow r;
  r.id = "weird \"id\", 1";
  r.commanded << 0.1, -0.2, 200.30000000000001, 1e-7, -3.5e-5, 0.017453292519943295;
  r.measured = r.commanded * 1.0000001;
  r.role = ki::Role::Test;
  r.temp = 21.25;
  r.status = "ok";
  t.rows.push_back(r);
  ki::PoseRow f = r;
  f.id = "failed";
  f.measured.reset();
  f.status = "out of limits";
  f.role = ki::Role::Cal;
  t.rows.push_back(f);
  std::ostringstream os;
  ki::write_pose_table(t, os);
  const ki::PoseTable back = ki::parse_pose_table(os.str(), "x.csv");
  ASSERT_EQ(back.rows.size(), 2u);
  EXPECT_EQ(back.rows[0].id, r.id);
  EXPECT_EQ(back.rows[0].commanded, r.commanded);  // shortest round-trip text: exact
  EXPECT_EQ(*back.rows[0].measured, *r.measured);
  EXPECT_EQ(back.rows[0].role, ki::Role::Test);
  EXPECT_EQ(*back.rows[0].temp, 21.25);
  EXPECT_EQ(back.rows[1].status, "out of limits");
  EXPECT_FALSE(back.rows[1].measured.has_value());
  // A measured field left empty on a row without a failure status is an error.
  const ki::InputError e = table_error("id,x,y,z,rx,ry,rz,mx,my,mz,mrx,mry,mrz\na,0,0,0,0,0,0,,,,,,\n");
  EXPECT_TRUE(contains(e.what(), "m.csv:2:15: empty value in column 'mx'")) << e.what();
}

TEST(identifyCsv, NumberFormattingIsShortestRoundTrip) {
  EXPECT_EQ(ki::format_number(0.1), "0.1");
  EXPECT_EQ(ki::format_number(200.0), "200");
  EXPECT_EQ(ki::format_number(-1.25e-9), "-1.25e-09");
}
