// `kincal effects [--robot R] [--json]`: every registered effect (the GUIDE's
// five candidates and any registered by the user), its parameters, what it
// models and the measurement columns it needs — the vocabulary of
// `simulate --effect NAME:PARAM=VALUE`, `identify --effects` and
// `diagnose --effects`.
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>

#include "commands.hpp"
#include "kincal/identify/effects.hpp"
#include "kincal/identify/robot.hpp"

namespace ki = kincal::identify;

namespace kincal_app {

CLI::App* add_effects_command(CLI::App& app, EffectsArgs& a) {
  CLI::App* e = app.add_subcommand(
      "effects", "list every effect: its parameters, what it models and the measurement columns it needs");
  e->add_option("--robot", a.robot,
                "built-in robot name or robot description file: its parameter names, machine data and the "
                "formula effects of its `effects` key (default: stewart-seed001)");
  e->add_flag("--json", a.json, "print the list as JSON");
  return e;
}

int run_effects(const EffectsArgs& a) {
  const ki::Robot robot = ki::load_robot(a.robot.empty() ? std::string("stewart-seed001") : a.robot);
  const kincal::EffectParameters<double> frame = ki::effect_frame(robot);
  nlohmann::json list = nlohmann::json::array();
  for (const ki::Effect* effect : ki::effect_candidates(robot)) {
    nlohmann::json e;
    e["name"] = effect->name();
    e["description"] = effect->description();
    e["parameters"] = effect->parameter_names(robot);
    e["inputs"] = effect->inputs();
    list.push_back(e);
  }
  // What the family offers formula effects beside q, dir, load, temp, …
  nlohmann::json offered = nlohmann::json::array();
  for (const ki::FamilyFormulaVariable& v : ki::family_formula_variables(robot))
    offered.push_back({{"name", v.name}, {"description", v.description}});
  if (a.json) {
    nlohmann::json out;
    out["robot"] = robot.name;
    out["screw_lead_mm"] = frame.screw_lead;
    out["effects"] = list;
    out["formula_family_variables"] = offered;
    std::cout << out.dump(2) << "\n";
    return 0;
  }
  // The cyclic effect's period in the joints' unit: a screw's lead (mm), or
  // a rotary motor's period at its joint (rad, the 6-RUS).
  const bool rotary = robot.revolute(0);
  std::cout << "effects for robot " << robot.name << " (" << (rotary ? "cyclic period " : "screw lead ")
            << frame.screw_lead << (rotary ? " rad" : " mm")
            << "; set one with --effect NAME:PARAM=VALUE in simulate, name them in identify/diagnose --effects)\n";
  for (const nlohmann::json& e : list) {
    std::cout << "\n" << e["name"].get<std::string>() << ": " << e["description"].get<std::string>()
              << "\n  parameters:";
    for (const auto& p : e["parameters"]) std::cout << " " << p.get<std::string>();
    std::cout << "\n  needs: " << e["inputs"].get<std::string>() << "\n";
  }
  if (!offered.empty()) {
    std::cout << "\nformula variables this family offers (robot description key `effects`; NAME is this joint's in a "
                 "joint-kind formula, NAME1..NAME6 any joint's):\n";
    for (const nlohmann::json& v : offered)
      std::cout << "  " << v["name"].get<std::string>() << ": " << v["description"].get<std::string>() << "\n";
  }
  return 0;
}

}  // namespace kincal_app
