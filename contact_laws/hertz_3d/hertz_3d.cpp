// hertz_3d: coupled 3D friction contact (2D tangential slider inside the friction circle,
// normal motion with separation) with penetration-dependent Hertz stiffnesses, thesis
// eq. 3.2 (Kt = sqrt(Z), Kn = 3 sqrt(Z) / 2 for unit coefficients).
//
//   p  = p0 + u_n - g                       penetration; open for p <= 0
//   s(p) = sqrt(p)                          p >= eps
//        = 1.5 p / sqrt(eps) - p^2 / (2 eps^1.5)   0 <= p < eps (C1, s'(0) finite)
//   kt = c_t s(p),  kn = 1.5 c_n s(p),  N = integral of kn from 0 to p:
//        N = c_n (1.125 p^2 / sqrt(eps) - p^3 / (4 eps^1.5))  p < eps
//        N = c_n (p^1.5 - eps^1.5 / 8)                          p >= eps
//   trial T* = kt (u_t - w_prev)              (2-vectors, secant with the current kt)
//   stick  |T*| <= mu N : T = T*,              w = w_prev
//   slip   |T*| >  mu N : T = mu N T*/|T*|,    w = u_t - T / kt
//   open   p <= 0      : T = 0, N = 0,         w = u_t   (the slider is released)
// State: w = (w1, w2), the slider position in the tangential plane, m.
//
// step() (the samples alone) advances the slider by the return above, first order in the
// step. step_along() (ABI 1.3, the host's periodic traces) advances it along the motion
// between the samples with the SDK's FrictionCircleSlider (the law solved on the step's cubic
// Hermite motion, its events located inside the step); its tangents come from dual numbers.
#include <Eigen/Core>
#include <array>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "frichb/plugin/friction_circle.hpp"
#include "frichb/plugin/sdk.hpp"
#include "frichb/plugin/tangents.hpp"

