// Identifiability (identify/identifiability.hpp): rank with a stated
// tolerance, column scaling, the seed 000 Section 4.1 reconstructions,
// observability indices, and the collinearity / null-space report, on designs
// with planted dependencies.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <string>

#include "kincal/identify/decompositions.hpp"
#include "kincal/identify/identifiability.hpp"
#include "kincal/identify/input_error.hpp"
#include "random_design.hpp"

using namespace kincal::identify;
using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

using kincal::test::gaussian;  // random_design.hpp

bool contains(const std::vector<Index>& v, Index x) { return std::find(v.begin(), v.end(), x) != v.end(); }

}  // namespace

TEST(identifyIdentifiability, RankBySvdWithStatedTolerance) {
  std::mt19937_64 rng(21);
  MatrixXd H = gaussian(50, 6, rng);
  const RankReport full = rank_by_svd(H);
  EXPECT_EQ(full.rank, 6);
  EXPECT_DOUBLE_EQ(full.rcond, kRankThreshold);  // the one rule (rank_tolerance.hpp)
  EXPECT_DOUBLE_EQ(full.tolerance, full.rcond * full.singular_values(0));
  EXPECT_NEAR(full.condition_number, full.singular_values(0) / full.singular_values(5), 1e-12);
  H.col(5) = 0.5 * H.col(0) - 3.0 * H.col(2);
  const RankReport def = rank_by_svd(H);
  EXPECT_EQ(def.rank, 5);
  EXPECT_TRUE(std::isinf(def.condition_number));
  // A near-dependency at 1e-12 of the column: dependent under the default
  // (above rounding's max(n, m)·ε = 1.1e-14, below kRankThreshold) …
  const MatrixXd exact = H;
  H.col(5) += 1e-12 * H.col(5).norm() * gaussian(50, 1, rng).normalized();
  EXPECT_EQ(rank_by_svd(H).rank, 5);
  EXPECT_EQ(rank_by_svd(H, 50 * std::numeric_limits<double>::epsilon()).rank, 6);
  // … and an explicit, looser tolerance: a near-dependency at 1e-6 counts as dependent
  H = exact;
  H.col(5) += 1e-7 * gaussian(50, 1, rng);
  EXPECT_EQ(rank_by_svd(H).rank, 6);
  EXPECT_EQ(rank_by_svd(H, 1e-5).rank, 5);
}

TEST(identifyIdentifiability, ColumnScalingMakesRankUnitIndependent) {
  std::mt19937_64 rng(22);
  MatrixXd H = gaussian(40, 5, rng);
  H.col(3) *= 1e-14;  // e.g. a parameter in a tiny unit: still independent
  EXPECT_EQ(rank_by_svd(H).rank, 5);
  EXPECT_EQ(rank_by_svd(H, kDefaultRcond, ColumnScaling::None).rank, 4);
  const VectorXd d = column_scales(H);
  EXPECT_NEAR(d(3), H.col(3).norm(), 1e-30);
  MatrixXd Z = H;
  Z.col(1).setZero();
  EXPECT_EQ(column_scales(Z)(1), 1.0);  // a zero column keeps scale 1 and stays unidentifiable
  EXPECT_EQ(rank_by_svd(Z).rank, 4);
}

