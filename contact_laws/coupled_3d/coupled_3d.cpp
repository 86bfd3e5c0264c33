// coupled_3d: elastic Coulomb slider in the tangential plane (t1, t2) with an isotropic
// friction circle, and a constant normal load or one that follows the normal relative
// displacement, with separation (the 3D coupled law).
//
//   N = max(0, N0 + kn (u_n - g0))            (kn = 0: N = N0, constant)
//   trial T* = kt (u_t - w_prev)               (2-vectors in the tangential plane)
//   stick  |T*| <= mu N : T = T*,                  w = w_prev
//   slip   |T*| >  mu N : T = mu N T* / |T*|,      w = u_t - T / kt   (radial return)
//   separated N = 0     : T = 0,                   w = u_t   (the slider is released)
// State: w = (w1, w2), the slider (stick-point) position in m.
//
// step() (the samples alone) advances the slider by the radial return above, first order in
// the step. step_along() (ABI 1.3, the host's periodic traces) advances it along the motion
// between the samples with the SDK's FrictionCircleSlider: the law solved on the step's cubic
// Hermite motion with its events located inside the step, fourth order in the step before the
// host's quadrature; its tangents come from dual numbers.
//
// Consistent tangents in slip, with n = T*/|T*| and P = I - n n^T:
//   dT/du_t = (mu N / |T*|) kt P,   dT/dw_prev = -dT/du_t,   dT/du_n = mu (dN/du_n) n,
//   dw/du_t = I - dT/du_t / kt,     dw/dw_prev = -dT/dw_prev / kt,   dw/du_n = -dT/du_n / kt.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "frichb/plugin/friction_circle.hpp"
#include "frichb/plugin/normal_load.hpp"
#include "frichb/plugin/sdk.hpp"
#include "frichb/plugin/tangents.hpp"

namespace {

using frichb::sdk::Param;

std::vector<frichb_param_spec> coupled_schema() {
  return frichb::sdk::with_normal_load({
      Param::real("kt", "N/m", "tangential contact stiffness, isotropic in the tangential plane")
          .greater_than(0),
      Param::real("mu", "", "friction coefficient").at_least(0),
  });
}

// The normal side for the slider: N = max(0, N0 + kn (u_n - g0)) (constant N0 when kn = 0),
// kt constant. N and the stick radius mu N / kt never decrease with u_n (kn >= 0).
struct LinearNormalSide {
  static constexpr bool kMonotone = true;
  double n0, kn, gap, kt;
  template <class S>
  S closure(const S& un) const {
    return kn > 0 ? n0 + kn * (un - gap) : S(n0);
  }
  template <class S>
  frichb::sdk::NormalSide<S> side(const S& un) const {
    return {closure(un), S(kn), S(kt), S(0.0)};
  }
};

class Coupled3d final : public frichb::sdk::ContactLaw {
 public:
  explicit Coupled3d(const frichb::sdk::Params& p)
      : kt_(p.real("kt")),
        mu_(p.real("mu")),
        normal_(p),
        slider_(LinearNormalSide{p.real("normal_load"), p.real("kn"), p.real("gap"), p.real("kt")},
                p.real("mu")) {}

  frichb_contact_law_traits traits() const override {
    return frichb::sdk::make_traits(2, normal_.variable(), 2, true, true);
  }

  void step_along(const double* state_prev, const double* u_prev, const double* u_now,
                  const frichb_step_motion& motion, double* force_now, double* state_now,
                  const frichb_step_tangents* tangents,
                  const frichb_motion_tangents* motion_tangents,
                  frichb_force_kinks* kinks) const override {
    frichb::sdk::friction_circle_step_along(slider_, normal_.variable(), state_prev, u_prev, u_now,
                                            motion, force_now, state_now, tangents, motion_tangents,
                                            kinks);
  }

