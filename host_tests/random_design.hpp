// Test helper shared by the estimator and identifiability tests: a random
// design with independent N(0, 1) entries, reproducible from the generator.
#pragma once

#include <Eigen/Core>
#include <random>

namespace kincal::test {

inline Eigen::MatrixXd gaussian(Eigen::Index rows, Eigen::Index cols, std::mt19937_64& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::MatrixXd A(rows, cols);
  for (Eigen::Index j = 0; j < cols; ++j)
    for (Eigen::Index i = 0; i < rows; ++i) A(i, j) = g(rng);
  return A;
}

}  // namespace kincal::test
