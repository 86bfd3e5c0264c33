// The normal-load model shared by the built-in friction laws (jenkins_1d, uncoupled_2d,
// coupled_3d): a constant normal load, or one that follows the normal relative displacement
// with separation,
//
//   N = N0                                   (kn = 0)
//   N = max(0, N0 + kn (u_n - g0))           (kn > 0; u_n > 0 closes the contact)
//
// with its schema entries (normal_load, kn, gap) so that every law spells them alike.
// Header-only, compiled into each plugin; nothing of it crosses the plugin boundary.
#pragma once

#include <algorithm>
#include <stdexcept>
#include <vector>

#include "frichb/plugin/sdk.hpp"

namespace frichb::contact_laws {

// Appends the parameters normal_load (N0, N), kn (N/m) and gap (g0, m) to `schema`.
inline std::vector<frichb_param_spec> with_normal_load(std::vector<frichb_param_spec> schema) {
  using sdk::Param;
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
  // Reads normal_load, kn and gap; refuses a gap without kn, and a gap with a preload.
  explicit NormalLoad(const sdk::Params& p)
      : n0_(p.real("normal_load")), kn_(p.real("kn")), gap_(p.real("gap")) {
    if (gap_ > 0 && kn_ <= 0) throw std::invalid_argument("gap > 0 needs kn > 0");
    if (gap_ > 0 && n0_ > 0)
      throw std::invalid_argument("give either normal_load (preload) or gap, not both");
  }

  // True when N follows u_n (the law then uses the normal direction).
  bool variable() const { return kn_ > 0; }

  struct State {
    double normal;       // N >= 0
    double dnormal_dun;  // dN/du_n (0 when constant or open)
    bool open;           // separated: N = 0 with a variable load
  };
  State at(double normal_displacement) const {
    if (!variable()) return {n0_, 0.0, false};
    const double trial = n0_ + kn_ * (normal_displacement - gap_);
    if (trial <= 0) return {0.0, 0.0, true};
    return {trial, kn_, false};
  }

 private:
  double n0_, kn_, gap_;
};

}  // namespace frichb::contact_laws
