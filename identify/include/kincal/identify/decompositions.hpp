#pragma once
// Eigen's dense decompositions on dynamic-size double matrices, the ones
// identify/ factors its designs with, declared here as instantiated once, in
// src/estimate/decompositions.cpp, instead of in every translation unit that
// solves a least-squares problem. Include this header, not <Eigen/QR>,
// <Eigen/SVD>, <Eigen/Cholesky> or <Eigen/Eigenvalues>, wherever one of them
// is used: a BDCSVD alone cost 20 s of template instantiation in
// estimators.cpp (clang -O1, -ftime-trace; docs/benchmarks.md "Build time").
//
// `extern template` changes where the code is generated, not what it computes:
// the one instantiation is compiled with the same flags as its callers.

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/QR>
#include <Eigen/SVD>

extern template class Eigen::BDCSVD<Eigen::MatrixXd>;
extern template class Eigen::JacobiSVD<Eigen::MatrixXd>;
extern template class Eigen::HouseholderQR<Eigen::MatrixXd>;
extern template class Eigen::ColPivHouseholderQR<Eigen::MatrixXd>;
extern template class Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd>;
extern template class Eigen::LLT<Eigen::MatrixXd>;
extern template class Eigen::LDLT<Eigen::MatrixXd>;
extern template class Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>;
extern template class Eigen::PartialPivLU<Eigen::MatrixXd>;
