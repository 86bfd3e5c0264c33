// regularized_coulomb: an example third-party contact law. A slider whose elastic stretch
// e = u - w saturates smoothly at mu N / kt instead of switching from stick to slip
// (a Bouc-Wen-type law of exponent 1), integrated exactly over each step:
//
//   s = sign(u_now - u_prev),  E = exp(-kt |u_now - u_prev| / (mu N))
//   e_now = s mu N / kt + (e_prev - s mu N / kt) E,  with e_prev = u_prev - w_prev
//   T = kt e_now,  w_now = u_now - e_now
//
// It depends on u_prev, so it fills the u_prev tangents too. State: w (m).
#include <cmath>
#include <stdexcept>

#include "frichb/plugin/sdk.hpp"
#include "frichb/plugin/tangents.hpp"

namespace {

std::vector<frichb_param_spec> schema() {
  using frichb::sdk::Param;
  return {Param::real("kt", "N/m", "initial tangential stiffness").greater_than(0),
          Param::real("mu", "", "friction coefficient").greater_than(0),
          Param::real("normal_load", "N", "constant normal load").greater_than(0)};
}

class RegularizedCoulomb final : public frichb::sdk::ContactLaw {
 public:
  explicit RegularizedCoulomb(const frichb::sdk::Params& p)
      : kt_(p.real("kt")), slip_(p.real("mu") * p.real("normal_load")) {}

  frichb_contact_law_traits traits() const override {
    return frichb::sdk::make_traits(1, false, 1, true);
  }

  void step(const double* state_prev, const double* u_prev, const double* u_now, double* force_now,
            double* state_now, const frichb_step_tangents* tangents) const override {
    const double delta = u_now[0] - u_prev[0];
    const double s = delta > 0 ? 1.0 : (delta < 0 ? -1.0 : 0.0);
    const double e_prev = u_prev[0] - state_prev[0];
    const double limit = s * slip_ / kt_;
    const double decay = std::exp(-kt_ * std::abs(delta) / slip_);
    // limit * (1 - decay) with expm1: for a large mu N the plain form cancels catastrophically
    // (limit is huge and 1 - decay tiny), which the conformance kit's full-stick check shows.
    const double e_now = e_prev * decay - limit * std::expm1(-kt_ * std::abs(delta) / slip_);
    force_now[0] = kt_ * e_now;
    force_now[1] = force_now[2] = 0.0;
    state_now[0] = u_now[0] - e_now;
    const frichb::sdk::StepTangents tangent(tangents, 1);
    if (!tangent.wanted()) return;  // value only
    // de/d(delta) = E (1 - s kt e_prev / (mu N)),  de/de_prev = E.
    const double de_ddelta = decay * (1.0 - s * kt_ * e_prev / slip_);
    const double de_dunow = de_ddelta, de_duprev = decay - de_ddelta, de_dw = -decay;
    tangent.zero();  // then only the t1 entries (row and column 0) are not zero
    tangent.dforce_du_now()(0, 0) = kt_ * de_dunow;
    tangent.dforce_du_prev()(0, 0) = kt_ * de_duprev;
    tangent.dforce_dstate_prev()(0, 0) = kt_ * de_dw;
    tangent.dstate_du_now()(0, 0) = 1.0 - de_dunow;
    tangent.dstate_du_prev()(0, 0) = -de_duprev;
    tangent.dstate_dstate_prev()(0, 0) = -de_dw;
  }

 private:
  double kt_, slip_;
};

}  // namespace

FRICHB_CONTACT_LAW_PLUGIN(RegularizedCoulomb, regularized_coulomb, "1.0.0",
                          "example third-party law: slider with a smooth (Bouc-Wen) stick-slip "
                          "transition",
                          schema)
