// The estimators' shared checks and message formatting (estimator_detail.hpp).
#include "estimate/estimator_detail.hpp"

#include <cstdio>

#include "kincal/identify/input_error.hpp"

namespace kincal::identify::detail {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

std::string fmt(double v, const char* format) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

std::string idx(Index i) { return std::to_string(i); }

void validate_design(const LinearProblem& p) {
  const Index n = p.H.rows(), m = p.H.cols();
  if (n == 0 || m == 0) throw InputError("estimation: empty design matrix (" + idx(n) + " x " + idx(m) + ")");
  if (!p.names.empty() && static_cast<Index>(p.names.size()) != m) {
    throw InputError("estimation: " + std::to_string(p.names.size()) + " parameter names for " + idx(m) + " columns");
  }
  for (Index j = 0; j < m; ++j) {
    for (Index i = 0; i < n; ++i) {
      if (!std::isfinite(p.H(i, j))) {
        throw InputError("estimation: design entry at row " + idx(i) + ", column '" + column_name(p, j) +
                         "' is not finite");
      }
    }
  }
  if (p.weights) {
    if (p.weights->size() != n) {
      throw InputError("estimation: " + idx(p.weights->size()) + " weights for " + idx(n) + " rows");
    }
    for (Index i = 0; i < n; ++i) {
      const double w = (*p.weights)(i);
      if (!std::isfinite(w) || !(w > 0)) {
        throw InputError("estimation: weight of row " + idx(i) + " is " + fmt(w) + " (must be finite and > 0)");
      }
    }
  }
  if (!p.row_node.empty() && static_cast<Index>(p.row_node.size()) != n) {
    throw InputError("estimation: row_node has " + std::to_string(p.row_node.size()) + " entries for " + idx(n) +
                     " rows");
  }
  if (n <= m) {
    throw InputError("estimation: too few measurements, " + idx(n) + " rows for " + idx(m) +
                     " parameters (need more rows than parameters to estimate the noise variance)");
  }
}

void validate_y(const LinearProblem& p) {
  if (p.y.size() != p.H.rows()) {
    throw InputError("estimation: y has " + idx(p.y.size()) + " entries for " + idx(p.H.rows()) + " rows");
  }
  for (Index i = 0; i < p.y.size(); ++i) {
    if (!std::isfinite(p.y(i))) throw InputError("estimation: measurement y at row " + idx(i) + " is not finite");
  }
}

}  // namespace kincal::identify::detail
