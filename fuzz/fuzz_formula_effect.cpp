// libFuzzer target: the robot description key `effects` (formula effects,
// identify/formula_effect.hpp; issue #32). The text is a whole description;
// what reads must then evaluate (value and exact Jacobian) at a node with
// its start values, finitely or with the one-line error that names the
// node, and print its C++.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fuzz_check.hpp"
#include "kincal/identify/formula_effect.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace ki = kincal::identify;
  static const ki::FormulaContext context = [] {
    ki::FormulaContext c;
    c.family_variables = {"crank"};
    return c;
  }();
  const std::string text(reinterpret_cast<const char*>(data), size);
  kincal::fuzz::run(
      [&] {
        const std::vector<ki::FormulaEffect> effects = ki::read_formula_effects(text, "robot.json", context);
        for (const ki::FormulaEffect& e : effects) {
          const ki::FormulaLayout& l = e.layout();
          std::vector<double> vars(static_cast<std::size_t>(l.size()), 0.5);
          for (int j = 1; j <= l.joints; ++j) vars[static_cast<std::size_t>(l.q(j))] = 100.0 * j;
          const std::vector<double> params = e.start_values();
          const std::size_t outputs = static_cast<std::size_t>(e.output_count());
          std::vector<double> values(outputs), jacobian(outputs * params.size());
          ki::FormulaWorkspace ws;
          try {
            e.evaluate(vars.data(), params.data(), values.data(), jacobian.data(), "fuzz", ws);
            kincal::fuzz::check_finite_all(Eigen::Map<const Eigen::VectorXd>(values.data(), Eigen::Index(outputs)), "value");
          } catch (const ki::InputError& err) {
            kincal::fuzz::check_message(err, "");
          }
          if (e.cpp_function(e.cpp_function_name()).empty()) kincal::fuzz::broken("no C++", e.name());
        }
      },
      "robot.json");
  return 0;
}