namespace {

using frichb::sdk::Param;

std::vector<frichb_param_spec> hertz_schema() {
  return {
      Param::real("normal_coefficient", "N/m^1.5", "c_n in N = c_n p^1.5 (p: penetration)")
          .greater_than(0),
      Param::real("tangential_coefficient", "N/m^1.5",
                  "c_t in the tangential stiffness kt = c_t sqrt(p)")
          .greater_than(0),
      Param::real("mu", "", "friction coefficient").at_least(0),
      Param::real("gap", "m", "initial normal gap g (p = p0 + u_n - g)")
          .defaults_to(0.0)
          .at_least(0),
      Param::real("static_penetration", "m",
                  "penetration p0 of the static equilibrium at u = 0 (its force N(p0) is "
                  "subtracted by the host as the reference force)")
          .defaults_to(0.0)
          .at_least(0),
      Param::real("regularization", "m",
                  "eps: below this penetration sqrt(p) is replaced by a C1 quadratic so that "
                  "the stiffness derivatives stay finite at p = 0")
          .defaults_to(1e-9)
          .greater_than(0),
  };
}

// The normal side for the slider: penetration p = p0 + u_n - g, and with the regularised root
// s(p) (header comment) kt = c_t s, N = c_n * integral of 1.5 s, dN/du_n = 1.5 c_n s.
// The closure and the stick radius mu N / kt (mu c_n / c_t times pen - eps^1.5 / (8 sqrt(pen))
// above eps and pen (9 - 2 x) / (12 - 4 x), x = pen / eps, below) never decrease with u_n.
struct HertzNormalSide {
  static constexpr bool kMonotone = true;
  double cn, ct, gap, p0, eps;
  // At a contact change crossed at the normal rate v (m per step) the penetration grows as
  // |v| |s - s_c|: N ~ c_n |v|^1.5 |s - s_c|^1.5 and kt ~ c_t |v|^0.5 |s - s_c|^0.5 (the
  // regularisation below eps spans eps / |v| of a step, 1e-4 at 1e-5 m per step; its effect
  // on the quadrature is of the order of c_n eps^1.5).
  static constexpr double kOnsetPower = 1.5;
  template <class S>
  S normal_onset(const S& rate) const {
    using std::sqrt;
    const S speed = rate > 0 ? rate : S(0.0) - rate;
    return speed > 0 ? cn * speed * sqrt(speed) : S(0.0);
  }
  template <class S>
  S stiffness_onset(const S& rate) const {
    using std::sqrt;
    const S speed = rate > 0 ? rate : S(0.0) - rate;
    return speed > 0 ? ct * sqrt(speed) : S(0.0);
  }
  template <class S>
  S closure(const S& un) const {
    return un + (p0 - gap);
  }
  template <class S>
  frichb::sdk::NormalSide<S> side(const S& un) const {
    const S pen = closure(un);
    if (!(pen > 0)) return {S(0.0), S(0.0), S(0.0), S(0.0)};  // open: the law's N = 0, kt = 0
    const double sqrt_eps = std::sqrt(eps), e15 = eps * sqrt_eps;
    S root, droot, integral;
    if (pen >= eps) {
      using std::sqrt;
      root = sqrt(pen);
      droot = 0.5 / root;
      integral = pen * root - 0.125 * e15;
    } else {
      root = 1.5 * pen / sqrt_eps - 0.5 * pen * pen / e15;
      droot = 1.5 / sqrt_eps - pen / e15;
      integral = 1.125 * pen * pen / sqrt_eps - 0.25 * pen * pen * pen / e15;
    }
    return {cn * integral, 1.5 * cn * root, ct * root, ct * droot};
  }
};

class Hertz3d final : public frichb::sdk::ContactLaw {
 public:
  explicit Hertz3d(const frichb::sdk::Params& p)
      : cn_(p.real("normal_coefficient")),
        ct_(p.real("tangential_coefficient")),
        mu_(p.real("mu")),
        gap_(p.real("gap")),
        p0_(p.real("static_penetration")),
        eps_(p.real("regularization")),
        sqrt_eps_(std::sqrt(eps_)),
        slider_(HertzNormalSide{cn_, ct_, gap_, p0_, eps_}, mu_) {
    if (gap_ > 0 && p0_ > 0)
      throw std::invalid_argument("give either gap or static_penetration, not both");
  }

  frichb_contact_law_traits traits() const override {
    return frichb::sdk::make_traits(2, true, 2, true, true);
  }

  void step_along(const double* state_prev, const double* u_prev, const double* u_now,
                  const frichb_step_motion& motion, double* force_now, double* state_now,
                  const frichb_step_tangents* tangents,
                  const frichb_motion_tangents* motion_tangents,
                  frichb_force_kinks* kinks) const override {
    frichb::sdk::friction_circle_step_along(slider_, true, state_prev, u_prev, u_now, motion,
                                            force_now, state_now, tangents, motion_tangents, kinks);
  }

