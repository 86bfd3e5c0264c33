// A trivial, valid contact law (a linear tangential spring). The tests build it twice into
// two folders so that a search path holding both has two files declaring `duplicate_law`.
#include "frichb/plugin/sdk.hpp"

namespace {

std::vector<frichb_param_spec> duplicate_schema() {
  using frichb::sdk::Param;
  return {Param::real("kt", "N/m", "tangential stiffness").greater_than(0)};
}

class DuplicateLaw final : public frichb::sdk::ContactLaw {
 public:
  explicit DuplicateLaw(const frichb::sdk::Params& p) : kt_(p.real("kt")) {}
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

FRICHB_CONTACT_LAW_PLUGIN(DuplicateLaw, duplicate_law, "1.0.0",
                          "test only: a linear tangential spring", duplicate_schema)
