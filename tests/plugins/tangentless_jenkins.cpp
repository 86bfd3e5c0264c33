// Test only: the Jenkins element with constant normal load but WITHOUT tangents
// (provides_tangent = 0), to check the core's finite-difference fallback through the loader.
#include <cmath>

#include "frichb/plugin/sdk.hpp"

namespace {

std::vector<frichb_param_spec> tangentless_schema() {
  using frichb::sdk::Param;
  return {Param::real("kt", "N/m", "tangential stiffness").greater_than(0),
          Param::real("slip_force", "N", "mu N").at_least(0)};
}

class TangentlessJenkins final : public frichb::sdk::ContactLaw {
 public:
  explicit TangentlessJenkins(const frichb::sdk::Params& p)
      : kt_(p.real("kt")), slip_(p.real("slip_force")) {}
  frichb_contact_law_traits traits() const override {
    return frichb::sdk::make_traits(1, false, 1, false);
  }
  void step(const double* state_prev, const double* /*u_prev*/, const double* u_now,
            double* force_now, double* state_now,
            const frichb_step_tangents* /*tangents*/) const override {
    const double trial = kt_ * (u_now[0] - state_prev[0]);
    const double t = std::abs(trial) <= slip_ ? trial : std::copysign(slip_, trial);
    force_now[0] = t;
    force_now[1] = force_now[2] = 0;
    state_now[0] = u_now[0] - t / kt_;
  }

 private:
  double kt_, slip_;
};

}  // namespace

FRICHB_CONTACT_LAW_PLUGIN(TangentlessJenkins, tangentless_jenkins, "1.0.0",
                          "test only: Jenkins element without tangents", tangentless_schema)
