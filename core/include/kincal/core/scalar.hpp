// Scalar-dependent tolerances and the fixed-size Eigen aliases used by core/.
// core/ is templated on Scalar; `d`/`f` aliases are given next to each type
// (Sophus / manif style). Tolerances are per scalar so that float firmware and
// double host builds share one source.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <cmath>

// Stack control on the controller: a function whose locals must not share a
// frame with its caller's (the worst-case stack is the deepest path, and
// GCC -Os merges an inlined callee's locals into the caller's frame).
#if defined(__GNUC__)
#define KINCAL_NOINLINE __attribute__((noinline))
// Not inlined itself, but everything it calls is: e.g. the compensator's
// closed-form IK, compiled for its one use (no Jacobian), so the Jacobian
// code is not linked in.
#define KINCAL_NOINLINE_FLATTEN __attribute__((noinline, flatten))
// Inlined even at -Os: a small building block whose own frame (and the
// copy of its result) would sit on the controller's deepest path.
#define KINCAL_ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define KINCAL_NOINLINE
#define KINCAL_NOINLINE_FLATTEN
#define KINCAL_ALWAYS_INLINE inline
#endif

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
  // FK stops when every joint residual is below fk_residual · |joint| (a few
  // ulps: the rounding floor). On the reference machines the pose error is
  // then ~1e-11 mm (GUIDE bar: 1e-9 mm).
  static constexpr double fk_residual = 1e-13;
  // A dimensionless Jacobian whose LU pivot ratio (min/max |u_kk|) falls below
  // this is singular.
  static constexpr double singular_pivot_ratio = 1e-9;
  static constexpr int fk_max_iterations = 20;
};

template <> struct Tolerance<float> {
  // float: 4 ulps of the joint value (~1e-4 mm on a 233 mm leg).
  static constexpr float fk_residual = 4.8e-7f;
  static constexpr float singular_pivot_ratio = 1e-5f;
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
