// uncoupled_2d: two independent elastic Coulomb sliders (Jenkins elements) in t1 and t2,
// each limited by the same mu N, with a constant normal load or one that follows the normal
// relative displacement, with separation. The friction limit is a square, not a circle:
// |T| may reach sqrt(2) mu N (the common simplification; coupled_3d is the coupled law).
//
//   N = max(0, N0 + kn (u_n - g0))            (kn = 0: N = N0, constant)
//   for i = 1, 2: trial T*_i = kt (u_ti - w_i,prev)
//   stick  |T*_i| <= mu N : T_i = T*_i,                w_i = w_i,prev
//   slip   |T*_i| >  mu N : T_i = mu N sign(T*_i),     w_i = u_ti - T_i / kt
//   separated N = 0       : T = 0,                     w = u_t   (both sliders released)
// State: w = (w1, w2), the slider (stick-point) positions in m.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "frichb/plugin/normal_load.hpp"
#include "frichb/plugin/sdk.hpp"
#include "frichb/plugin/tangents.hpp"

namespace {

using frichb::sdk::Param;

std::vector<frichb_param_spec> uncoupled_schema() {
  return frichb::sdk::with_normal_load({
      Param::real("kt", "N/m", "tangential contact stiffness, the same in t1 and t2")
          .greater_than(0),
      Param::real("mu", "", "friction coefficient").at_least(0),
  });
}

class Uncoupled2d final : public frichb::sdk::ContactLaw {
 public:
  explicit Uncoupled2d(const frichb::sdk::Params& p)
      : kt_(p.real("kt")), mu_(p.real("mu")), normal_(p) {}

  frichb_contact_law_traits traits() const override {
    return frichb::sdk::make_traits(2, normal_.variable(), 2, true);
  }

  void step(const double* state_prev, const double* /*u_prev*/, const double* u_now,
            double* force_now, double* state_now,
            const frichb_step_tangents* tangents) const override {
    const bool variable = normal_.variable();
    const auto [normal, dnormal_dun, open] = normal_.at(u_now[2]);
    const double limit = mu_ * normal;
    const bool separated = open;

    // Per direction i: T_i, w_i and their partial derivatives with respect to u_ti, u_n and
    // w_i,prev (the directions do not interact).
    double t[2] = {0, 0}, w[2] = {0, 0};
    Eigen::Vector2d dt_dut = Eigen::Vector2d::Zero(), dt_dun = Eigen::Vector2d::Zero(),
                    dt_dw = Eigen::Vector2d::Zero();
    Eigen::Vector2d dw_dut = Eigen::Vector2d::Zero(), dw_dun = Eigen::Vector2d::Zero(),
                    dw_dw = Eigen::Vector2d::Zero();
    for (int i = 0; i < 2; ++i) {
      const double trial = kt_ * (u_now[i] - state_prev[i]);
      if (separated) {
        // Separated: no force, and the slider follows so that contact resumes unloaded.
        w[i] = u_now[i];
        dw_dut(i) = 1;
      } else if (std::abs(trial) <= limit) {
        t[i] = trial;
        w[i] = state_prev[i];
        dt_dut(i) = kt_;
        dt_dw(i) = -kt_;
        dw_dw(i) = 1;
      } else {
        const double sign = trial > 0 ? 1.0 : -1.0;
        t[i] = sign * limit;
        w[i] = u_now[i] - t[i] / kt_;
        dt_dun(i) = sign * mu_ * dnormal_dun;
        dw_dut(i) = 1;
        dw_dun(i) = -dt_dun(i) / kt_;
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
    // Diagonal blocks in (t1, t2): each direction depends on its own u_ti and w_i only.
    auto fu = tangent.dforce_du_now();
    fu.topLeftCorner<2, 2>().diagonal() = dt_dut;
    fu.topRightCorner<2, 1>() = dt_dun;
    fu(2, 2) = variable ? dnormal_dun : 0.0;
    tangent.dforce_dstate_prev().topRows<2>().diagonal() = dt_dw;
    auto su = tangent.dstate_du_now();
    su.leftCols<2>().diagonal() = dw_dut;
    su.col(2) = dw_dun;
    tangent.dstate_dstate_prev().diagonal() = dw_dw;
  }

 private:
  double kt_, mu_;
  frichb::sdk::NormalLoad normal_;
};

}  // namespace

FRICHB_CONTACT_LAW_PLUGIN(Uncoupled2d, uncoupled_2d, "1.0.0",
                          "two independent elastic Coulomb sliders in t1 and t2 limited by the "
                          "same mu N (square friction limit), constant or displacement-dependent "
                          "normal load with separation",
                          uncoupled_schema)
