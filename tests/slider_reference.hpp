// An independent reference for friction-circle contacts: the slider of an elastic Coulomb
// contact integrated in time along a smooth prescribed motion by an adaptive Dormand-Prince
// 5(4) scheme (tolerance 1e-12 by default), with its stick, slip, separation and re-contact
// events located by bisection to 1e-14 of the period, and the force's Fourier coefficients
// and the energy per cycle integrated as part of the same ODE (so each smooth piece between
// events is integrated to the tolerance, with no sampling at all).
//
// It shares no code with the SDK's FrictionCircleSlider: the slider is integrated as a vector,
// w' = lambda e in slip (e = (u_t - w) / |u_t - w|), not by its direction, along the exact
// motion u(theta), not an interpolated one, and its events come from bisection on the
// integrated state.
//
// Time is the phase theta in [0, 2 pi); rates are d/dtheta. The periodic response is reached
// by tracing whole periods from the unloaded slider until it repeats to 1e-13.
#pragma once

#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <functional>
#include <numbers>
#include <stdexcept>
#include <vector>

namespace frichb::testing {

struct ReferenceContact {
  double mu = 0.3;
  // N(u_n) >= 0, and kt(u_n) > 0 where N > 0; their derivatives in u_n.
  std::function<double(double)> normal, dnormal, stiffness, dstiffness;
};

struct ReferenceMotion {
  std::function<Eigen::Vector3d(double)> position, rate;  // u(theta), du/dtheta
};

struct ReferenceResult {
  // force_coefficients(a, k): component a (T1, T2, N) of [mean, cos 1, sin 1, cos 2, ...],
  // the layout q = c0 + sum (c_n cos n theta + s_n sin n theta).
  Eigen::MatrixXd force_coefficients;
  double energy = 0;  // closed integral of f . du over the period, J
  int periods = 0;
  long steps = 0;
};

class SliderReference {
 public:
  SliderReference(ReferenceContact contact, ReferenceMotion motion, int max_harmonic,
                  double tolerance = 1e-12)
      : c_(std::move(contact)), m_(std::move(motion)), h_(max_harmonic), tol_(tolerance) {}

  ReferenceResult solve(int max_periods = 5000) {
    std::array<double, 2> w{0, 0};
    Mode mode = Mode::kStick;
    ReferenceResult r;
    for (r.periods = 1; r.periods <= max_periods; ++r.periods) {
      const std::array<double, 2> start = w;
      Eigen::VectorXd q;
      // A slider that starts a period outside the circle is returned onto it first.
      mode = classify(0.0, w);
      run_period(w, mode, q, r.steps);
      const double scale = std::max({1e-300, std::abs(w[0]), std::abs(w[1]),
                                     m_.position(0.0).head<2>().cwiseAbs().maxCoeff()});
      if (std::max(std::abs(w[0] - start[0]), std::abs(w[1] - start[1])) <= 1e-13 * scale &&
          r.periods > 1) {
        const int cols = 2 * h_ + 1;
        r.force_coefficients.resize(3, cols);
        for (int a = 0; a < 3; ++a)
          for (int k = 0; k < cols; ++k)
            r.force_coefficients(a, k) =
                q(a * cols + k) / (k == 0 ? 2 * std::numbers::pi : std::numbers::pi);
        r.energy = q(3 * cols);
        return r;
      }
    }
    throw std::runtime_error("reference slider did not become periodic");
  }

 private:
  enum class Mode { kOpen, kStick, kSlip };

  int quadratures() const { return 3 * (2 * h_ + 1) + 1; }

  // Mode at theta for slider w (returned onto the circle when outside it).
  Mode classify(double t, std::array<double, 2>& w) const {
    const Eigen::Vector3d u = m_.position(t);
    const double n = c_.normal(u[2]);
    if (!(n > 0) || !(c_.mu > 0)) return Mode::kOpen;
    const double kt = c_.stiffness(u[2]);
    const Eigen::Vector2d d(u[0] - w[0], u[1] - w[1]);
    const double limit = c_.mu * n;
    if (kt * d.norm() < limit * (1 - 1e-12)) return Mode::kStick;
    const Eigen::Vector2d e = d / d.norm();
    w = {u[0] - limit / kt * e[0], u[1] - limit / kt * e[1]};
    return slip_rate(t, w) > 0 ? Mode::kSlip : Mode::kStick;
  }

  double slip_rate(double t, const std::array<double, 2>& w) const {
    const Eigen::Vector3d u = m_.position(t), v = m_.rate(t);
    const double n = c_.normal(u[2]), kt = c_.stiffness(u[2]);
    Eigen::Vector2d e(u[0] - w[0], u[1] - w[1]);
    e.normalize();
    return e.dot(v.head<2>()) + c_.mu * n * c_.dstiffness(u[2]) * v[2] / (kt * kt) -
           c_.mu * c_.dnormal(u[2]) * v[2] / kt;
  }

