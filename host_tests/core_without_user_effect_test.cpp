// A build without the user joint effect's code (KINCAL_CORE_USER_EFFECT=0, as
// the firmware images are built so that their worst-case stack stays
// statically bounded): a table that carries user-effect numbers is refused
// with a status, one without them compensates as usual.
#define KINCAL_CORE_USER_EFFECT 0
#include <gtest/gtest.h>

#include "kincal/core/compensation.hpp"
#include "kincal/core/reference_machines.hpp"

namespace {

using namespace kincal;

TEST(coreWithoutUserEffect, TableWithUserNumbersIsRefused) {
  const StewartCalibrationTable<double> plain = nominal_table(make_stewart_seed001<double>());
  const Compensator<StewartMachine<double>> ok(plain, trust_table_bounds);
  EXPECT_EQ(ok.status(), CompensationStatus::Ok);

  StewartCalibrationTable<double> with_user = plain;
  with_user.effects.user[2] = 1e-5;
  const StewartCalibrationTable<double> sealed = seal_table(with_user);
  EXPECT_EQ(validate_table(sealed), CompensationStatus::Ok);  // a valid table ...
  Compensator<StewartMachine<double>> refused(sealed, trust_table_bounds);
  EXPECT_EQ(refused.status(), CompensationStatus::TableValues);  // ... this build cannot run
  refused.set_user_effect([](const double*, int, const Vec6<double>&, const EffectInputs<double>&) { return 0.0; });
  EXPECT_EQ(refused.status(), CompensationStatus::TableValues);  // setting code does not change that
  Vec6<double> q = Vec6<double>::Constant(-1.0);
  auto state = refused.start(Vec6<double>::Zero());
  EXPECT_EQ(refused.compensate(state, Pose<double>::from_xyz_rpy(Vec6<double>(0, 0, 200, 0, 0, 0)), q),
            CompensationStatus::TableValues);
  EXPECT_EQ(q, Vec6<double>::Zero());  // the held output: the command the stream started from
}

}  // namespace
