#include "kincal/identify/outliers.hpp"

#include <algorithm>
#include <sstream>

#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

OutlierScreen screen_outliers(const LinearProblem& problem, const std::vector<NodeTest>& nodes,
                              const SequentialOutlierOptions& options, const OutlierReport* first_round) {
  const SequentialOutliers s = sequential_outliers(problem, options, first_round);
  OutlierScreen out;
  out.systematic = s.systematic;
  out.p_threshold = s.p_threshold;
  for (const NodeStatistic& st : s.removed) {
    if (st.node < 0 || std::size_t(st.node) >= nodes.size())
      throw InputError("outlier screen: node " + std::to_string(st.node) + " has no id");
    NodeTest t = nodes[std::size_t(st.node)];
    t.f = st.f;
    t.p_value = st.p_value;
    t.testable = st.testable;
    t.outlying = st.outlying;
    out.flagged.push_back(t);
  }
  return out;
}

PoseTable without_rows(const PoseTable& data, const std::vector<NodeTest>& rows) {
  PoseTable out = data;
  for (const NodeTest& t : rows) {
    const auto it = std::find_if(out.rows.begin(), out.rows.end(),
                                 [&](const PoseRow& r) { return r.line == t.line && r.id == t.id; });
    if (it != out.rows.end()) out.rows.erase(it);
  }
  return out;
}

std::string describe_outliers(const std::string& file, const OutlierScreen& screen) {
  std::ostringstream os;
  for (const NodeTest& t : screen.flagged)
    os << "    " << file << ":" << t.line << ": node '" << t.id << "': F = " << t.f << ", p = " << t.p_value << "\n";
  return os.str();
}

void print_outlier_screen(std::ostream& os, const std::string& file, const OutlierScreen& screen, std::size_t nodes,
                          bool keep) {
  if (screen.flagged.empty()) {
    os << "  outliers: none (deleted-node F test, p < " << screen.p_threshold << ")\n";
    return;
  }
  os << "  nodes inconsistent with the others (set aside one at a time, most significant first):\n"
     << describe_outliers(file, screen);
  if (screen.systematic)
    os << "  still flagged after " << screen.flagged.size() << " of " << nodes
       << " nodes were set aside: the misfit is systematic (an unmodelled effect, or data without noise), "
          "not a few bad nodes; no node is left out (kincal diagnose names the effect)\n";
  else if (screen.excluded)
    os << "  the model is fitted without them (keep them with --keep-outliers)\n";
  else if (keep)
    os << "  the model still uses every node (--keep-outliers)\n";
}

}  // namespace kincal::identify