TEST(identifyIdentifiability, ColumnSelectionKeepsExactlyTheIndependentColumns) {
  std::mt19937_64 rng(23);
  const Index n = 90;
  MatrixXd H(n, 10);
  H.leftCols(3) = gaussian(n, 3, rng);                       // ξ: actuated joints
  H.col(3) = gaussian(n, 1, rng);                            // η0 independent
  H.col(4) = H.col(0) + 2.0 * H.col(3);                      // η1 = ξ0 + 2 η0        → drop
  H.col(5) = 1e3 * gaussian(n, 1, rng);                      // η2 independent (other unit)
  H.col(6) = 2.0 * H.col(5) - H.col(1);                      // η3 = 2 η2 − ξ1       → drop
  H.col(7).setZero();                                        // η4 no effect at all  → drop
  H.col(8) = gaussian(n, 1, rng) * 1e-3;                     // η5 independent (tiny unit)
  H.col(9) = H.col(8) + H.col(3) - 0.5 * H.col(2);           // η6                  → drop
  const std::vector<std::string> names = {"q1", "q2", "q3", "e0", "e1", "e2", "e3", "e4", "e5", "e6"};
  const ColumnSelection sel = reconstruct_by_column_selection(H, {0, 1, 2}, {3, 4, 5, 6, 7, 8, 9}, names);
  EXPECT_EQ(sel.kept, (std::vector<Index>{0, 1, 2, 3, 5, 8}));
  EXPECT_EQ(sel.dropped, (std::vector<Index>{4, 6, 7, 9}));
  EXPECT_EQ(sel.dropped_names, (std::vector<std::string>{"e1", "e3", "e4", "e6"}));
  EXPECT_EQ(sel.rank, 6);
  ASSERT_EQ(sel.distance.size(), 7u);
  EXPECT_GT(sel.distance[0], 0.1);
  EXPECT_LT(sel.distance[1], 1e-13);
  // the kept design has full rank and the same rank as H (seed 000 Sec. 4.1 Step 3)
  MatrixXd kept(n, 6);
  for (Index a = 0; a < 6; ++a) kept.col(a) = H.col(sel.kept[static_cast<std::size_t>(a)]);
  EXPECT_EQ(rank_by_svd(kept).rank, 6);
  EXPECT_EQ(rank_by_svd(H).rank, 6);
  // the order of η matters only in which of two dependent columns is kept
  const ColumnSelection rev = reconstruct_by_column_selection(H, {0, 1, 2}, {9, 8, 7, 6, 5, 4, 3}, names);
  EXPECT_EQ(rev.rank, 6);
  EXPECT_TRUE(contains(rev.kept, 9));
}

TEST(identifyIdentifiability, ColumnSelectionRejectsDependentActuatedColumns) {
  std::mt19937_64 rng(24);
  MatrixXd H = gaussian(30, 4, rng);
  H.col(1) = -H.col(0);
  EXPECT_THROW(reconstruct_by_column_selection(H, {0, 1}, {2, 3}), InputError);
  EXPECT_THROW(reconstruct_by_column_selection(H, {0, 7}, {2}), std::invalid_argument);
  EXPECT_THROW(reconstruct_by_column_selection(H, {0, 2}, {2}), std::invalid_argument);
}

TEST(identifyIdentifiability, SpectralReductionFirstWay) {
  std::mt19937_64 rng(25);
  MatrixXd H = gaussian(60, 6, rng);
  H.col(4) = H.col(0) - H.col(1);
  H.col(5) = 3.0 * H.col(2);
  const VectorXd y = gaussian(60, 1, rng).col(0);
  for (ColumnScaling sc : {ColumnScaling::None, ColumnScaling::UnitNorm}) {
    const SpectralReduction red = spectral_reduction(H, kDefaultRcond, sc);
    ASSERT_EQ(red.rank, 4);
    EXPECT_EQ(red.phi1.rows(), 6);
    EXPECT_EQ(red.z1.cols(), 4);
    EXPECT_EQ(rank_by_svd(red.z1).rank, 4);  // Z₁ has full column rank
    // LS in α, mapped back by Δχ = Φ₁Δα, fits as well as any LS solution in χ
    const VectorXd a = red.z1.colPivHouseholderQr().solve(y);
    const VectorXd chi = red.to_parameters(a);
    const VectorXd best = H.completeOrthogonalDecomposition().solve(y);
    EXPECT_NEAR((y - H * chi).norm(), (y - H * best).norm(), 1e-10);
  }
  // unscaled: Φ₁ are eigenvectors of HᵀH with the non-zero eigenvalues
  const SpectralReduction red = spectral_reduction(H, kDefaultRcond, ColumnScaling::None);
  const MatrixXd N = H.transpose() * H;
  EXPECT_LT((red.phi1.transpose() * red.phi1 - MatrixXd::Identity(4, 4)).norm(), 1e-12);
  EXPECT_LT((N * red.phi1 - red.phi1 * red.singular_values.cwiseAbs2().asDiagonal()).norm(), 1e-9 * N.norm());
}

