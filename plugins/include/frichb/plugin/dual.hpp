// FricHB plugin SDK: forward-mode dual numbers, for a law's consistent tangents.
//
// A law written once as a template over its scalar type gets its tangents by running the
// same code on Dual<N>: a value and its N partial derivatives, carried through every
// operation by the chain rule. The tangents are then the exact derivatives of the computed
// step, branches, sub-step events and inner iterations included, with no hand-written
// derivative to keep in step with the value.
//
//   using D = frichb::sdk::Dual<8>;
//   D x = D::variable(1.5, 0);      // x = 1.5, dx/dx_0 = 1
//   D y = sin(x) * x;               // y.value(), y.derivative(0) = cos(1.5) 1.5 + sin(1.5)
//
// Contract:
//  - Comparisons look at values only: a branch taken on a value is differentiated as taken
//    (the derivative of the piece the input lies on).
//  - An iteration that converges in value (a root, a fixed point) does not in general carry
//    the derivative of its limit; finish it with a Newton step written in duals (the root's
//    derivative is then -dg/dx / g'(root), the implicit-function rule).
//  - Functions not differentiable at a point (sqrt at 0, hypot at the origin, abs at 0)
//    return the derivative of one side, or 0 where none is finite.
//  - Threading: a plain value type, no shared state. Header-only, C++17, no dependency.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>

namespace frichb::sdk {

template <int N>
class Dual {
 public:
  static constexpr int kSize = N;

  constexpr Dual() = default;
  constexpr Dual(double value) : value_(value) {}  // NOLINT(google-explicit-constructor)
  // The independent variable `index` (0 <= index < N) at `value`.
  static Dual variable(double value, int index) {
    Dual d(value);
    d.derivative_[static_cast<std::size_t>(index)] = 1.0;
    return d;
  }

  double value() const { return value_; }
  double derivative(int index) const { return derivative_[static_cast<std::size_t>(index)]; }
  const std::array<double, N>& derivatives() const { return derivative_; }

  Dual& operator+=(const Dual& o) {
    value_ += o.value_;
    for (int i = 0; i < N; ++i) derivative_[i] += o.derivative_[i];
    return *this;
  }
  Dual& operator-=(const Dual& o) {
    value_ -= o.value_;
    for (int i = 0; i < N; ++i) derivative_[i] -= o.derivative_[i];
    return *this;
  }
  Dual& operator*=(const Dual& o) {
    for (int i = 0; i < N; ++i)
      derivative_[i] = derivative_[i] * o.value_ + value_ * o.derivative_[i];
    value_ *= o.value_;
    return *this;
  }
  Dual& operator/=(const Dual& o) {
    const double inv = 1.0 / o.value_;
    value_ /= o.value_;  // a true division: the value is bitwise the double code's
    for (int i = 0; i < N; ++i) derivative_[i] = (derivative_[i] - value_ * o.derivative_[i]) * inv;
    return *this;
  }
  Dual operator-() const {
    Dual d(*this);
    d.value_ = -d.value_;
    for (auto& x : d.derivative_) x = -x;
    return d;
  }

  // f(value) with derivative f'(value) times this one's derivatives.
  Dual chain(double f, double df) const {
    Dual d(f);
    for (int i = 0; i < N; ++i) d.derivative_[i] = df * derivative_[i];
    return d;
  }
  // A function of K duals at their values: value f, partial derivatives df with respect to
  // each (the chain rule: derivatives sum_k df[k] x[k]'), for code that writes a function's
  // partials out rather than running its whole expression in duals.
  template <std::size_t K>
  static Dual from_partials(double f, const std::array<double, K>& df,
                            const std::array<const Dual*, K>& x) {
    std::array<double, N> sum{};
    for (std::size_t k = 0; k < K; ++k)
      for (int i = 0; i < N; ++i) sum[i] += df[k] * x[k]->derivative_[i];
    Dual d(f);
    d.derivative_ = sum;
    return d;
  }

