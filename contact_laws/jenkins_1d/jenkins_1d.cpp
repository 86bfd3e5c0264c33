// jenkins_1d: elastic Coulomb slider (Jenkins element) in one tangential direction, with a
// constant normal load or a normal load that follows the normal relative displacement.
//
//   N = max(0, N0 + kn (u_n - g0))            (kn = 0: N = N0, constant)
//   trial T* = kt (u_t - w_prev)
//   stick  |T*| <= mu N : T = T*,              w = w_prev
//   slip   |T*| >  mu N : T = mu N sign(T*),   w = u_t - T / kt
//   separated N = 0     : T = 0,               w = u_t   (the slider is released)
// State: w, the slider (stick-point) position in m.
#include <cmath>
#include <stdexcept>

#include "frichb/plugin/normal_load.hpp"
#include "frichb/plugin/sdk.hpp"
#include "frichb/plugin/tangents.hpp"

namespace {

using frichb::sdk::Param;

std::vector<frichb_param_spec> jenkins_schema() {
  return frichb::sdk::with_normal_load({
      Param::real("kt", "N/m", "tangential contact stiffness").greater_than(0),
      Param::real("mu", "", "friction coefficient").at_least(0),
  });
}

class Jenkins1d final : public frichb::sdk::ContactLaw {
 public:
  explicit Jenkins1d(const frichb::sdk::Params& p)
      : kt_(p.real("kt")), mu_(p.real("mu")), normal_(p) {}

  frichb_contact_law_traits traits() const override {
    return frichb::sdk::make_traits(1, normal_.variable(), 1, true);
  }

  void step(const double* state_prev, const double* /*u_prev*/, const double* u_now,
            double* force_now, double* state_now,
            const frichb_step_tangents* tangents) const override {
    const double ut = u_now[0];
    const double w_prev = state_prev[0];
    const bool variable = normal_.variable();
    const auto [normal, dnormal_dun, open] = normal_.at(u_now[2]);
    const double limit = mu_ * normal;
    const double trial = kt_ * (ut - w_prev);

    double t = 0, w = 0;
    // Partial derivatives of T and w with respect to (u_t, u_n, w_prev).
    double dt_dut = 0, dt_dun = 0, dt_dw = 0, dw_dut = 0, dw_dun = 0, dw_dw = 0;
    if (open) {
      // Separated: no force, and the slider follows so that contact resumes unloaded.
      t = 0;
      w = ut;
      dw_dut = 1;
    } else if (std::abs(trial) <= limit) {
      t = trial;
      w = w_prev;
      dt_dut = kt_;
      dt_dw = -kt_;
      dw_dw = 1;
    } else {
      const double sign = trial > 0 ? 1.0 : -1.0;
      t = sign * limit;
      w = ut - t / kt_;
      dt_dun = sign * mu_ * dnormal_dun;
      dw_dut = 1;
      dw_dun = -dt_dun / kt_;
    }
    force_now[0] = t;
    force_now[1] = 0;
    force_now[2] = variable ? normal : 0.0;
    state_now[0] = w;
    const frichb::sdk::StepTangents tangent(tangents, 1);
    if (!tangent.wanted()) return;
    tangent.zero();
    auto fu = tangent.dforce_du_now();
    fu(0, 0) = dt_dut;
    fu(0, 2) = dt_dun;
    fu(2, 2) = variable ? dnormal_dun : 0.0;
    tangent.dforce_dstate_prev()(0, 0) = dt_dw;
    auto su = tangent.dstate_du_now();
    su(0, 0) = dw_dut;
    su(0, 2) = dw_dun;
    tangent.dstate_dstate_prev()(0, 0) = dw_dw;
  }

 private:
  double kt_, mu_;
  frichb::sdk::NormalLoad normal_;
};

}  // namespace

FRICHB_CONTACT_LAW_PLUGIN(Jenkins1d, jenkins_1d, "1.0.0",
                          "elastic Coulomb slider in one tangential direction, constant or "
                          "displacement-dependent normal load with separation",
                          jenkins_schema)