TEST(identifyIdentifiability, ObservabilityIndices) {
  const VectorXd s = (VectorXd(3) << 4.0, 2.0, 0.5).finished();
  const ObservabilityIndices o = observability_indices(s, 16);
  EXPECT_NEAR(o.o1, std::cbrt(4.0) / 4.0, 1e-15);  // (4·2·0.5)^(1/3) / √16
  EXPECT_NEAR(o.o2, 0.125, 1e-15);
  EXPECT_NEAR(o.o3, 0.5, 1e-15);
  EXPECT_NEAR(o.o4, 0.0625, 1e-15);
  EXPECT_NEAR(o.o5, 1.0 / (0.25 + 0.5 + 2.0), 1e-15);
  // a rank-deficient design has O1 = O2 = O3 = O4 = O5 = 0
  std::mt19937_64 rng(26);
  MatrixXd H = gaussian(20, 3, rng);
  H.col(2) = H.col(1);
  const ObservabilityIndices z = observability_indices(H);
  EXPECT_LT(z.o2, 1e-14);
  EXPECT_LT(z.o1, 1e-5);
}

TEST(identifyIdentifiability, VifAndConditionIndicesNameAPlantedCollinearPair) {
  std::mt19937_64 rng(27);
  const Index n = 100;
  MatrixXd H = gaussian(n, 7, rng);
  H.col(2) *= 250.0;                                            // a rad column with a 250 mm lever
  H.col(5) = H.col(2) / 250.0 * 0.8 + 1e-4 * gaussian(n, 1, rng).col(0);  // nearly collinear with col 2
  const std::vector<std::string> names = {"dXB1", "dYB1", "dZB1", "dXP1", "dYP1", "dl1", "dZP1"};
  CollinearityOptions opt;
  opt.hint = [](const std::string& p) { return p.rfind("dl", 0) == 0 ? "vary the leg length more" : ""; };
  const CollinearityReport rep = collinearity_report(H, names, opt);
  EXPECT_EQ(rep.rank.rank, 7);
  EXPECT_TRUE(rep.unidentifiable.empty());
  // VIF against its definition 1/(1 − R²_j) (uncentred regression of column j on the others)
  for (Index j : {0, 2, 5}) {
    MatrixXd others(n, 6);
    Index c = 0;
    for (Index k = 0; k < 7; ++k)
      if (k != j) others.col(c++) = H.col(k);
    const VectorXd hj = H.col(j);
    const VectorXd fit = others * others.colPivHouseholderQr().solve(hj);
    const double r2 = 1.0 - (hj - fit).squaredNorm() / hj.squaredNorm();
    EXPECT_NEAR(rep.vif(j), 1.0 / (1.0 - r2), 1e-6 * rep.vif(j)) << j;
  }
  EXPECT_GT(rep.vif(2), 1e5);
  EXPECT_GT(rep.vif(5), 1e5);
  for (Index j : {0, 1, 3, 4, 6}) EXPECT_LT(rep.vif(j), 3.0) << j;
  // variance-decomposition proportions sum to 1 per parameter
  for (Index j = 0; j < 7; ++j) EXPECT_NEAR(rep.variance_proportions.row(j).sum(), 1.0, 1e-12);
  ASSERT_EQ(rep.confounded.size(), 1u);
  EXPECT_EQ(rep.confounded[0].columns, (std::vector<Index>{2, 5}));
  EXPECT_GT(rep.confounded[0].condition_index, 30.0);
  ASSERT_EQ(rep.notes.size(), 2u);
  EXPECT_NE(rep.notes[0].text.find("dZB1 is confounded with dl1"), std::string::npos) << rep.notes[0].text;
  EXPECT_NE(rep.notes[1].text.find("dl1 is confounded with dZB1"), std::string::npos) << rep.notes[1].text;
  EXPECT_EQ(rep.notes[1].hint, "vary the leg length more");
  std::ostringstream out;
  print_collinearity_report(rep, out);
  EXPECT_NE(out.str().find("dZB1 is confounded with dl1"), std::string::npos);
}

