// Post-processing of harmonic solutions: amplitudes of structure nodes.
//
// The amplitude of a node is the maximum over one period of the Euclidean norm of its
// displacement components (for a scalar DOF: max |x(t)|), evaluated on a time grid of
// `samples` points (default: 8 times the AFT grid, at least 256).
#pragma once

#include <Eigen/Dense>
#include <complex>
#include <vector>

#include "frichb/core/numerics/harmonics.hpp"

namespace frichb::core {

class AmplitudeSampler {
 public:
  AmplitudeSampler(const std::vector<int>& harmonics, int samples);

  // `per_harmonic[k](i)`: complex amplitude (X = c - i s) of component i at kept harmonic k.
  double peak_amplitude(const std::vector<Eigen::VectorXcd>& per_harmonic,
                        const std::vector<Eigen::Index>& components);
  // sqrt(sum_i |X_k,i|^2) for each kept harmonic k (|c0| for harmonic 0).
  static std::vector<double> harmonic_amplitudes(const std::vector<Eigen::VectorXcd>& per_harmonic,
                                                 const std::vector<Eigen::Index>& components);

 private:
  HarmonicLayout layout_;
  Aft aft_;
};

}  // namespace frichb::core
