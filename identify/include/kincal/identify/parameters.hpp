// Parameter errors for `kincal simulate --errors PARAMS.csv` (GUIDE
// "Command-line contract"): `name,value` rows, each adding `value` to one
// geometric quantity of the nominal robot. The names per family live in one
// table in the family's folder (Family::parameter_specs,
// identify/src/families/<family>/): extending the error set is adding rows.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "kincal/identify/robot.hpp"

namespace kincal::identify {

struct ParameterSpec {
  std::string name;         // e.g. "dXB1" (case-sensitive: dXA1 ≠ dXa1)
  const char* unit;         // "mm", "rad" or "mm2" (the 6-UPS leg_offset_sq)
  std::string description;  // what the value is added to
  std::function<void(Robot&, double)> add;  // adds the value to the robot's geometry
};

// The valid names for the robot's family, in table order.
const std::vector<ParameterSpec>& parameter_specs(const Robot& robot);
std::vector<std::string> parameter_names(const Robot& robot);

struct ParameterValue {
  std::string name;
  double value = 0;
  std::size_t line = 0;  // source line, 0 if not from a file
};

struct ParameterSet {
  std::string file;
  std::vector<ParameterValue> values;
};

// Reads PARAMS.csv (header `name,value`; other columns are ignored with a
// warning through `warn`). Unknown or repeated names, non-finite values →
// InputError with file:line:column (unknown names list the valid ones).
ParameterSet parse_parameters(std::string_view text, const std::string& file, const Robot& robot,
                              const std::function<void(const std::string&)>& warn = {});
ParameterSet read_parameters(const std::string& path, const Robot& robot,
                             const std::function<void(const std::string&)>& warn = {});

// nominal + errors: each value added to its quantity. The workpiece frame and
// tool offset of a hybrid stay those of the nominal machine (they define the
// measurement frame, they are not part of the machine).
Robot apply_parameters(const Robot& nominal, const ParameterSet& errors);

// `--effect NAME:PARAM=VALUE`, parsed for syntax; EffectValues::set
// (effects.hpp) checks the names against the effect registry.
struct EffectSetting {
  std::string effect, parameter;
  double value = 0;
};
EffectSetting parse_effect_option(const std::string& text);
// `--effect NAME:PARAM=VALUE[,PARAM=VALUE...]`: several numbers of one
// effect in one option (leg_thermal:a1=1.5e-5,a2=2.5e-5).
std::vector<EffectSetting> parse_effect_options(const std::string& text);

}  // namespace kincal::identify