TEST(identifyIdentifiability, NullSpaceCombinationOfAPlantedDependency) {
  std::mt19937_64 rng(28);
  const Index n = 60;
  MatrixXd H = gaussian(n, 6, rng);
  H.col(3) *= 100.0;                             // different units
  H.col(4) = 2.0 * H.col(1) - 0.5 * H.col(3);    // x4 = 2·x1 − 0.5·x3  ⇒  H·(0, 2, 0, −0.5, −1, 0) = 0
  const std::vector<std::string> names = {"dXB1", "dZB1", "dYP1", "dl1", "dZP1", "dXP2"};
  const std::vector<NullCombination> ns = null_space_combinations(H, names);
  ASSERT_EQ(ns.size(), 1u);
  EXPECT_EQ(ns[0].columns, (std::vector<Index>{1, 3, 4}));
  ASSERT_EQ(ns[0].coefficients.size(), 3u);
  EXPECT_NEAR(ns[0].coefficients[0], 1.0, 1e-12);     // leading coefficient 1, own units
  EXPECT_NEAR(ns[0].coefficients[1], -0.25, 1e-9);
  EXPECT_NEAR(ns[0].coefficients[2], -0.5, 1e-9);
  EXPECT_EQ(ns[0].text, "+1*dZB1 -0.25*dl1 -0.5*dZP1");
  EXPECT_EQ(unidentifiable_columns(H), (std::vector<Index>{1, 3, 4}));

  // two independent dependencies: each combination gets its own leading parameter
  H.col(5) = H.col(0) + H.col(2);
  const std::vector<NullCombination> two = null_space_combinations(H, names);
  ASSERT_EQ(two.size(), 2u);
  for (const NullCombination& c : two) {
    VectorXd v = VectorXd::Zero(6);
    for (std::size_t t = 0; t < c.columns.size(); ++t) v(c.columns[t]) = c.coefficients[t];
    EXPECT_LT((H * v).norm(), 1e-9 * H.norm() * v.norm());
  }
  EXPECT_EQ(two[0].columns, (std::vector<Index>{0, 2, 5}));
  EXPECT_EQ(two[1].columns, (std::vector<Index>{1, 3, 4}));

  CollinearityOptions opt;
  opt.hint = [](const std::string& p) { return p == "dl1" ? "measure the orientation too" : ""; };
  const CollinearityReport rep = collinearity_report(H, names, opt);
  EXPECT_EQ(rep.rank.rank, 4);
  EXPECT_EQ(rep.unidentifiable, (std::vector<Index>{0, 1, 2, 3, 4, 5}));
  EXPECT_TRUE(std::isinf(rep.vif(3)));
  bool found = false;
  for (const ParameterNote& note : rep.notes) {
    if (note.name != "dl1") continue;
    found = true;
    EXPECT_NE(note.text.find("dl1 is not identifiable"), std::string::npos) << note.text;
    EXPECT_NE(note.text.find("+1*dZB1 -0.25*dl1 -0.5*dZP1"), std::string::npos) << note.text;
    EXPECT_EQ(note.hint, "measure the orientation too");
  }
  EXPECT_TRUE(found);
}

