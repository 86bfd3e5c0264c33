// Test only: Jenkins elements with one deliberate fault each, selected at compile time, to
// prove that the conformance kit names the check a faulty law fails.
//   FAULT_TANGENT_SIGN: the stick tangent dT/du has the wrong sign.
//   FAULT_BEYOND_COULOMB: the slip force is 1.5 mu N.
#include <cmath>

#include "frichb/plugin/sdk.hpp"

namespace {

std::vector<frichb_param_spec> faulty_schema() {
  using frichb::sdk::Param;
  return {Param::real("kt", "N/m", "tangential stiffness").greater_than(0),
          Param::real("mu", "", "friction coefficient").at_least(0),
          Param::real("normal_load", "N", "constant normal load").defaults_to(1.0).at_least(0)};
}

class FaultyJenkins final : public frichb::sdk::ContactLaw {
 public:
  explicit FaultyJenkins(const frichb::sdk::Params& p)
      : kt_(p.real("kt")), slip_(p.real("mu") * p.real("normal_load")) {}
  frichb_contact_law_traits traits() const override {
    return frichb::sdk::make_traits(1, false, 1, true);
  }
  void step(const double* state_prev, const double* /*u_prev*/, const double* u_now,
            double* force_now, double* state_now,
            const frichb_step_tangents* tangents) const override {
#ifdef FAULT_BEYOND_COULOMB
    const double limit = 1.5 * slip_;
#else
    const double limit = slip_;
#endif
    const double trial = kt_ * (u_now[0] - state_prev[0]);
    const bool stick = std::abs(trial) <= limit;
    const double t = stick ? trial : std::copysign(limit, trial);
    force_now[0] = t;
    force_now[1] = force_now[2] = 0;
    state_now[0] = u_now[0] - t / kt_;
    if (!tangents) return;
#ifdef FAULT_TANGENT_SIGN
    tangents->dforce_du_now[0] = stick ? -kt_ : 0.0;
#else
    tangents->dforce_du_now[0] = stick ? kt_ : 0.0;
#endif
    tangents->dforce_dstate_prev[0] = stick ? -kt_ : 0.0;
    tangents->dstate_du_now[0] = stick ? 0.0 : 1.0;
    tangents->dstate_dstate_prev[0] = stick ? 1.0 : 0.0;
  }

 private:
  double kt_, slip_;
};

}  // namespace

#ifdef FAULT_TANGENT_SIGN
FRICHB_CONTACT_LAW_PLUGIN(FaultyJenkins, faulty_tangent_sign, "1.0.0",
                          "test only: Jenkins with a sign error in its tangent", faulty_schema)
#else
FRICHB_CONTACT_LAW_PLUGIN(FaultyJenkins, faulty_beyond_coulomb, "1.0.0",
                          "test only: Jenkins whose slip force exceeds mu N", faulty_schema)
#endif
