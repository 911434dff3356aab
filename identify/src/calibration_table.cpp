#include "kincal/identify/calibration_table.hpp"

#include <string>

#include "kincal/core/compensation.hpp"
#include "kincal/identify/hybrid_calibration.hpp"
#include "kincal/identify/hybrid_error_model.hpp"
#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

namespace {

template <class Machine>
void finish(CalibrationTable<Machine>& t, const CalibrationModel& model, const CalibrationTableOptions& options) {
  t.effects = to_table(model.effects.to_core(model.nominal));
  if (options.max_correction) {
    for (int i = 0; i < 6; ++i) t.bounds.max_correction[i] = (*options.max_correction)(i);
  }
  t = seal_table(t);
  const CompensationStatus st = validate_table(t);
  if (st != CompensationStatus::Ok)
    throw InputError(std::string("the calibration table fails its check (") + to_string(st) +
                     "): a correction above its bound or a value out of range");
}

}  // namespace

StewartCalibrationTable<double> stewart_calibration_table(const CalibrationModel& model,
                                                          const CalibrationTableOptions& options) {
  if (!model.nominal.is_stewart()) throw InputError("a 6-UPS calibration table needs a model of a 6-UPS robot");
  const StewartGeometry<double>& nominal = model.nominal.stewart();
  StewartCalibrationTable<double> t{};
  t.machine.nominal = to_table(nominal);
  t.machine.calibrated = to_table(calibrated_robot(model).stewart());  // seed 001: IK of the calibrated geometry
  t.bounds = default_bounds(nominal);
  finish(t, model, options);
  return t;
}

HybridCalibrationTable<double> hybrid_calibration_table(const CalibrationModel& model,
                                                        const CalibrationTableOptions& options) {
  if (!model.nominal.is_hybrid()) throw InputError("a hybrid calibration table needs a model of a hybrid robot");
  const HybridCompensation c = hybrid_compensation_from_model(model);
  HybridCalibrationTable<double> t{};
  t.machine.nominal = to_table(c.nominal);
  t.machine.up_split = HybridErrorModelOptions().up_split;  // the model B was identified with
  for (int i = 0; i < 6; ++i) t.machine.encoder_offsets[i] = c.encoder_offsets(i);
  for (int k = HybridErrorModel::kEncoderCount; k < kHybridSourceErrorCount; ++k)
    t.machine.source_errors[k] = c.structural.size() > 0 ? c.structural(k) : 0.0;
  t.bounds = default_bounds(c.nominal);
  finish(t, model, options);
  return t;
}

AnyCalibrationTable calibration_table(const CalibrationModel& model, const CalibrationTableOptions& options) {
  if (model.nominal.is_hybrid()) return hybrid_calibration_table(model, options);
  return stewart_calibration_table(model, options);
}

}  // namespace kincal::identify
