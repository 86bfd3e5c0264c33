// `frichb timesim`: the time-integration reference of a scene without cyclic symmetry, at one
// excitation frequency, with the same contact-law plugins stepping the contacts.
//
// The structure is integrated in its modal coordinates q (x = Phi q at the kept DOFs, all the
// provider's modes; no residual flexibility), q'' + C q' + diag(w^2) q = Phi^T (f_ext - G^T f),
// by velocity Verlet with the contact forces of each new position, from rest, until the
// response repeats from one period to the next (relative 1e-8, three periods in a row) or
// `max_periods`. Use it to check a harmonic-balance result; it is far slower.
#pragma once

#include <filesystem>

namespace frichb::core {

struct TimesimRequest {
  std::filesystem::path scene_file;
  std::filesystem::path output_directory;  // empty: out/<scene stem>-timesim
  double frequency_hz = 0.0;
  int steps_per_period = 4000;
  int max_periods = 3000;
};

// Writes timesim.csv (the last period: time and each response node's DOFs) and summary.json
// (per response node: maximum over the period of the displacement norm, half peak-to-peak,
// harmonic amplitudes; periods run; whether the response became periodic). Returns an
// ExitCode (run.hpp): kExitIncomplete when max_periods passed without a periodic response.
int run_timesim(const TimesimRequest& request);

}  // namespace frichb::core
