// A trivial contact law built against a plugin ABI this frichb does not have (99.x): the
// host must refuse to load it, naming the file and both versions.
#define FRICHB_ABI_MAJOR 99
#include "frichb/plugin/sdk.hpp"

namespace {

std::vector<frichb_param_spec> wrong_abi_schema() {
  using frichb::sdk::Param;
  return {Param::real("kt", "N/m", "tangential stiffness").greater_than(0)};
}

class WrongAbiLaw final : public frichb::sdk::ContactLaw {
 public:
  explicit WrongAbiLaw(const frichb::sdk::Params& p) : kt_(p.real("kt")) {}
  frichb_contact_law_traits traits() const override {
    return frichb::sdk::make_traits(1, false, 0, false);
  }
  void step(const double* /*state_prev*/, const double* /*u_prev*/, const double* u_now,
            double* force_now, double* /*state_now*/,
            const frichb_step_tangents* /*tangents*/) const override {
    force_now[0] = kt_ * u_now[0];
    force_now[1] = 0;
    force_now[2] = 0;
  }

 private:
  double kt_;
};

}  // namespace

static_assert(FRICHB_ABI_MAJOR == 99, "abi.h must honour a predefined FRICHB_ABI_MAJOR");

FRICHB_CONTACT_LAW_PLUGIN(WrongAbiLaw, wrong_abi_law, "0.0.1",
                          "test only: a linear spring built against plugin ABI 99",
                          wrong_abi_schema)
