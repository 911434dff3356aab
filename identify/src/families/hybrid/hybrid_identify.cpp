// The hybrid's own pipeline and its narrative: seed 000's coarse encoder
// offsets by iterated OLS (Eq. (15)), then the identifiable source errors by
// Liu (Eq. (11), d of Eq. (14)), OLS, ridge or PCR, and by default the
// Gauss–Newton base on top; identify.hpp dispatches to it.
#include <algorithm>
#include <cmath>

#include "families/hybrid/hybrid_family.hpp"
#include "pipeline/pipeline_support.hpp"
#include "kincal/identify/effect_calibration.hpp"
#include "kincal/identify/hybrid_calibration.hpp"
#include "kincal/identify/hybrid_error_model.hpp"
#include "kincal/identify/identifiability.hpp"
#include "kincal/identify/model.hpp"

namespace kincal::identify {

Identification HybridFamilyPipeline::identify_own(const Robot& robot, const PoseTable& data, const IdentifyOptions& options,
                                                  std::ostream& narrative) const {
  Identification out;
  std::string estimator = options.estimator.empty() ? "liu" : options.estimator;
  EstimatorOptions eo = estimator_options(options, estimator);
  HybridCalibrationOptions ho;
  // Liu by default, unless the data reject its shrinkage (then ridge, said
  // below); an estimator asked for by name is kept.
  if (!options.estimator.empty()) ho.liu_fallback = std::nullopt;
  ho.estimator = eo.kind;
  ho.ridge = eo.ridge;
  ho.pcr = eo.pcr;
  ho.coarse_layers = options.coarse_layers;
  narrative << "identify: " << options.data_file << ", robot " << robot.name << " (seed 000: coarse encoder offsets, then fine "
            << estimator << " on the identifiable source errors)\n";
  const HybridCalibration c = calibrate_hybrid(robot, data, ho);
  const bool liu_rejected = c.options.estimator != ho.estimator;
  if (liu_rejected) {
    estimator = to_string(c.options.estimator);
    eo = estimator_options(options, estimator);
    narrative << "  liu rejected by the data: its shrinkage adds F = " << c.liu_check_f << " (p = " << c.liu_check_p
              << ") to the OLS residual, so it removes the machine's errors, not noise; fine stage by " << estimator
              << " (--estimator liu keeps liu)\n";
  }
  ho = c.options;  // the outlier refits keep the estimator chosen here
  narrative << "  cal nodes " << c.cal_nodes << "\n  coarse (Eq. (15)) on " << c.coarse_ids.size() << " nodes";
  if (!c.options.coarse_layers.empty()) {
    narrative << " of layer(s)";
    for (long long l : c.options.coarse_layers) narrative << " " << l;
    if (c.coarse_test_rows > 0)
      narrative << " (" << c.coarse_test_rows << " of them test rows: held out from the fine stage, not from the "
                << "encoder offsets)";
  }
  narrative << ": " << c.coarse_history.size() << " rounds, converged: " << (c.coarse_converged ? "yes" : "no")
            << "\n";
  for (std::size_t k = 0; k < c.coarse_history.size(); ++k)
    narrative << "    round " << k + 1 << ": gauge residual rms " << 1e3 * c.coarse_history[k].rms_residual
              << " um, relative change " << c.coarse_history[k].relative_change << "\n";
  narrative << "  fine: " << c.kept.size() << " of " << HybridErrorModel::kParameterCount << " source errors identifiable (Sec. 4.1 reconstruction), rank "
            << c.rank << ", condition number " << c.condition_number << "\n";
  if (c.linearisations.size() > 1) {
    // Large source errors: seed 000's one linear step did not predict the
    // model's residual at its estimate (hybrid_calibration.hpp).
    narrative << "  fine: linearised " << c.linearisations.size() << " times (one step left the residual "
              << std::sqrt(c.linearisations.front().rss / std::max(c.linearisations.front().rss_predicted, 1e-300))
              << "x the linear prediction; large source errors)"
              << (c.fine_linearisation_valid ? "" : ", NOT converged: the result is where the iteration stopped")
              << "\n";
    for (std::size_t k = 0; k < c.linearisations.size(); ++k) {
      const HybridFineLinearisation& l = c.linearisations[k];
      const double rows = 9.0 * double(c.cal_nodes);
      narrative << "    linearisation " << k + 1 << ": "
                << (l.damping > 0 ? "damped least-squares step (lambda " + detail::number_text(l.damping) + ")"
                                  : std::string(k == 0 ? "seed 000's step" : "the estimator's step"))
                << ", residual rms "
                << 1e3 * std::sqrt(l.rss / rows) << " um (predicted " << 1e3 * std::sqrt(l.rss_predicted / rows)
                << " um)\n";
    }
  }
  // What would make the others identifiable (pure-translation layers leave
  // whole families of source errors without effect on the gauge).
  const IdentifiabilityHint hint = hybrid_identifiability_hint(robot, c);
  if (!hint.text.empty()) narrative << "  not identifiable from these poses; to separate them: " << hint.text << "\n";
  // Nodes inconsistent with the others (identify/outliers.hpp): the
  // sequential search on the fine design; left out unless --keep-outliers.
  const HybridOutlierSearch search = hybrid_outlier_search(robot, data, c, ho);
  const OutlierScreen screen = screen_of(search, c.outlier_p_threshold, options.keep_outliers);
  print_outlier_screen(narrative, options.data_file, screen, c.cal_nodes, options.keep_outliers);
  const HybridCalibration& used = screen.excluded ? search.rest : c;
  const Estimate& est = *used.estimate(used.options.estimator);
  narrative << "  estimator " << describe_estimate(est, eo) << "; fit residual rms "
            << 1e3 * std::sqrt(est.rss / double(std::max<Eigen::Index>(1, est.rows))) << " um per gauge coordinate\n";
  CalibrationModel model = hybrid_model(robot, used, options.data_file);
  // The base by default (issue #14): seed 000's estimate finished by
  // Gauss–Newton on the nonlinear model, shrunk toward the coarse machine by
  // a ridge penalty whose k is chosen by GCV at the solution — the base of
  // `identify --effects` with no effect. Seed 000's single Liu step
  // compensated clean data of one design to 1.33–4.02 µm over three noise
  // seeds, this base to 1.28–1.65 µm (docs/diagnosis.md). An estimator asked
  // for by name is seed 000's fine stage with it, as is.
  std::string base_line;
  if (options.estimator.empty()) {
    EffectCalibrationReport rep;
    model = calibrate_with_effects(robot, screen.excluded ? without_rows(data, screen.flagged) : data, {}, {},
                                       &rep);
    model.data_file = options.data_file;
    base_line = rep.base;
    narrative << "  base: " << rep.base << "; cal residual rms " << rep.rms_cal_um_final
              << " um per gauge coordinate (seed 000's " << estimator << " step as is: --estimator " << estimator
              << ")\n";
  }
  const HybridCompensation comp = hybrid_compensation_from_model(model);
  out.before = hybrid_residuals(robot, nullptr, data);
  out.after = hybrid_residuals(robot, &comp, data);
  out.nominal = "pose error from the gauge, measured - nominal model";
  detail::add_unevaluated_warnings(out, options.data_file, out.after);
  detail::add_table_warning(out, model, data);
  if (options.summary) {
    nlohmann::json& j = out.summary;
    j["estimator"] = base_line.empty() ? estimator : model.estimator;
    j["estimator_settings"] = base_line.empty() ? estimator_settings(est, eo) : model.settings;
    if (!base_line.empty()) {
      j["base"] = base_line;
      j["fine_stage"] = {{"estimator", estimator}, {"estimator_settings", estimator_settings(est, eo)}};
    }
    j["rank"] = used.rank;
    j["parameters"] = HybridErrorModel::kParameterCount;
    j["identifiable"] = used.kept_names;
    j["dropped"] = used.dropped_names;
    j["dropped_hint"] = hint.text;
    j["condition_number"] = used.condition_number;
    j["liu_d"] = used.liu.liu_d;
    j["liu_check"] = {{"f", c.liu_check_f}, {"p_value", c.liu_check_p}, {"rejected", liu_rejected}};
    j["fine_linearisations"] = used.linearisations.size();
    j["fine_linearisation_valid"] = used.fine_linearisation_valid;
    j["coarse_iterations"] = used.coarse_history.size();
    j["coarse_nodes"] = used.coarse_ids.size();
    j["coarse_layers"] = used.options.coarse_layers;
    j["sigma_um"] = 1e3 * std::sqrt(est.sigma2_unbiased);
  }
  out.model = model;
  out.screen = screen;
  out.node_tests = c.node_tests;
  return out;
}


}  // namespace kincal::identify
