// Test only: a smooth hardening spring f = k u + k3 u^3 along t1, without state (a Duffing
// element). The stability oracles need a contact whose harmonic-balance solution converges
// quickly in the number of harmonics, which a stick-slip law does not.
#include "frichb/plugin/sdk.hpp"

namespace {

std::vector<frichb_param_spec> hardening_schema() {
  using frichb::sdk::Param;
  return {Param::real("k", "N/m", "linear stiffness").at_least(0),
          Param::real("k3", "N/m^3", "cubic stiffness").at_least(0)};
}

class HardeningSpring final : public frichb::sdk::ContactLaw {
 public:
  explicit HardeningSpring(const frichb::sdk::Params& p) : k_(p.real("k")), k3_(p.real("k3")) {}
  frichb_contact_law_traits traits() const override {
    return frichb::sdk::make_traits(1, false, 0, true);
  }
  void step(const double* /*state_prev*/, const double* /*u_prev*/, const double* u_now,
            double* force_now, double* /*state_now*/,
            const frichb_step_tangents* tangents) const override {
    const double u = u_now[0];
    force_now[0] = (k_ + k3_ * u * u) * u;
    force_now[1] = force_now[2] = 0;
    if (tangents) tangents->dforce_du_now[0] = k_ + 3 * k3_ * u * u;
  }

 private:
  double k_, k3_;
};

}  // namespace

FRICHB_CONTACT_LAW_PLUGIN(HardeningSpring, hardening_spring, "1.0.0",
                          "test only: a smooth hardening spring k u + k3 u^3", hardening_schema)
