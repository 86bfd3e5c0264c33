// FricHB plugin SDK: the normal-load model of a friction law. A constant normal load, or one
// that follows the normal relative displacement with separation:
//
//   N = N0                                   (kn = 0)
//   N = max(0, N0 + kn (u_n - g0))           (kn > 0; u_n > 0 closes the contact)
//
// with its schema entries (normal_load, kn, gap) so that every law spells them alike. The
// built-in jenkins_1d, uncoupled_2d and coupled_3d use it; a third-party law that offers the
// same parameters gets the same validation, defaults and documentation.
//
//   std::vector<frichb_param_spec> my_schema() {
//     return frichb::sdk::with_normal_load({Param::real("kt", "N/m", "...").greater_than(0)});
//   }
//   explicit MyLaw(const frichb::sdk::Params& p) : kt_(p.real("kt")), normal_(p) {}
//   traits(): make_traits(1, normal_.variable(), 1, true)   (the normal matters iff kn > 0)
//   step():   const auto [normal, dnormal_dun, open] = normal_.at(u_now[2]);
//
// Contract:
//  - Units: N0 in N, kn in N/m, g0 and u_n in m; dN/du_n in N/m.
//  - NormalLoad is an immutable value (three doubles); at() is const, allocation-free and
//    safe to call from several threads, as ContactLaw::step requires.
//  - Failure: the constructor throws std::invalid_argument for a gap without kn and for a
//    gap together with a preload (the SDK's trampolines report it as the create() error);
//    it throws std::invalid_argument too when the schema lacks one of the three parameters.
//    at() never throws.
//
// Header-only and C++17, on top of sdk.hpp; nothing of it crosses the plugin boundary.
#pragma once

#include <stdexcept>
#include <vector>

#include "frichb/plugin/sdk.hpp"

namespace frichb::sdk {

// Appends the parameters normal_load (N0, N), kn (N/m) and gap (g0, m) to `schema`, all
// optional with default 0 and bounded below by 0.
inline std::vector<frichb_param_spec> with_normal_load(std::vector<frichb_param_spec> schema) {
  schema.push_back(
      Param::real("normal_load", "N", "normal load N0 at zero normal displacement (preload)")
          .defaults_to(0.0)
          .at_least(0));
  schema.push_back(Param::real("kn", "N/m",
                               "normal contact stiffness; 0 keeps the normal load constant, > 0 "
                               "makes it follow the normal relative displacement with separation")
                       .defaults_to(0.0)
                       .at_least(0));
  schema.push_back(
      Param::real("gap", "m", "initial normal gap g0 (needs kn > 0 and normal_load = 0)")
          .defaults_to(0.0)
          .at_least(0));
  return schema;
}

class NormalLoad {
 public:
  // Reads normal_load, kn and gap (as with_normal_load declares them); refuses a gap without
  // kn, and a gap with a preload.
  explicit NormalLoad(const Params& p)
      : n0_(p.real("normal_load")), kn_(p.real("kn")), gap_(p.real("gap")) {
    if (gap_ > 0 && kn_ <= 0) throw std::invalid_argument("gap > 0 needs kn > 0");
    if (gap_ > 0 && n0_ > 0)
      throw std::invalid_argument("give either normal_load (preload) or gap, not both");
  }

  // True when N follows u_n (the law then uses the normal direction).
  bool variable() const { return kn_ > 0; }

  struct State {
    double normal;       // N >= 0, in N
    double dnormal_dun;  // dN/du_n in N/m (0 when constant or open)
    bool open;           // separated: N = 0 with a variable load
  };
  // The normal load at the normal relative displacement u_n (m).
  State at(double normal_displacement) const {
    if (!variable()) return {n0_, 0.0, false};
    const double trial = n0_ + kn_ * (normal_displacement - gap_);
    if (trial <= 0) return {0.0, 0.0, true};
    return {trial, kn_, false};
  }

 private:
  double n0_, kn_, gap_;
};

}  // namespace frichb::sdk
