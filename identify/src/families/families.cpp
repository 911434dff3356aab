// The registry of machine families (family.hpp). Adding a family is its
// folder and one line in kFamilies (docs/architecture.md "Adding a machine
// family").
#include "families/family.hpp"

#include <stdexcept>
#include <string>

#include "effects/base_fit.hpp"
#include "families/family_errors.hpp"
#include "families/hybrid/hybrid_family.hpp"
#include "families/rus6/rus6_family.hpp"
#include "families/stewart/stewart_family.hpp"
#include "kincal/identify/joint_limits.hpp"

namespace kincal::identify {

namespace {

const StewartFamily kStewart;
const HybridFamily kHybrid;
const Rus6Family kRus6;
const Family* const kFamilies[] = {&kStewart, &kHybrid, &kRus6};

}  // namespace

// Without an own pipeline nothing routes a table to it (reads_own_measurement
// is false): reaching here is a caller's bug, said as one.
detail::BaseModel Family::fit_base(const Robot& robot, const PoseTable&, const std::vector<std::optional<EffectNode>>&,
                                   std::optional<EstimatorKind>, bool, double) const {
  throw std::logic_error(std::string("the ") + name() + " family has no own pipeline (robot '" + robot.name +
                         "'): its measurements go to the target fit");
}

// A family offers no stepped base fit unless it says so (effects alternate
// with its fit_base).
std::unique_ptr<detail::SteppedBaseFit> Family::stepped_base_fit(const Robot&, const PoseTable&,
                                                                 const std::vector<std::optional<EffectNode>>&,
                                                                 EstimatorKind, double) const {
  return nullptr;
}

const Family& family_of(const Robot& robot) {
  for (const Family* f : kFamilies)
    if (f->describes(robot)) return *f;
  // Robot's variant holds one of the registered families' geometries; a
  // geometry added to the variant without its family here is a programming
  // error, said rather than answered by another family.
  throw std::logic_error("no registered family describes robot '" + robot.name +
                         "' (identify/src/families/families.cpp: add its family to kFamilies)");
}

const Family* family_named(const std::string& name) {
  for (const Family* f : kFamilies)
    if (name == f->name()) return f;
  return nullptr;
}

std::string family_names() {
  std::string out;
  for (const Family* f : kFamilies) out += (out.empty() ? "" : ", ") + std::string(f->name());
  return out;
}

namespace detail {

std::unique_ptr<FamilyErrors> family_errors(const Robot& robot) {
  return family_of(robot).errors(without_limits(robot));
}

}  // namespace detail

}  // namespace kincal::identify