namespace {

// A toy measurement with known physics: a target point measured in the base
// frame, p = t + R·(c + a) + b + s·z·e_z, with a platform-fixed offset a
// (turns with the platform), a base-fixed offset b, and a height-proportional
// error s (e.g. a scale error of a vertical axis). Rows at a pose: ∂p/∂(a, b, s).
MatrixXd toy_rows(const Eigen::Matrix<double, 6, 1>& pose) {
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(pose(5), Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(pose(4), Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(pose(3), Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  MatrixXd rows(3, 7);
  rows.leftCols(3) = R;
  rows.middleCols(3, 3).setIdentity();
  rows.col(6) = pose(2) * Eigen::Vector3d::UnitZ();
  return rows;
}

const std::vector<std::string> kToyNames = {"ax", "ay", "az", "bx", "by", "bz", "sz"};

MatrixXd stack(const std::vector<Eigen::Matrix<double, 6, 1>>& poses) {
  MatrixXd H(3 * static_cast<Index>(poses.size()), 7);
  for (std::size_t k = 0; k < poses.size(); ++k) H.middleRows(3 * static_cast<Index>(k), 3) = toy_rows(poses[k]);
  return H;
}

}  // namespace

TEST(identifyIdentifiability, HintNamesTheMeasurementThatSeparatesEachCombination) {
  // Poses on a 3 × 3 grid in x, y, all at one height and one orientation: a
  // and b are confounded (R = I), and s·z0 with b_z. The probes say which
  // change of pose separates them.
  std::vector<Eigen::Matrix<double, 6, 1>> poses;
  for (double x : {-100.0, 0.0, 100.0})
    for (double y : {-100.0, 0.0, 100.0}) {
      Eigen::Matrix<double, 6, 1> p;
      p << x, y, 250.0, 0.0, 0.0, 0.0;
      poses.push_back(p);
    }
  const MatrixXd H = stack(poses);
  const auto null = null_space_combinations(H, kToyNames);
  ASSERT_EQ(null.size(), 4u);
  const IdentifiabilityHint hint = identifiability_hint(null, kToyNames, poses, toy_rows);
  std::printf("%s\n", hint.text.c_str());
  ASSERT_EQ(hint.combinations.size(), 4u);
  for (const CombinationHint& h : hint.combinations) {
    const std::string& lead = kToyNames[static_cast<std::size_t>(h.combination.columns.front())];
    std::vector<PoseDof> want;
    if (lead == "ax") want = {PoseDof::Ry, PoseDof::Rz};  // R·e_x changes only by turns about y or z
    if (lead == "ay") want = {PoseDof::Rx, PoseDof::Rz};
    if (lead == "az") want = {PoseDof::Z, PoseDof::Rx, PoseDof::Ry};  // az vs s·z0: a tilt or another height
    if (lead == "bz") want = {PoseDof::Z};                            // bz vs s·z0: another height
    EXPECT_EQ(h.revealed_by, want) << h.combination.text;
  }
  EXPECT_EQ(hint.parameters, kToyNames);
  EXPECT_NE(hint.text.find("ax, bx: add poses with different orientations (ry, rz)"), std::string::npos);
  EXPECT_NE(hint.text.find("ay, by: add poses with different orientations (rx, rz)"), std::string::npos);
  EXPECT_NE(hint.text.find("bz, sz: add poses at another height (z), e.g. another layer"), std::string::npos);
  EXPECT_NE(hint.text.find("add poses at another height (z), e.g. another layer or add tilted poses (rx, ry)"),
            std::string::npos);
  EXPECT_EQ(hint.text.find('\n'), std::string::npos);
}

TEST(identifyIdentifiability, HintCallsARedundancyARedundancy) {
  // Two parameters with the same effect at every pose (b_x twice): no change
  // of pose separates them. A full-rank design gives no hint.
  const auto rows = [](const Eigen::Matrix<double, 6, 1>& pose) -> MatrixXd {
    MatrixXd r(3, 8);
    r.leftCols(7) = toy_rows(pose);
    r.col(7) = r.col(3);
    return r;
  };
  std::vector<Eigen::Matrix<double, 6, 1>> poses;
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int k = 0; k < 12; ++k) {
    Eigen::Matrix<double, 6, 1> p;
    p << 100 * u(rng), 100 * u(rng), 250 + 50 * u(rng), 0.2 * u(rng), 0.2 * u(rng), 0.2 * u(rng);
    poses.push_back(p);
  }
  MatrixXd H(36, 8);
  for (int k = 0; k < 12; ++k) H.middleRows(3 * k, 3) = rows(poses[static_cast<std::size_t>(k)]);
  std::vector<std::string> names = kToyNames;
  names.push_back("bx_again");
  const IdentifiabilityHint hint = identifiability_hint(null_space_combinations(H, names), names, poses, rows);
  ASSERT_EQ(hint.combinations.size(), 1u);
  EXPECT_TRUE(hint.combinations[0].revealed_by.empty());
  EXPECT_FALSE(hint.combinations[0].revealed_jointly);
  EXPECT_EQ(hint.text, "bx, bx_again: no change of pose separates them (a redundancy of the model: hold one at its "
                       "nominal value or measure it directly)");
  EXPECT_TRUE(identifiability_hint(null_space_combinations(stack(poses), kToyNames), kToyNames, poses, toy_rows)
                  .text.empty());
}
