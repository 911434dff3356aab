// The registry of machine families (family.hpp). Adding a family is its
// folder and one line in families() (docs/architecture.md "Adding a machine
// family").
#include "families/family.hpp"

#include <stdexcept>
#include <string>
#include <vector>

#include "effects/base_fit.hpp"
#include "families/family_errors.hpp"
#include "families/hybrid/hybrid_family.hpp"
#include "families/rus6/rus6_family.hpp"
#include "families/stewart/stewart_family.hpp"
#include "kincal/identify/joint_limits.hpp"

namespace kincal::identify {

namespace {

// The registry: one line per family.
const std::vector<const Family*>& families() {
  static const std::vector<const Family*> registered = {&stewart_family(), &hybrid_family(), &rus6_family()};
  return registered;
}

}  // namespace

// A pipeline offers no stepped base fit unless it says so (effects
// alternate with its fit_base).
std::unique_ptr<detail::SteppedBaseFit> FamilyPipeline::stepped_base_fit(const Robot&, const PoseTable&,
                                                                         const std::vector<std::optional<EffectNode>>&,
                                                                         EstimatorKind, double) const {
  return nullptr;
}

const FamilyPipeline* Family::pipeline_reading(const Robot& robot, const PoseTable& data) const {
  if (own_pipeline_ == nullptr || data.in_instrument_frame) return nullptr;
  if (!data.has_targets && !data.has_measured) return own_pipeline_;
  return own_pipeline_->reads(robot, data) ? own_pipeline_ : nullptr;
}

const Family& family_of(const Robot& robot) {
  for (const Family* f : families())
    if (f->description().describes(robot)) return *f;
  // Robot's variant holds one of the registered families' geometries; a
  // geometry added to the variant without its family here is a programming
  // error, said rather than answered by another family.
  throw std::logic_error("no registered family describes robot '" + robot.name +
                         "' (identify/src/families/families.cpp: add its family to families())");
}

const Family* family_named(const std::string& name) {
  for (const Family* f : families())
    if (name == f->name()) return f;
  return nullptr;
}

std::string family_names() {
  std::string out;
  for (const Family* f : families()) out += (out.empty() ? "" : ", ") + std::string(f->name());
  return out;
}

namespace detail {

std::unique_ptr<FamilyErrors> family_errors(const Robot& robot) {
  return family_of(robot).error_model().errors(without_limits(robot));
}

}  // namespace detail

}  // namespace kincal::identify
