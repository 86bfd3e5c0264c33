// Post-processing of harmonic solutions: the amplitude of a structure node.
//
// The amplitude of a node is the maximum over one period of the Euclidean norm of its
// displacement components (for a scalar DOF: max |x(t)|), taken in continuous time: the
// largest samples of a time grid of `samples` points (default: 8 times the AFT grid, at least
// 256) locate the maxima, and Newton's method on the time polishes each on the harmonic series
// itself, to rounding. The measure is then a smooth function of the harmonic amplitudes
// wherever the norm's largest maximum over the period is a single, strict one (everywhere but
// where two maxima of the period exchange, and at zero motion), which is what lets the peak of
// a response curve be solved for rather than searched (model/resonance_peak.hpp).
#pragma once

#include <Eigen/Dense>
#include <complex>
#include <vector>

#include "frichb/core/numerics/harmonics.hpp"

namespace frichb::core {

// Not thread-safe (its AFT buffers); one per thread.
class AmplitudeSampler {
 public:
  AmplitudeSampler(const std::vector<int>& harmonics, int samples);

  // `per_harmonic[k](i)`: complex amplitude (X = c - i s, the motion c cos + s sin) of
  // component i at kept harmonic k. Returns max over the period of |x(t)|_2 over the
  // `components`, m when the amplitudes are in m; 0 for no motion.
  double peak_amplitude(const std::vector<Eigen::VectorXcd>& per_harmonic,
                        const std::vector<Eigen::Index>& components);
  // The gradient of the last peak_amplitude in the amplitudes it was given: per kept harmonic k,
  // q_k over the `components` (in their order), with dA = sum_k Re(q_k^H dX_k). It is the
  // norm's derivative at the instant of the maximum (which does not move to first order): exact
  // where the measure is smooth (a single, strict maximum). Where maxima of the period tie (to
  // 1e-9, as the two of a motion symmetric over half a period do), the measure has a kink and
  // this is the mean of their gradients: the derivative central differences see. Zero for no
  // motion.
  std::vector<Eigen::VectorXcd> peak_gradient() const;
  // sqrt(sum_i |X_k,i|^2) for each kept harmonic k (|c0| for harmonic 0).
  static std::vector<double> harmonic_amplitudes(const std::vector<Eigen::VectorXcd>& per_harmonic,
                                                 const std::vector<Eigen::Index>& components);

 private:
  HarmonicLayout layout_;
  Aft aft_;
  Eigen::MatrixXd cos_, sin_;  // per component (column), per kept harmonic (row)
  Eigen::VectorXd squared_, samples_, coefficients_;
  double peak_ = 0.0;                // the last peak_amplitude
  std::vector<double> peak_phases_;  // omega t of its maximum (of each tied one)
};

}  // namespace frichb::core