  // y = [w1, w2, quadratures...]
  Eigen::VectorXd rhs(double t, const Eigen::VectorXd& y, Mode mode) const {
    Eigen::VectorXd f = Eigen::VectorXd::Zero(y.size());
    const Eigen::Vector3d u = m_.position(t), v = m_.rate(t);
    std::array<double, 3> force{0, 0, 0};
    if (mode != Mode::kOpen) {
      const double kt = c_.stiffness(u[2]);
      force = {kt * (u[0] - y[0]), kt * (u[1] - y[1]), c_.normal(u[2])};
      if (mode == Mode::kSlip) {
        const double lam = slip_rate(t, {y[0], y[1]});
        Eigen::Vector2d e(u[0] - y[0], u[1] - y[1]);
        e.normalize();
        f[0] = lam * e[0];
        f[1] = lam * e[1];
      }
    } else {
      f[0] = v[0];
      f[1] = v[1];
    }
    const int cols = 2 * h_ + 1;
    for (int a = 0; a < 3; ++a) {
      f[2 + a * cols] = force[static_cast<std::size_t>(a)];
      for (int n = 1; n <= h_; ++n) {
        f[2 + a * cols + 2 * n - 1] = force[static_cast<std::size_t>(a)] * std::cos(n * t);
        f[2 + a * cols + 2 * n] = force[static_cast<std::size_t>(a)] * std::sin(n * t);
      }
    }
    f[2 + 3 * cols] = force[0] * v[0] + force[1] * v[1] + force[2] * v[2];
    return f;
  }

  // One Dormand-Prince step; returns the fifth-order result and the error estimate.
  Eigen::VectorXd dp_step(double t, const Eigen::VectorXd& y, double h, Mode mode,
                          double* error) const {
    static constexpr double a21 = 1.0 / 5, a31 = 3.0 / 40, a32 = 9.0 / 40, a41 = 44.0 / 45,
                            a42 = -56.0 / 15, a43 = 32.0 / 9, a51 = 19372.0 / 6561,
                            a52 = -25360.0 / 2187, a53 = 64448.0 / 6561, a54 = -212.0 / 729,
                            a61 = 9017.0 / 3168, a62 = -355.0 / 33, a63 = 46732.0 / 5247,
                            a64 = 49.0 / 176, a65 = -5103.0 / 18656, b1 = 35.0 / 384,
                            b3 = 500.0 / 1113, b4 = 125.0 / 192, b5 = -2187.0 / 6784,
                            b6 = 11.0 / 84, e1 = 71.0 / 57600, e3 = -71.0 / 16695, e4 = 71.0 / 1920,
                            e5 = -17253.0 / 339200, e6 = 22.0 / 525, e7 = -1.0 / 40;
    const Eigen::VectorXd k1 = rhs(t, y, mode);
    const Eigen::VectorXd k2 = rhs(t + h / 5, y + h * a21 * k1, mode);
    const Eigen::VectorXd k3 = rhs(t + 3 * h / 10, y + h * (a31 * k1 + a32 * k2), mode);
    const Eigen::VectorXd k4 = rhs(t + 4 * h / 5, y + h * (a41 * k1 + a42 * k2 + a43 * k3), mode);
    const Eigen::VectorXd k5 =
        rhs(t + 8 * h / 9, y + h * (a51 * k1 + a52 * k2 + a53 * k3 + a54 * k4), mode);
    const Eigen::VectorXd k6 =
        rhs(t + h, y + h * (a61 * k1 + a62 * k2 + a63 * k3 + a64 * k4 + a65 * k5), mode);
    const Eigen::VectorXd y5 = y + h * (b1 * k1 + b3 * k3 + b4 * k4 + b5 * k5 + b6 * k6);
    const Eigen::VectorXd k7 = rhs(t + h, y5, mode);
    if (error != nullptr) {
      const Eigen::VectorXd err = h * (e1 * k1 + e3 * k3 + e4 * k4 + e5 * k5 + e6 * k6 + e7 * k7);
      double worst = 0;
      for (Eigen::Index i = 0; i < y.size(); ++i)
        worst = std::max(worst, std::abs(err[i]) / (atol_[i] + tol_ * std::abs(y5[i])));
      *error = worst;
    }
    return y5;
  }

  // Event function of the mode at (t, y): a sign change ends the mode.
  double event(double t, const Eigen::VectorXd& y, Mode mode, int* which) const {
    const Eigen::Vector3d u = m_.position(t);
    const double n = c_.normal(u[2]);
    const double scale = c_.mu * n_scale_;
    if (mode == Mode::kOpen) {
      *which = 0;
      return n > 0 ? 1.0 : -1.0;  // closes
    }
    if (!(n > 0)) {
      *which = 1;  // opens
      return 1.0;
    }
    if (mode == Mode::kStick) {
      *which = 2;  // to slip
      const double kt = c_.stiffness(u[2]);
      return (kt * std::hypot(u[0] - y[0], u[1] - y[1]) - c_.mu * n) / scale;
    }
    *which = 3;  // to stick
    return -slip_rate(t, {y[0], y[1]});
  }

