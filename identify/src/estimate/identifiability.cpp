// Identifiability: rank, seed 000 Section 4.1 reconstructions, observability
// indices, collinearity report. See identifiability.hpp and docs/estimators.md.
#include "kincal/identify/identifiability.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <ostream>
#include <sstream>
#include <stdexcept>

#include "kincal/identify/decompositions.hpp"
#include "kincal/identify/input_error.hpp"

namespace kincal::identify {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

std::string name_of(const std::vector<std::string>& names, Index j) {
  if (!names.empty() && j < static_cast<Index>(names.size())) return names[static_cast<std::size_t>(j)];
  return "x" + std::to_string(j);
}

std::string fmt(double v, const char* format = "%.4g") {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

void check_design(const MatrixXd& H, const char* what) {
  if (H.rows() == 0 || H.cols() == 0) {
    throw InputError(std::string(what) + ": empty design matrix (" + std::to_string(H.rows()) + " x " +
                     std::to_string(H.cols()) + ")");
  }
  for (Index j = 0; j < H.cols(); ++j) {
    for (Index i = 0; i < H.rows(); ++i) {
      if (!std::isfinite(H(i, j))) {
        throw InputError(std::string(what) + ": design entry at row " + std::to_string(i) + ", column " +
                         std::to_string(j) + " is not finite");
      }
    }
  }
}

void check_names(const std::vector<std::string>& names, Index cols) {
  if (!names.empty() && static_cast<Index>(names.size()) != cols) {
    throw std::invalid_argument("identifiability: " + std::to_string(names.size()) + " names for " +
                                std::to_string(cols) + " columns");
  }
}

struct ScaledSvd {
  VectorXd scale;  // D
  VectorXd s;      // min(n, m) singular values of H·D⁻¹, descending
  MatrixXd V;      // m × m (only when asked)
  Index rank = 0;
  double rcond = 0, tolerance = 0;
};

// The SVD of H·D⁻¹ (n × m) from the triangular factor R of H = Q·R: Q is
// orthonormal, so H·D⁻¹ = Q·(R·D⁻¹) has the singular values and right
// singular vectors of the m × m matrix R·D⁻¹, and H's column norms are R's.
// One Householder QR (2nm² flops) and a small SVD instead of bidiagonalising
// the whole tall design (issue #13).
ScaledSvd scaled_svd_of_factor(const MatrixXd& R, double rcond, ColumnScaling scaling, bool want_v) {
  ScaledSvd out;
  out.scale = column_scales(R, scaling);
  const MatrixXd Rs = R * out.scale.cwiseInverse().asDiagonal();
  if (want_v) {
    Eigen::BDCSVD<MatrixXd> svd(Rs, Eigen::ComputeFullV);
    out.s = svd.singularValues();
    out.V = svd.matrixV();
  } else {
    Eigen::BDCSVD<MatrixXd> svd(Rs);
    out.s = svd.singularValues();
  }
  out.rcond = effective_rcond(rcond);
  const double smax = out.s.size() > 0 ? out.s(0) : 0.0;
  out.tolerance = out.rcond * smax;
  out.rank = 0;
  for (Index k = 0; k < out.s.size(); ++k) {
    if (out.s(k) > out.tolerance && out.s(k) > 0) ++out.rank;
  }
  return out;
}

ScaledSvd scaled_svd(const MatrixXd& H, double rcond, ColumnScaling scaling, bool want_v) {
  return scaled_svd_of_factor(triangular_factor(H), rcond, scaling, want_v);
}

RankReport report_of(const ScaledSvd& sv, Index rows, Index cols, ColumnScaling scaling) {
  RankReport r;
  r.rows = rows;
  r.cols = cols;
  r.rank = sv.rank;
  r.rcond = sv.rcond;
  r.tolerance = sv.tolerance;
  r.scaling = scaling;
  r.column_scale = sv.scale;
  r.singular_values = sv.s;
  if (sv.rank < cols || sv.s.size() == 0) {
    r.condition_number = std::numeric_limits<double>::infinity();
  } else {
    r.condition_number = sv.s(0) / sv.s(sv.s.size() - 1);
  }
  return r;
}

// Reduced row echelon form of the k × m matrix A (rows: null-space basis
// vectors in scaled coordinates), partial pivoting within each column, left to
// right.
void reduced_row_echelon(MatrixXd& A, std::vector<Index>& pivots) {
  const Index k = A.rows(), m = A.cols();
  Index row = 0;
  pivots.clear();
  for (Index j = 0; j < m && row < k; ++j) {
    Index p = row;
    for (Index i = row + 1; i < k; ++i) {
      if (std::abs(A(i, j)) > std::abs(A(p, j))) p = i;
    }
    // Basis vectors have unit norm, so a pivot this small only reflects
    // rounding; skip the column (it is expressed through later pivots).
    if (std::abs(A(p, j)) <= 1e-6) continue;
    A.row(row).swap(A.row(p));
    A.row(row) /= A(row, j);
    for (Index i = 0; i < k; ++i) {
      if (i != row) A.row(i) -= A(i, j) * A.row(row);
    }
    pivots.push_back(j);
    ++row;
  }
}

std::vector<NullCombination> combinations_from(const ScaledSvd& sv, const std::vector<std::string>& names) {
  std::vector<NullCombination> out;
  const Index m = sv.V.rows();
  const Index k = m - sv.rank;
  if (k <= 0) return out;
  MatrixXd A = sv.V.rightCols(k).transpose();  // k × m, orthonormal rows
  std::vector<Index> pivots;
  reduced_row_echelon(A, pivots);
  for (Index row = 0; row < static_cast<Index>(pivots.size()); ++row) {
    const double biggest = A.row(row).cwiseAbs().maxCoeff();
    NullCombination c;
    // scaled coordinates v (H·D⁻¹·v = 0) → original units D⁻¹·v
    const Index lead = pivots[static_cast<std::size_t>(row)];
    const double lead_value = A(row, lead) / sv.scale(lead);
    std::string text;
    for (Index j = 0; j < m; ++j) {
      if (std::abs(A(row, j)) <= 1e-9 * biggest) continue;
      const double coef = (A(row, j) / sv.scale(j)) / lead_value;
      c.columns.push_back(j);
      c.coefficients.push_back(coef);
      if (!text.empty()) text += ' ';
      text += (coef < 0 ? "-" : "+") + fmt(std::abs(coef)) + "*" + name_of(names, j);
    }
    c.text = text;
    out.push_back(std::move(c));
  }
  return out;
}

std::vector<Index> unidentifiable_from(const ScaledSvd& sv) {
  std::vector<Index> out;
  const Index m = sv.V.rows();
  const Index k = m - sv.rank;
  if (k <= 0) return out;
  for (Index j = 0; j < m; ++j) {
    if (sv.V.row(j).tail(k).norm() > 1e-7) out.push_back(j);
  }
  return out;
}

}  // namespace

Eigen::VectorXd column_scales(const Eigen::MatrixXd& H, ColumnScaling scaling) {
  VectorXd d = VectorXd::Ones(H.cols());
  if (scaling == ColumnScaling::UnitNorm) {
    for (Index j = 0; j < H.cols(); ++j) {
      const double n = H.col(j).norm();
      if (n > 0 && std::isfinite(n)) d(j) = n;
    }
  }
  return d;
}

RankReport rank_by_svd(const Eigen::MatrixXd& H, double rcond, ColumnScaling scaling) {
  check_design(H, "rank");
  return report_of(scaled_svd(H, rcond, scaling, false), H.rows(), H.cols(), scaling);
}

Eigen::MatrixXd triangular_factor(const Eigen::MatrixXd& H) {
  if (H.rows() <= H.cols()) return H;
  const Eigen::HouseholderQR<MatrixXd> qr(H);
  return qr.matrixQR().topRows(H.cols()).triangularView<Eigen::Upper>();
}

RankReport rank_of_factor(const Eigen::MatrixXd& R, Eigen::Index rows, double rcond, ColumnScaling scaling) {
  return report_of(scaled_svd_of_factor(R, rcond, scaling, false), rows, R.cols(), scaling);
}

ColumnSelection reconstruct_by_column_selection(const Eigen::MatrixXd& H, const std::vector<Index>& xi,
                                                const std::vector<Index>& eta,
                                                const std::vector<std::string>& names, double tolerance) {
  check_design(H, "reconstruction");
  check_names(names, H.cols());
  const Index n = H.rows(), m = H.cols();
  std::vector<char> seen(static_cast<std::size_t>(m), 0);
  for (const auto* set : {&xi, &eta}) {
    for (Index j : *set) {
      if (j < 0 || j >= m) throw std::invalid_argument("reconstruction: column index " + std::to_string(j) + " out of range");
      if (seen[static_cast<std::size_t>(j)]) {
        throw std::invalid_argument("reconstruction: column " + std::to_string(j) + " listed twice");
      }
      seen[static_cast<std::size_t>(j)] = 1;
    }
  }
  ColumnSelection out;
  out.tolerance = tolerance >= 0 ? tolerance
                                 : effective_rcond(kDefaultRcond) * std::sqrt(static_cast<double>(m));
  MatrixXd Q(n, std::min(n, static_cast<Index>(xi.size() + eta.size())));
  Index q = 0;
  VectorXd r(n);
  // Distance of the unit column h_j from span(Q), classical Gram–Schmidt run
  // twice ("twice is enough", Giraud et al.) so the basis stays orthonormal.
  auto distance = [&](Index j) -> double {
    const double norm = H.col(j).norm();
    if (norm == 0) return 0.0;
    r = H.col(j) / norm;
    for (int pass = 0; pass < 2 && q > 0; ++pass) {
      const VectorXd proj = Q.leftCols(q).transpose() * r;
      r.noalias() -= Q.leftCols(q) * proj;
    }
    return r.norm();
  };
  auto append = [&](double dist) {
    Q.col(q) = r / dist;
    ++q;
  };
  for (Index j : xi) {
    const double dist = q < n ? distance(j) : 0.0;
    if (!(dist > out.tolerance)) {
      throw InputError("reconstruction: actuated-joint column '" + name_of(names, j) +
                       "' is dependent on the other actuated-joint columns (distance " + fmt(dist) +
                       " from their span): singular configuration or duplicated joint; H_xi must have full rank "
                       "(seed 000 Sec. 4.1)");
    }
    append(dist);
    out.kept.push_back(j);
  }
  for (Index j : eta) {
    const double dist = q < n ? distance(j) : 0.0;
    out.distance.push_back(dist);
    if (dist > out.tolerance) {  // rank([H h]) = rank(H) + 1: Step 2 keeps it
      append(dist);
      out.kept.push_back(j);
    } else {
      out.dropped.push_back(j);
    }
  }
  out.rank = q;
  for (Index j : out.kept) out.kept_names.push_back(name_of(names, j));
  for (Index j : out.dropped) out.dropped_names.push_back(name_of(names, j));
  return out;
}

SpectralReduction spectral_reduction(const Eigen::MatrixXd& H, double rcond, ColumnScaling scaling) {
  check_design(H, "spectral reduction");
  const ScaledSvd sv = scaled_svd(H, rcond, scaling, true);
  SpectralReduction out;
  out.rank = sv.rank;
  out.rank_report = report_of(sv, H.rows(), H.cols(), scaling);
  out.singular_values = sv.s.head(sv.rank);
  // H·D⁻¹ = U S Vᵀ → Δχ = D⁻¹ V₁ Δα, Z₁ = H D⁻¹ V₁ = U₁ S₁.
  out.phi1 = sv.scale.cwiseInverse().asDiagonal() * sv.V.leftCols(sv.rank);
  out.z1 = H * out.phi1;
  return out;
}

ObservabilityIndices observability_indices(const Eigen::VectorXd& s, Index rows) {
  ObservabilityIndices o;
  const Index m = s.size();
  if (m == 0 || rows <= 0) return o;
  const double smax = s.maxCoeff(), smin = s.minCoeff();
  if (smin > 0) {
    o.o1 = std::exp(s.array().log().mean()) / std::sqrt(static_cast<double>(rows));
    o.o5 = 1.0 / s.cwiseInverse().sum();
  }
  o.o2 = smax > 0 ? smin / smax : 0.0;
  o.o3 = smin;
  o.o4 = smax > 0 ? smin * smin / smax : 0.0;
  return o;
}

ObservabilityIndices observability_indices(const Eigen::MatrixXd& H, ColumnScaling scaling) {
  check_design(H, "observability");
  const ScaledSvd sv = scaled_svd(H, kDefaultRcond, scaling, false);
  VectorXd s = VectorXd::Zero(H.cols());  // n < m: the missing singular values are 0
  s.head(sv.s.size()) = sv.s;
  return observability_indices(s, H.rows());
}

std::vector<NullCombination> null_space_combinations(const Eigen::MatrixXd& H, const std::vector<std::string>& names,
                                                     double rcond) {
  check_design(H, "null space");
  check_names(names, H.cols());
  return combinations_from(scaled_svd(H, rcond, ColumnScaling::UnitNorm, true), names);
}

std::vector<Index> unidentifiable_columns(const Eigen::MatrixXd& H, double rcond) {
  check_design(H, "null space");
  return unidentifiable_from(scaled_svd(H, rcond, ColumnScaling::UnitNorm, true));
}

const char* to_string(PoseDof dof) {
  static const char* const kNames[6] = {"x", "y", "z", "rx", "ry", "rz"};
  const int k = static_cast<int>(dof);
  return k >= 0 && k < 6 ? kNames[k] : "?";
}

namespace {

using Pose6 = Eigen::Matrix<double, 6, 1>;

// The design rows of every measured pose moved by `shift`, stacked.
MatrixXd probe_design(const std::vector<Pose6>& poses, const PoseDesignRows& rows, const Pose6& shift, Index cols) {
  std::vector<MatrixXd> blocks;
  Index total = 0;
  for (const Pose6& p : poses) {
    MatrixXd b = rows(p + shift);
    if (b.size() == 0) continue;
    if (b.cols() != cols || !b.allFinite()) {
      throw std::invalid_argument("identifiability hint: the design rows at a pose have " + std::to_string(b.cols()) +
                                  " columns (or non-finite entries) for " + std::to_string(cols) + " parameters");
    }
    total += b.rows();
    blocks.push_back(std::move(b));
  }
  MatrixXd H(total, cols);
  Index at = 0;
  for (const MatrixXd& b : blocks) {
    H.middleRows(at, b.rows()) = b;
    at += b.rows();
  }
  return H;
}

// ‖H·v‖ / ‖D·v‖, D the column norms of the design at the measured poses (as
// null_space_combinations scaled it): how far the unit-scaled combination is
// from the null space of H. D is not the probe's own: a column that is zero
// at the measured poses (a leg in a coordinate plane) but not at the probe
// would otherwise look invisible after rescaling.
double visibility(const MatrixXd& H, const NullCombination& c, const VectorXd& D) {
  if (H.rows() == 0) return 0.0;
  VectorXd v = VectorXd::Zero(H.cols());
  for (std::size_t t = 0; t < c.columns.size(); ++t) v(c.columns[t]) = c.coefficients[t];
  const double den = D.cwiseProduct(v).norm();
  return den > 0 ? (H * v).norm() / den : 0.0;
}

std::string join_dofs(const std::vector<PoseDof>& dofs) {
  std::string out;
  for (PoseDof d : dofs) out += (out.empty() ? "" : ", ") + std::string(to_string(d));
  return out;
}

// What to measure, from the degrees of freedom that reveal a combination.
std::string measurement_phrase(const std::vector<PoseDof>& dofs, bool jointly) {
  std::vector<PoseDof> t, r;
  for (PoseDof d : dofs) (static_cast<int>(d) < 3 ? t : r).push_back(d);
  std::string pos, ori;
  if (t.size() == 1 && t.front() == PoseDof::Z) {
    pos = "add poses at another height (z), e.g. another layer";
  } else if (!t.empty()) {
    pos = "spread the positions (" + join_dofs(t) + ")";
  }
  const bool tilt_only = std::find(r.begin(), r.end(), PoseDof::Rz) == r.end();
  if (!r.empty()) ori = std::string(tilt_only ? "add tilted poses (" : "add poses with different orientations (") +
                        join_dofs(r) + ")";
  if (!pos.empty() && !ori.empty()) return pos + " or " + ori;
  if (!pos.empty()) return pos;
  if (!ori.empty()) return ori;
  if (jointly) return "move position and orientation together (no single degree of freedom separates them)";
  return "no change of pose separates them (a redundancy of the model: hold one at its nominal value or measure it "
         "directly)";
}

}  // namespace

IdentifiabilityHint identifiability_hint(const std::vector<NullCombination>& null_space,
                                         const std::vector<std::string>& names, const std::vector<Pose6>& poses,
                                         const PoseDesignRows& rows, const HintOptions& options) {
  IdentifiabilityHint out;
  if (null_space.empty()) return out;
  if (!rows) throw std::invalid_argument("identifiability hint: no design-rows function");
  if (!(options.translation_step > 0) || !(options.rotation_step > 0) || !(options.visible > 0) ||
      !(options.ratio >= 1)) {
    throw std::invalid_argument("identifiability hint: steps and the visibility threshold must be > 0, ratio >= 1");
  }
  Index cols = 0;
  for (const NullCombination& c : null_space)
    for (Index j : c.columns) cols = std::max(cols, j + 1);
  cols = std::max(cols, static_cast<Index>(names.size()));
  auto step = [&](int dof) { return dof < 3 ? options.translation_step : options.rotation_step; };
  // The measured poses themselves: the baseline the probes must clearly exceed.
  const MatrixXd H0 = probe_design(poses, rows, Pose6::Zero(), cols);
  const VectorXd D = column_scales(H0);
  std::vector<MatrixXd> probes;
  for (int dof = 0; dof < 6; ++dof) probes.push_back(probe_design(poses, rows, step(dof) * Pose6::Unit(dof), cols));
  Pose6 all;
  for (int dof = 0; dof < 6; ++dof) all(dof) = step(dof);
  const MatrixXd joint = probe_design(poses, rows, all, cols);

  std::vector<char> involved(static_cast<std::size_t>(cols), 0);
  for (const NullCombination& c : null_space) {
    CombinationHint h;
    h.combination = c;
    // Well above what the measured poses show: rounding for an exact null
    // combination, the small singular value for a near-null one (a rank
    // tolerance above rounding).
    const double threshold = std::max(options.visible, options.ratio * visibility(H0, c, D));
    for (int dof = 0; dof < 6; ++dof)
      if (visibility(probes[static_cast<std::size_t>(dof)], c, D) > threshold) h.revealed_by.push_back(PoseDof(dof));
    h.revealed_jointly = h.revealed_by.empty() && visibility(joint, c, D) > threshold;
    h.measurement = measurement_phrase(h.revealed_by, h.revealed_jointly);
    for (Index j : c.columns) involved[static_cast<std::size_t>(j)] = 1;
    out.combinations.push_back(std::move(h));
  }
  for (Index j = 0; j < cols; ++j)
    if (involved[static_cast<std::size_t>(j)]) out.parameters.push_back(name_of(names, j));

  // Group the combinations by the measurement that separates them, in order of
  // first appearance; list each group's parameters once.
  std::vector<std::string> phrases;
  std::vector<std::vector<char>> members;
  for (const CombinationHint& h : out.combinations) {
    auto it = std::find(phrases.begin(), phrases.end(), h.measurement);
    if (it == phrases.end()) {
      phrases.push_back(h.measurement);
      members.emplace_back(static_cast<std::size_t>(cols), 0);
      it = phrases.end() - 1;
    }
    std::vector<char>& m = members[static_cast<std::size_t>(it - phrases.begin())];
    for (Index j : h.combination.columns) {
      m[static_cast<std::size_t>(j)] = 1;
      if (options.leading_only) break;
    }
  }
  std::string text;
  for (std::size_t g = 0; g < phrases.size(); ++g) {
    std::string list;
    std::size_t count = 0, listed = 0;
    for (Index j = 0; j < cols; ++j) {
      if (!members[g][static_cast<std::size_t>(j)]) continue;
      ++count;
      if (listed < options.max_names) {
        list += (list.empty() ? "" : ", ") + name_of(names, j);
        ++listed;
      }
    }
    if (count > listed) list += " (+" + std::to_string(count - listed) + " more)";
    text += (text.empty() ? "" : "; ") + list + ": " + phrases[g];
  }
  out.text = text;
  return out;
}

CollinearityReport collinearity_report(const Eigen::MatrixXd& H, const std::vector<std::string>& names,
                                       const CollinearityOptions& options) {
  check_design(H, "collinearity");
  check_names(names, H.cols());
  const Index m = H.cols();
  const ScaledSvd sv = scaled_svd(H, options.rcond, ColumnScaling::UnitNorm, true);
  CollinearityReport rep;
  rep.rank = report_of(sv, H.rows(), H.cols(), ColumnScaling::UnitNorm);
  for (Index j = 0; j < m; ++j) rep.names.push_back(name_of(names, j));
  const Index r = sv.rank;
  rep.unidentifiable = unidentifiable_from(sv);
  rep.null_space = combinations_from(sv, names);
  std::vector<char> unident(static_cast<std::size_t>(m), 0);
  for (Index j : rep.unidentifiable) unident[static_cast<std::size_t>(j)] = 1;

  // φ_jk = V_jk² / s_k² over the identified components (Belsley, Kuh & Welsch 1980).
  MatrixXd phi(m, r);
  for (Index k = 0; k < r; ++k) phi.col(k) = sv.V.col(k).array().square() / (sv.s(k) * sv.s(k));
  rep.vif.resize(m);
  rep.variance_proportions.resize(m, r);
  for (Index j = 0; j < m; ++j) {
    const double total = phi.row(j).sum();
    rep.vif(j) = unident[static_cast<std::size_t>(j)] ? std::numeric_limits<double>::infinity() : total;
    rep.variance_proportions.row(j) = total > 0 ? (phi.row(j) / total).eval() : Eigen::RowVectorXd::Zero(r).eval();
  }
  rep.condition_indices.resize(r);
  for (Index k = 0; k < r; ++k) rep.condition_indices(k) = sv.s(0) / sv.s(k);

  auto hint_for = [&](const std::string& name) { return options.hint ? options.hint(name) : std::string(); };

  // Not identifiable: the null space, named.
  for (Index j : rep.unidentifiable) {
    ParameterNote note;
    note.column = j;
    note.name = rep.names[static_cast<std::size_t>(j)];
    std::string combos;
    for (const NullCombination& c : rep.null_space) {
      if (std::find(c.columns.begin(), c.columns.end(), j) == c.columns.end()) continue;
      if (!combos.empty()) combos += "; ";
      combos += "[" + c.text + "]";
    }
    note.text = note.name + " is not identifiable: the measurements do not change along " +
                (combos.empty() ? std::string("a null-space direction") : combos);
    note.hint = hint_for(note.name);
    rep.notes.push_back(std::move(note));
  }
  // Confounded: ≥ 2 parameters with proportion > threshold on one component
  // whose condition index exceeds the threshold.
  for (Index k = 0; k < r; ++k) {
    if (!(rep.condition_indices(k) > options.condition_index_threshold)) continue;
    ConfoundedGroup g;
    g.component = k;
    g.condition_index = rep.condition_indices(k);
    for (Index j = 0; j < m; ++j) {
      if (unident[static_cast<std::size_t>(j)]) continue;
      if (rep.variance_proportions(j, k) > options.proportion_threshold) {
        g.columns.push_back(j);
        g.proportions.push_back(rep.variance_proportions(j, k));
      }
    }
    if (g.columns.size() < 2) continue;
    for (std::size_t a = 0; a < g.columns.size(); ++a) {
      ParameterNote note;
      note.column = g.columns[a];
      note.name = rep.names[static_cast<std::size_t>(g.columns[a])];
      std::string others, props;
      for (std::size_t b = 0; b < g.columns.size(); ++b) {
        if (!props.empty()) props += ", ";
        props += fmt(g.proportions[b], "%.2f");
        if (b == a) continue;
        if (!others.empty()) others += ", ";
        others += rep.names[static_cast<std::size_t>(g.columns[b])];
      }
      note.text = note.name + " is confounded with " + others + " (variance proportions " + props +
                  " on condition index " + fmt(g.condition_index, "%.3g") + ")";
      note.hint = hint_for(note.name);
      rep.notes.push_back(std::move(note));
    }
    rep.confounded.push_back(std::move(g));
  }
  return rep;
}

void print_collinearity_report(const CollinearityReport& rep, std::ostream& out) {
  const RankReport& rk = rep.rank;
  out << "design " << rk.rows << " x " << rk.cols << ", rank " << rk.rank << " (unit-norm columns, rcond "
      << fmt(rk.rcond, "%.3g") << "), condition number " << fmt(rk.condition_number, "%.4g") << "\n";
  VectorXd s = VectorXd::Zero(rk.cols);
  s.head(rk.singular_values.size()) = rk.singular_values;
  const ObservabilityIndices o = observability_indices(s, rk.rows);
  out << "observability O1 " << fmt(o.o1) << ", O2 " << fmt(o.o2) << ", O3 " << fmt(o.o3) << ", O4 " << fmt(o.o4)
      << ", O5 " << fmt(o.o5) << "\n";
  out << "VIF:";
  for (Index j = 0; j < rep.vif.size(); ++j) out << " " << rep.names[static_cast<std::size_t>(j)] << "=" << fmt(rep.vif(j));
  out << "\n";
  for (const NullCombination& c : rep.null_space) out << "null space: " << c.text << "\n";
  for (const ParameterNote& n : rep.notes) {
    out << n.text;
    if (!n.hint.empty()) out << " — " << n.hint;
    out << "\n";
  }
}

}  // namespace kincal::identify