 private:
  // The derivatives first: a copy of a dual then moves them in the same 16-byte pairs that
  // the arithmetic loads (the value first offset every pair by 8 bytes, and a load of a pair
  // just copied then missed the store it should be forwarded from).
  std::array<double, N> derivative_{};
  double value_ = 0.0;
};

template <int N>
Dual<N> operator+(Dual<N> a, const Dual<N>& b) {
  return a += b;
}
template <int N>
Dual<N> operator-(Dual<N> a, const Dual<N>& b) {
  return a -= b;
}
template <int N>
Dual<N> operator*(Dual<N> a, const Dual<N>& b) {
  return a *= b;
}
template <int N>
Dual<N> operator/(Dual<N> a, const Dual<N>& b) {
  return a /= b;
}
template <int N>
Dual<N> operator+(Dual<N> a, double b) {
  return a += Dual<N>(b);
}
template <int N>
Dual<N> operator+(double a, Dual<N> b) {
  return b += Dual<N>(a);
}
template <int N>
Dual<N> operator-(Dual<N> a, double b) {
  return a -= Dual<N>(b);
}
template <int N>
Dual<N> operator-(double a, const Dual<N>& b) {
  return Dual<N>(a) - b;
}
template <int N>
Dual<N> operator*(Dual<N> a, double b) {
  return a.chain(a.value() * b, b);
}
template <int N>
Dual<N> operator*(double a, const Dual<N>& b) {
  return b.chain(a * b.value(), a);
}
template <int N>
Dual<N> operator/(const Dual<N>& a, double b) {
  return a.chain(a.value() / b, 1.0 / b);
}
template <int N>
Dual<N> operator/(double a, const Dual<N>& b) {
  return Dual<N>(a) / b;
}

#define FRICHB_DUAL_COMPARISON(op)                       \
  template <int N>                                       \
  bool operator op(const Dual<N>& a, const Dual<N>& b) { \
    return a.value() op b.value();                       \
  }                                                      \
  template <int N>                                       \
  bool operator op(const Dual<N>& a, double b) {         \
    return a.value() op b;                               \
  }                                                      \
  template <int N>                                       \
  bool operator op(double a, const Dual<N>& b) {         \
    return a op b.value();                               \
  }
FRICHB_DUAL_COMPARISON(<)
FRICHB_DUAL_COMPARISON(<=)
FRICHB_DUAL_COMPARISON(>)
FRICHB_DUAL_COMPARISON(>=)
#undef FRICHB_DUAL_COMPARISON

template <int N>
Dual<N> sqrt(const Dual<N>& x) {
  const double r = std::sqrt(x.value());
  return x.chain(r, r > 0 ? 0.5 / r : 0.0);
}
template <int N>
Dual<N> exp(const Dual<N>& x) {
  const double e = std::exp(x.value());
  return x.chain(e, e);
}
template <int N>
Dual<N> log(const Dual<N>& x) {
  return x.chain(std::log(x.value()), 1.0 / x.value());
}
template <int N>
Dual<N> log1p(const Dual<N>& x) {
  return x.chain(std::log1p(x.value()), 1.0 / (1.0 + x.value()));
}
template <int N>
Dual<N> sin(const Dual<N>& x) {
  return x.chain(std::sin(x.value()), std::cos(x.value()));
}
template <int N>
Dual<N> cos(const Dual<N>& x) {
  return x.chain(std::cos(x.value()), -std::sin(x.value()));
}
template <int N>
Dual<N> atan2(const Dual<N>& y, const Dual<N>& x) {
  const double r2 = x.value() * x.value() + y.value() * y.value();
  Dual<N> d(std::atan2(y.value(), x.value()));
  if (r2 > 0) d = (x * y.chain(0.0, 1.0) - y * x.chain(0.0, 1.0)) / r2 + d;
  return d;
}
template <int N>
Dual<N> hypot(const Dual<N>& a, const Dual<N>& b) {
  const double h = std::hypot(a.value(), b.value());
  if (h == 0) return Dual<N>(0.0);
  // The value is std::hypot's own (bitwise what the double code computes).
  return a.chain(h, a.value() / h) + b.chain(0.0, b.value() / h);
}
template <int N>
Dual<N> abs(const Dual<N>& x) {
  return x.value() < 0 ? -x : x;
}
template <int N>
Dual<N> pow(const Dual<N>& x, double p) {
  const double v = std::pow(x.value(), p);
  return x.chain(v, x.value() != 0 ? p * v / x.value() : 0.0);
}

// Code templated over double and Dual<N> calls these unqualified.
using std::abs;
using std::atan2;
using std::cos;
using std::exp;
using std::hypot;
using std::log;
using std::log1p;
using std::pow;
using std::sin;
using std::sqrt;

// The value of a double or a dual, for code templated over both.
inline double value_of(double x) {
  return x;
}
template <int N>
double value_of(const Dual<N>& x) {
  return x.value();
}

}  // namespace frichb::sdk