  void run_period(std::array<double, 2>& w, Mode& mode, Eigen::VectorXd& q, long& steps) {
    const double period = 2 * std::numbers::pi;
    Eigen::VectorXd y = Eigen::VectorXd::Zero(2 + quadratures());
    y[0] = w[0];
    y[1] = w[1];
    // Absolute tolerances: the slider on the motion's scale, quadratures on the force's.
    const double u_scale = std::max(1e-300, m_.position(0.0).cwiseAbs().maxCoeff() +
                                                m_.position(period / 4).cwiseAbs().maxCoeff());
    n_scale_ = 0;
    for (int k = 0; k < 16; ++k)
      n_scale_ = std::max(n_scale_, c_.normal(m_.position(period * k / 16)[2]));
    n_scale_ = std::max(n_scale_, 1e-300);
    atol_ = Eigen::VectorXd::Constant(y.size(), tol_ * std::max(1.0, n_scale_) * u_scale);
    atol_[0] = atol_[1] = tol_ * u_scale;
    double t = 0, h = period / 256;
    if (mode == Mode::kOpen) {
      const Eigen::Vector3d u = m_.position(0.0);
      y[0] = u[0];
      y[1] = u[1];
    }
    while (t < period) {
      h = std::min(h, period - t);
      double err = 0;
      Eigen::VectorXd next = dp_step(t, y, h, mode, &err);
      ++steps;
      if (err > 1.0) {
        h *= std::max(0.2, 0.9 * std::pow(err, -0.2));
        continue;
      }
      int which = 0;
      // Inside its mode the event function has not crossed yet, whatever rounding says at the
      // mode's start (a slider just put onto the circle).
      const double g0 = std::min(event(t, y, mode, &which), 0.0);
      const double g1 = event(t + h, next, mode, &which);
      if ((g0 <= 0) == (g1 <= 0) || (mode == Mode::kStick && which == 2 && g1 <= 0)) {
        t += h;
        y = next;
        if (mode == Mode::kOpen) {
          const Eigen::Vector3d u = m_.position(t);
          y[0] = u[0];
          y[1] = u[1];
        }
        h *= std::min(5.0, 0.9 * std::pow(std::max(err, 1e-10), -0.2));
        continue;
      }
      // Bisection on the step length for the event.
      double lo = 0, hi = h;
      while (hi - lo > 1e-14) {
        const double mid = 0.5 * (lo + hi);
        const Eigen::VectorXd trial = dp_step(t, y, mid, mode, nullptr);
        int w2 = 0;
        if ((event(t + mid, trial, mode, &w2) <= 0) == (g0 <= 0))
          lo = mid;
        else
          hi = mid;
      }
      y = dp_step(t, y, hi, mode, nullptr);
      t += hi;
      event(t, y, mode, &which);
      std::array<double, 2> ws{y[0], y[1]};
      const Eigen::Vector3d u = m_.position(t);
      if (which == 0) {
        ws = {u[0], u[1]};
        mode = Mode::kStick;
      } else if (which == 1) {
        mode = Mode::kOpen;
        ws = {u[0], u[1]};
      } else if (which == 2) {
        mode = classify(t, ws);
        if (mode == Mode::kStick) {
          // Grazing the circle with the motion turning inwards: stay stuck past the graze.
          y[0] = ws[0];
          y[1] = ws[1];
          const double dt = std::min(1e-9, period - t);
          y = dp_step(t, y, dt, mode, nullptr);
          t += dt;
          ws = {y[0], y[1]};
        }
      } else {
        mode = Mode::kStick;
      }
      y[0] = ws[0];
      y[1] = ws[1];
      if (mode == Mode::kSlip) {
        // Back onto the circle exactly (the constraint the vector ODE keeps to its tolerance).
        const double kt = c_.stiffness(u[2]), limit = c_.mu * c_.normal(u[2]);
        Eigen::Vector2d e(u[0] - y[0], u[1] - y[1]);
        e.normalize();
        y[0] = u[0] - limit / kt * e[0];
        y[1] = u[1] - limit / kt * e[1];
      }
      h = std::max(h, 1e-6);
    }
    w = {y[0], y[1]};
    q = y.tail(quadratures());
  }

  ReferenceContact c_;
  ReferenceMotion m_;
  int h_;
  double tol_;
  double n_scale_ = 1;
  Eigen::VectorXd atol_;
};

}  // namespace frichb::testing
