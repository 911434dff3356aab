// LU factorisation with partial pivoting for small fixed-size systems (the
// 3×3 and 6×6 kinematic Jacobians), written out so the compiler unrolls it.
// Why not Eigen::PartialPivLU: for a 6×6 its generic blocked code path costs
// ~1.8k instructions per factorisation plus ~1.3k for rcond(), about 2.5× this
// (measured with callgrind, docs/benchmarks.md); FK factorises every Newton step
// and sits on the controller's hot path. The host tests check it against Eigen.
#pragma once

#include "kincal/core/scalar.hpp"

// Full unrolling of the fixed-size loops (GCC; harmless elsewhere).
#if defined(__GNUC__) && !defined(__clang__)
#define KINCAL_UNROLL _Pragma("GCC unroll 8")
#else
#define KINCAL_UNROLL
#endif

namespace kincal {

template <class Scalar, int N> class SmallLu {
 public:
  using Matrix = Eigen::Matrix<Scalar, N, N>;
  using Vector = Eigen::Matrix<Scalar, N, 1>;

  // Factorises A (P·A = L·U) on a plain array: with constant N the compiler
  // unrolls the loops, which Eigen's row-swap expressions prevent. Returns false
  // for a non-finite or exactly singular matrix; otherwise pivot_ratio()
  // measures how close to singular it is.
  bool factor(const Matrix& A) {
    storage() = A;
    return factor();
  }

  // The matrix to factorise can also be written straight into the
  // factorisation's storage and factorised in place: one 6×6 copy fewer on
  // the stack of a controller's FK (docs/benchmarks.md, firmware stack).
  Eigen::Map<Eigen::Matrix<Scalar, N, N, Eigen::RowMajor>> storage() {
    return Eigen::Map<Eigen::Matrix<Scalar, N, N, Eigen::RowMajor>>(&a_[0][0]);
  }

  bool factor() {
    KINCAL_UNROLL
    for (int i = 0; i < N; ++i) row_[i] = i;
    // Rows are pivoted through the index array row_, not swapped in memory.
    Scalar max_pivot(0), min_pivot(0);
    KINCAL_UNROLL
    for (int k = 0; k < N; ++k) {
      int p = k;
      Scalar best = std::abs(a_[row_[k]][k]);
      KINCAL_UNROLL
      for (int i = k + 1; i < N; ++i) {
        const Scalar v = std::abs(a_[row_[i]][k]);
        if (v > best) {
          best = v;
          p = i;
        }
      }
      if (!(best > Scalar(0))) {  // zero or NaN column
        ratio_ = Scalar(0);
        return false;
      }
      const int pk = row_[p];
      row_[p] = row_[k];
      row_[k] = pk;
      if (k == 0 || best > max_pivot) max_pivot = best;
      if (k == 0 || best < min_pivot) min_pivot = best;
      const Scalar inv = Scalar(1) / a_[pk][k];
      inv_pivot_[k] = inv;  // solve() multiplies: a division costs ~10× a multiply
      KINCAL_UNROLL
      for (int i = k + 1; i < N; ++i) {
        Scalar* ri = a_[row_[i]];
        const Scalar f = ri[k] * inv;
        ri[k] = f;
        KINCAL_UNROLL
        for (int j = k + 1; j < N; ++j) ri[j] -= f * a_[pk][j];
      }
    }
    ratio_ = min_pivot / max_pivot;
    return ratio_ == ratio_;
  }

  // min |u_kk| / max |u_kk|: a cheap conditioning measure of a well-scaled
  // matrix (0 when singular). Callers scale mixed-unit Jacobians first.
  Scalar pivot_ratio() const { return ratio_; }

  Vector solve(const Vector& b) const {
    Scalar x[N];
    KINCAL_UNROLL
    for (int i = 0; i < N; ++i) {
      const Scalar* ri = a_[row_[i]];
      Scalar v = b(row_[i]);
      KINCAL_UNROLL
      for (int j = 0; j < i; ++j) v -= ri[j] * x[j];
      x[i] = v;
    }
    KINCAL_UNROLL
    for (int i = N - 1; i >= 0; --i) {
      const Scalar* ri = a_[row_[i]];
      Scalar v = x[i];
      KINCAL_UNROLL
      for (int j = i + 1; j < N; ++j) v -= ri[j] * x[j];
      x[i] = v * inv_pivot_[i];
    }
    Vector out;
    KINCAL_UNROLL
    for (int i = 0; i < N; ++i) out(i) = x[i];
    return out;
  }

  Matrix inverse() const {
    Matrix inv;
    KINCAL_UNROLL
    for (int j = 0; j < N; ++j) inv.col(j) = solve(Vector::Unit(j));
    return inv;
  }

 private:
  Scalar a_[N][N] = {};
  Scalar inv_pivot_[N] = {};
  int row_[N] = {};  // row_[k]: the stored row that is row k of P·A
  Scalar ratio_ = Scalar(0);
};

// The one singularity test of core/: a (dimensionless) Jacobian is singular
// when its LU fails or its pivot ratio falls below the scalar's threshold.
template <class Scalar, int N> bool factor_regular(SmallLu<Scalar, N>& lu, const Eigen::Matrix<Scalar, N, N>& A) {
  return lu.factor(A) && lu.pivot_ratio() > Tolerance<Scalar>::singular_pivot_ratio;
}

}  // namespace kincal
