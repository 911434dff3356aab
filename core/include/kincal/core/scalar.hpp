// Scalar-dependent tolerances and the fixed-size Eigen aliases used by core/.
// core/ is templated on Scalar; `d`/`f` aliases are given next to each type
// (Sophus / manif style). Tolerances are per scalar so that float firmware and
// double host builds share one source.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <cmath>

namespace kincal {

template <class Scalar> using Vec3 = Eigen::Matrix<Scalar, 3, 1>;
template <class Scalar> using Vec6 = Eigen::Matrix<Scalar, 6, 1>;
template <class Scalar> using Mat3 = Eigen::Matrix<Scalar, 3, 3>;
template <class Scalar> using Mat6 = Eigen::Matrix<Scalar, 6, 6>;
// A twist / pose error: (linear part at the reference point, angular part),
// both in base-frame coordinates.
template <class Scalar> using Twist = Vec6<Scalar>;

// Keeps a parameter out of template argument deduction, so optional outputs
// can be passed as nullptr.
template <class T> struct NonDeduced {
  using type = T;
};
template <class T> using NonDeducedT = typename NonDeduced<T>::type;

template <class Scalar> struct Tolerance;

template <> struct Tolerance<double> {
  // FK stops when the Newton step is below this (mm / rad). GUIDE bar: 1e-9 mm.
  static constexpr double fk_step = 1e-10;
  // A Jacobian whose reciprocal condition estimate falls below this is singular.
  static constexpr double singular_rcond = 1e-9;
  static constexpr int fk_max_iterations = 20;
};

template <> struct Tolerance<float> {
  // float has ~7 digits: on a ~1000 mm machine rounding alone moves a Newton
  // step by ~1e-4 mm, so the stopping step is 1 µm.
  static constexpr float fk_step = 1e-3f;
  static constexpr float singular_rcond = 1e-5f;
  static constexpr int fk_max_iterations = 20;
};

template <class Scalar> constexpr Scalar pi() { return Scalar(3.14159265358979323846); }

template <class Derived> bool all_finite(const Eigen::MatrixBase<Derived>& m) {
  // (x - x) is NaN for NaN and Inf inputs alike, 0 otherwise.
  return ((m.derived().array() - m.derived().array()) == 0).all();
}

inline bool is_finite(double x) { return std::isfinite(x); }
inline bool is_finite(float x) { return std::isfinite(x); }

}  // namespace kincal
