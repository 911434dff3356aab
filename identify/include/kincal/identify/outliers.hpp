// Measurement blunders (a mis-seated reflector, a mistyped row): one
// mechanism for `identify`, `identify --effects` and `diagnose` (issue #11
// item 5). Each fit hands over its linearised problem at the solution and the
// id / line of each node; estimators.hpp's sequential_outliers tests every
// node (deleted-node F test, Bonferroni over the nodes), sets the most
// significant aside and tests the rest, until none is flagged or the misfit
// proves systematic. Flagged rows are then left out and the model refitted
// once, unless the user keeps them (--keep-outliers) or the misfit is
// systematic (then excluding rows would hide a missing effect).
#pragma once

#include <algorithm>
#include <ostream>
#include <string>
#include <vector>

#include "kincal/identify/csv.hpp"
#include "kincal/identify/estimators.hpp"

namespace kincal::identify {

struct OutlierScreen {
  std::vector<NodeTest> flagged;  // in the order found, each with its statistic at that step
  bool systematic = false;        // still flagged after a tenth of the nodes was set aside
  double p_threshold = 0;         // α / testable nodes, of the first test
  bool excluded = false;          // the fit left the flagged rows out
};

// `nodes[k]`: id and line of the node numbered k in problem.row_node.
OutlierScreen screen_outliers(const LinearProblem& problem, const std::vector<NodeTest>& nodes,
                              const SequentialOutlierOptions& options = {},
                              const OutlierReport* first_round = nullptr);

// The node test a fit already ran on its final problem, for the screen's
// first round (sequential_outliers): none by default; a calibration that
// keeps its report overloads this next to its type (found by argument-
// dependent lookup), e.g. outlier_report_of(const StewartCalibration&).
template <class Fit> const OutlierReport* outlier_report_of(const Fit&) { return nullptr; }

// The screen with refits: the sequential search runs about one solution, and
// leaving a gross error out moves the solution, so the fit is repeated without
// the flagged rows and screened again until no new row is flagged (at most 5
// rounds). At most a tenth of the nodes (at least 2) may be flagged in all;
// beyond that the misfit is systematic and `rest` is `all`.
// problem_of(fit) / nodes_of(fit): the fit's linearised problem and node ids;
// refit(table): the same fit on other rows.
template <class Fit> struct ScreenedFit {
  OutlierScreen screen;
  Fit rest;
};
template <class Fit, class ProblemOf, class NodesOf, class Refit>
ScreenedFit<Fit> screen_and_refit(const PoseTable& data, const Fit& all, ProblemOf problem_of, NodesOf nodes_of,
                                  Refit refit, SequentialOutlierOptions options = {}) {
  ScreenedFit<Fit> out{{}, all};
  const Eigen::Index budget =
      std::max<Eigen::Index>(2, Eigen::Index(options.max_fraction * double(nodes_of(all).size())));
  for (int round = 0; round < 5; ++round) {
    options.max_removed = budget - Eigen::Index(out.screen.flagged.size());
    const OutlierScreen s = screen_outliers(problem_of(out.rest), nodes_of(out.rest), options, outlier_report_of(out.rest));
    if (round == 0) out.screen.p_threshold = s.p_threshold;
    out.screen.flagged.insert(out.screen.flagged.end(), s.flagged.begin(), s.flagged.end());
    if (s.systematic) {
      out.screen.systematic = true;
      out.rest = all;
      break;
    }
    if (s.flagged.empty()) break;
    out.rest = refit(without_rows(data, out.screen.flagged));
  }
  return out;
}

// What a family's outlier search returns (stewart_outlier_search,
// hybrid_outlier_search, stewart_target_outlier_search): the flagged nodes in
// the order found (each with its statistic at that step), and `rest`, the fit
// without them — or the fit of all nodes when none was flagged or the misfit
// is systematic.
template <class Fit> struct OutlierSearch {
  std::vector<NodeTest> removed;
  Fit rest;
  bool systematic = false;
};
template <class Fit> OutlierSearch<Fit> outlier_search_of(ScreenedFit<Fit> s) {
  return {std::move(s.screen.flagged), std::move(s.rest), s.screen.systematic};
}

// A fit's node tests from its report at the solution: node k of the report is
// nodes[k] (its .id and .line); the ids of the flagged ones go to `outlying`.
template <class Node>
void add_node_tests(const OutlierReport& report, const std::vector<Node>& nodes, std::vector<NodeTest>& tests,
                    std::vector<std::string>& outlying) {
  for (const NodeStatistic& st : report.nodes) {
    const Node& n = nodes[std::size_t(st.node)];
    tests.push_back({n.id, n.line, st.f, st.p_value, st.testable, st.outlying});
    if (st.outlying) outlying.push_back(n.id);
  }
}

// The policy every command follows: leave the flagged rows out unless the
// user keeps them or the misfit is systematic.
inline bool leave_out(const OutlierScreen& screen, bool keep) {
  return !keep && !screen.systematic && !screen.flagged.empty();
}

// A family's search result (StewartOutlierSearch, HybridOutlierSearch:
// `removed`, `systematic`) as the screen the commands report, with the
// policy applied.
template <class Search> OutlierScreen screen_of(const Search& search, double p_threshold, bool keep) {
  OutlierScreen s;
  s.flagged = search.removed;
  s.systematic = search.systematic;
  s.p_threshold = p_threshold;
  s.excluded = leave_out(s, keep);
  return s;
}

// `data` without the rows of `rows` (matched by line and id).
PoseTable without_rows(const PoseTable& data, const std::vector<NodeTest>& rows);

// The screen's fields in SUMMARY.json / DIAG.json (nlohmann::json or
// ordered_json): outliers (ids), outlier_tests (id, line, F, p),
// outliers_excluded, outliers_systematic, outlier_p_threshold.
template <class Json> void add_outlier_fields(Json& j, const OutlierScreen& screen) {
  Json ids = Json::array(), tests = Json::array();
  for (const NodeTest& t : screen.flagged) {
    ids.push_back(t.id);
    tests.push_back({{"id", t.id}, {"line", t.line}, {"f", t.f}, {"p_value", t.p_value}});
  }
  j["outliers"] = ids;
  j["outlier_tests"] = tests;
  j["outliers_excluded"] = screen.excluded;
  j["outliers_systematic"] = screen.systematic;
  j["outlier_p_threshold"] = screen.p_threshold;
}

// One line per flagged node for a terminal: "FILE:LINE: node 'ID': F = …, p = …".
std::string describe_outliers(const std::string& file, const OutlierScreen& screen);

// The screen as identify and diagnose print it: none, or the flagged nodes
// and what was done with them (of `nodes` cal nodes; `keep`: --keep-outliers).
void print_outlier_screen(std::ostream& os, const std::string& file, const OutlierScreen& screen, std::size_t nodes,
                          bool keep);

}  // namespace kincal::identify