  void step(const double* state_prev, const double* /*u_prev*/, const double* u_now,
            double* force_now, double* state_now,
            const frichb_step_tangents* tangents) const override {
    const double pen = u_now[2] + p0_ - gap_;
    const std::array<double, 2> ut{u_now[0], u_now[1]};
    const std::array<double, 2> wp{state_prev[0], state_prev[1]};

    std::array<double, 2> t{0, 0}, w{0, 0};
    double normal = 0, kn = 0;
    // Partial derivatives: T and w with respect to u_t (2x2), u_n (2), w_prev (2x2).
    Eigen::Matrix2d dt_dut = Eigen::Matrix2d::Zero(), dt_dw = Eigen::Matrix2d::Zero();
    Eigen::Matrix2d dw_dut = Eigen::Matrix2d::Zero(), dw_dw = Eigen::Matrix2d::Zero();
    Eigen::Vector2d dt_dun = Eigen::Vector2d::Zero(), dw_dun = Eigen::Vector2d::Zero();

    if (pen <= 0) {
      w = ut;
      dw_dut.setIdentity();
    } else {
      const Root r = root(pen);
      const double kt = ct_ * r.s;
      const double dkt = ct_ * r.ds;
      normal = cn_ * r.integral;
      kn = 1.5 * cn_ * r.s;
      const std::array<double, 2> d{ut[0] - wp[0], ut[1] - wp[1]};
      const std::array<double, 2> trial{kt * d[0], kt * d[1]};
      const double norm = std::hypot(trial[0], trial[1]);
      const double limit = mu_ * normal;
      if (norm <= limit) {
        t = trial;
        w = wp;
        dt_dut << kt, 0, 0, kt;
        dt_dw << -kt, 0, 0, -kt;
        dt_dun << dkt * d[0], dkt * d[1];
        dw_dw.setIdentity();
      } else {
        // norm > limit >= 0 and kt > 0 here (pen > 0), so |d| > 0.
        const double dn = std::hypot(d[0], d[1]);
        const std::array<double, 2> e{d[0] / dn, d[1] / dn};
        t = {limit * e[0], limit * e[1]};
        w = {ut[0] - t[0] / kt, ut[1] - t[1] / kt};
        // dT/du_t = mu N (I - e e^T) / |d| = -dT/dw_prev
        const double c = limit / dn;
        dt_dut << c * (1 - e[0] * e[0]), -c * e[0] * e[1], -c * e[1] * e[0], c * (1 - e[1] * e[1]);
        dt_dw = -dt_dut;
        dt_dun << mu_ * kn * e[0], mu_ * kn * e[1];
        for (int i = 0; i < 2; ++i) {
          for (int j = 0; j < 2; ++j) {
            dw_dut(i, j) = (i == j ? 1.0 : 0.0) - dt_dut(i, j) / kt;
            dw_dw(i, j) = -dt_dw(i, j) / kt;
          }
          dw_dun(i) = -dt_dun(i) / kt + t[i] * dkt / (kt * kt);
        }
      }
    }
    force_now[0] = t[0];
    force_now[1] = t[1];
    force_now[2] = normal;
    state_now[0] = w[0];
    state_now[1] = w[1];
    const frichb::sdk::StepTangents tangent(tangents, 2);
    if (!tangent.wanted()) return;
    tangent.zero();
    auto fu = tangent.dforce_du_now();
    fu.topLeftCorner<2, 2>() = dt_dut;
    fu.topRightCorner<2, 1>() = dt_dun;
    fu(2, 2) = kn;
    tangent.dforce_dstate_prev().topRows<2>() = dt_dw;
    auto su = tangent.dstate_du_now();
    su.leftCols<2>() = dw_dut;
    su.col(2) = dw_dun;
    tangent.dstate_dstate_prev() = dw_dw;
  }

 private:
  // s(p), s'(p) and the integral of 1.5 s from 0 to p (so that N = c_n * integral).
  struct Root {
    double s, ds, integral;
  };
  Root root(double pen) const {
    if (pen >= eps_) {
      const double sq = std::sqrt(pen);
      return {sq, 0.5 / sq, pen * sq - 0.125 * eps_ * sqrt_eps_};
    }
    const double e15 = eps_ * sqrt_eps_;
    return {1.5 * pen / sqrt_eps_ - 0.5 * pen * pen / e15, 1.5 / sqrt_eps_ - pen / e15,
            1.125 * pen * pen / sqrt_eps_ - 0.25 * pen * pen * pen / e15};
  }

  double cn_, ct_, mu_, gap_, p0_, eps_, sqrt_eps_;
  frichb::sdk::FrictionCircleSlider<HertzNormalSide> slider_;
};

}  // namespace

FRICHB_CONTACT_LAW_PLUGIN(Hertz3d, hertz_3d, "1.0.0",
                          "coupled 3D friction contact with Hertz stiffnesses kt = c_t sqrt(p), "
                          "N = c_n p^1.5, slip on the friction circle and separation",
                          hertz_schema)