  void step(const double* state_prev, const double* /*u_prev*/, const double* u_now,
            double* force_now, double* state_now,
            const frichb_step_tangents* tangents) const override {
    const bool variable = normal_.variable();
    const auto [normal, dnormal_dun, open] = normal_.at(u_now[2]);
    const double limit = mu_ * normal;
    const double trial[2] = {kt_ * (u_now[0] - state_prev[0]), kt_ * (u_now[1] - state_prev[1])};
    const double trial_norm = std::hypot(trial[0], trial[1]);

    double t[2] = {0, 0}, w[2] = {0, 0};
    // Partial derivatives of T and w (rows i = t1, t2) with respect to u_t (columns t1, t2),
    // u_n and w_prev (columns w1, w2).
    Eigen::Matrix2d dt_dut = Eigen::Matrix2d::Zero(), dt_dw = Eigen::Matrix2d::Zero();
    Eigen::Matrix2d dw_dut = Eigen::Matrix2d::Zero(), dw_dw = Eigen::Matrix2d::Zero();
    Eigen::Vector2d dt_dun = Eigen::Vector2d::Zero(), dw_dun = Eigen::Vector2d::Zero();
    if (open) {
      // Separated: no force, and the slider follows so that contact resumes unloaded.
      for (int i = 0; i < 2; ++i) {
        w[i] = u_now[i];
        dw_dut(i, i) = 1;
      }
    } else if (trial_norm <= limit) {
      for (int i = 0; i < 2; ++i) {
        t[i] = trial[i];
        w[i] = state_prev[i];
        dt_dut(i, i) = kt_;
        dt_dw(i, i) = -kt_;
        dw_dw(i, i) = 1;
      }
    } else {
      // Radial return onto the friction circle; trial_norm > limit >= 0 here.
      const double dir[2] = {trial[0] / trial_norm, trial[1] / trial_norm};
      const double ratio = limit / trial_norm;
      for (int i = 0; i < 2; ++i) {
        t[i] = limit * dir[i];
        w[i] = u_now[i] - t[i] / kt_;
        dt_dun(i) = mu_ * dnormal_dun * dir[i];
        dw_dun(i) = -dt_dun(i) / kt_;
        for (int j = 0; j < 2; ++j) {
          const double projector = (i == j ? 1.0 : 0.0) - dir[i] * dir[j];
          dt_dut(i, j) = ratio * kt_ * projector;
          dt_dw(i, j) = -dt_dut(i, j);
          dw_dut(i, j) = (i == j ? 1.0 : 0.0) - dt_dut(i, j) / kt_;
          dw_dw(i, j) = -dt_dw(i, j) / kt_;
        }
      }
    }
    force_now[0] = t[0];
    force_now[1] = t[1];
    force_now[2] = variable ? normal : 0.0;
    state_now[0] = w[0];
    state_now[1] = w[1];
    const frichb::sdk::StepTangents tangent(tangents, 2);
    if (!tangent.wanted()) return;
    tangent.zero();
    auto fu = tangent.dforce_du_now();
    fu.topLeftCorner<2, 2>() = dt_dut;
    fu.topRightCorner<2, 1>() = dt_dun;
    fu(2, 2) = variable ? dnormal_dun : 0.0;
    tangent.dforce_dstate_prev().topRows<2>() = dt_dw;
    auto su = tangent.dstate_du_now();
    su.leftCols<2>() = dw_dut;
    su.col(2) = dw_dun;
    tangent.dstate_dstate_prev() = dw_dw;
  }

 private:
  double kt_, mu_;
  frichb::sdk::NormalLoad normal_;
  frichb::sdk::FrictionCircleSlider<LinearNormalSide> slider_;
};

}  // namespace

FRICHB_CONTACT_LAW_PLUGIN(Coupled3d, coupled_3d, "1.0.0",
                          "elastic Coulomb slider in the tangential plane with an isotropic "
                          "friction circle, constant or displacement-dependent normal load with "
                          "separation",
                          coupled_schema)
