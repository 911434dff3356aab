// `kincal export linuxcnc --model MODEL.json --out DIR`: an identified 6-UPS
// model as the files a LinuxCNC 2.9 hexapod (genhexkins) needs
// (identify/linuxcnc_export.hpp, docs/linuxcnc.md).
#include <filesystem>
#include <iostream>
#include <string>

#include "commands.hpp"
#include "kincal/identify/files.hpp"
#include "kincal/identify/input_error.hpp"
#include "kincal/identify/linuxcnc_export.hpp"
#include "kincal/identify/model.hpp"

namespace ki = kincal::identify;

namespace kincal_app {

CLI::App* add_export_command(CLI::App& app, ExportArgs& a) {
  CLI::App* e = app.add_subcommand("export", "write an identified model in another controller's own format");
  e->require_subcommand(0, 1);  // none: main says which targets there are
  CLI::App* l = e->add_subcommand(
      "linuxcnc", "the files a LinuxCNC 2.9 hexapod (genhexkins) needs: HAL setp lines of the calibrated joints, "
                  "home offsets, joint compensation tables, an INI fragment and a README (docs/linuxcnc.md)");
  l->add_option("--model", a.model, "MODEL.json from kincal identify (a 6-UPS model)")->required();
  l->add_option("--out", a.out, "directory to write (refused if it exists, unless --force)")->required();
  l->add_option("--data", a.data,
                "measured poses on which the README predicts the error of what LinuxCNC cannot carry "
                "(default: the model's data file, if it is there)");
  l->add_flag("--force", a.force, "replace an existing --out directory (as one step)");
  l->add_option("--units", a.units, "LinuxCNC's machine units, [TRAJ] LINEAR_UNITS (default mm)")
      ->check(CLI::IsMember({"mm", "inch"}));
  l->add_option("--home-offsets", a.home_offsets,
                "the configuration's HOME_OFFSET of joints 0..5 today, 'h0,...,h5' in --units (default: the "
                "nominal strut lengths at the robot's home pose)");
  l->add_option("--tolerance-um", a.tolerance_um,
                "largest deviation of LinuxCNC's interpolated compensation from kincal's, um; above it the export warns (default 0.1; tables aim at half of it)")
      ->check(decimal(0, 1e6, true));
  return l;
}

int run_export(const ExportArgs& a) {
  ki::check_outputs({a.out}, {a.model, a.data});
  ki::check_export_directory(a.out, a.force);
  const ki::CalibrationModel model = ki::read_model_file(a.model);
  ki::check_linuxcnc_family(model);
  ki::LinuxCncExportOptions options;
  options.inch = a.units == "inch";
  options.comp_tolerance_mm = a.tolerance_um * 1e-3;
  if (!a.home_offsets.empty()) {
    const std::vector<double> h = number_list(a.home_offsets, "--home-offsets");
    if (h.size() != 6) throw ki::InputError("--home-offsets: give six numbers, one per joint, not " + std::to_string(h.size()));
    options.home_offsets = Eigen::Map<const kincal::Vec6<double>>(h.data());
  }
  // The measured poses: --data, else the model's own data file where it is.
  std::string data_path = a.data;
  if (data_path.empty() && !model.data_file.empty()) {
    std::error_code ec;
    if (std::filesystem::is_regular_file(model.data_file, ec)) data_path = model.data_file;
  }
  ki::PoseTable data;
  if (!data_path.empty()) {
    ki::PoseTableOptions read;
    read.warn = warn;
    data = ki::read_pose_table(data_path, read);
    options.data = &data;
  } else {
    warn(a.model + ": warning: no measured poses (--data, or the model's data file '" + model.data_file +
         "'): the README does not predict the error of what LinuxCNC cannot carry");
  }
  const ki::LinuxCncExport out = ki::linuxcnc_export(model, options);
  for (const std::string& w : out.warnings) warn(a.model + ": warning: " + w);
  ki::write_export_directory(out.files, a.out, a.force);
  std::cout << "wrote " << a.out << "/:";
  for (const auto& [name, text] : out.files) std::cout << " " << name;
  std::cout << "\n";
  if (!out.not_carried.empty()) {
    std::cout << "not carried by LinuxCNC:";
    for (const std::string& n : out.not_carried) std::cout << " " << n;
    std::cout << " (" << a.out << "/README.md says what error remains without them)\n";
  }
  for (const ki::LinuxCncPrediction& p : out.predictions)
    std::cout << "  predicted " << p.what << ": " << p.rms_position_mm * 1e3 << " um RMS over " << p.poses
              << " poses\n";
  return 0;
}

}  // namespace kincal_app
