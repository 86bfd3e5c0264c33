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
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "frichb/plugin/normal_load.hpp"
#include "frichb/plugin/sdk.hpp"

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
    double dt_dut[2] = {}, dt_dun[2] = {}, dt_dw[2] = {};
    double dw_dut[2] = {}, dw_dun[2] = {}, dw_dw[2] = {};
    for (int i = 0; i < 2; ++i) {
      const double trial = kt_ * (u_now[i] - state_prev[i]);
      if (separated) {
        // Separated: no force, and the slider follows so that contact resumes unloaded.
        w[i] = u_now[i];
        dw_dut[i] = 1;
      } else if (std::abs(trial) <= limit) {
        t[i] = trial;
        w[i] = state_prev[i];
        dt_dut[i] = kt_;
        dt_dw[i] = -kt_;
        dw_dw[i] = 1;
      } else {
        const double sign = trial > 0 ? 1.0 : -1.0;
        t[i] = sign * limit;
        w[i] = u_now[i] - t[i] / kt_;
        dt_dun[i] = sign * mu_ * dnormal_dun;
        dw_dut[i] = 1;
        dw_dun[i] = -dt_dun[i] / kt_;
      }
    }
    force_now[0] = t[0];
    force_now[1] = t[1];
    force_now[2] = variable ? normal : 0.0;
    state_now[0] = w[0];
    state_now[1] = w[1];
    if (!tangents || !tangents->dforce_du_now) return;
    double* a = tangents->dforce_du_now;
    double* su = tangents->dstate_du_now;
    for (int k = 0; k < 9; ++k) {
      a[k] = 0;
      tangents->dforce_du_prev[k] = 0;
    }
    for (int k = 0; k < 6; ++k) {
      su[k] = 0;
      tangents->dstate_du_prev[k] = 0;
      tangents->dforce_dstate_prev[k] = 0;
    }
    double* fs = tangents->dforce_dstate_prev;  // 3 x 2
    double* ss = tangents->dstate_dstate_prev;  // 2 x 2
    ss[1] = ss[2] = 0;
    for (int i = 0; i < 2; ++i) {
      a[i * 3 + i] = dt_dut[i];
      a[i * 3 + 2] = dt_dun[i];
      fs[i * 2 + i] = dt_dw[i];
      su[i * 3 + i] = dw_dut[i];
      su[i * 3 + 2] = dw_dun[i];
      ss[i * 2 + i] = dw_dw[i];
    }
    a[2 * 3 + 2] = variable ? dnormal_dun : 0.0;
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
