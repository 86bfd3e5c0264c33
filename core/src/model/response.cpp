#include "frichb/core/model/response.hpp"

#include <cmath>

namespace frichb::core {

AmplitudeSampler::AmplitudeSampler(const std::vector<int>& harmonics, int samples)
    : layout_(harmonics, samples), aft_(layout_) {}

double AmplitudeSampler::peak_amplitude(const std::vector<Eigen::VectorXcd>& per_harmonic,
                                        const std::vector<Eigen::Index>& components) {
  const int n = layout_.samples();
  Eigen::VectorXd squared = Eigen::VectorXd::Zero(n), samples(n);
  Eigen::VectorXd coefficients(layout_.coefficient_count());
  const auto& h = layout_.harmonics();
  for (Eigen::Index comp : components) {
    for (std::size_t k = 0; k < h.size(); ++k) {
      const std::complex<double> x = per_harmonic[k](comp);
      coefficients(layout_.cos_index(k)) = x.real();
      if (h[k] > 0) coefficients(layout_.sin_index(k)) = -x.imag();
    }
    aft_.to_time(coefficients.data(), samples.data());
    squared += samples.cwiseAbs2();
  }
  return std::sqrt(squared.maxCoeff());
}

std::vector<double> AmplitudeSampler::harmonic_amplitudes(
    const std::vector<Eigen::VectorXcd>& per_harmonic,
    const std::vector<Eigen::Index>& components) {
  std::vector<double> out;
  for (const auto& x : per_harmonic) {
    double sum = 0;
    for (Eigen::Index comp : components) sum += std::norm(x(comp));
    out.push_back(std::sqrt(sum));
  }
  return out;
}

}  // namespace frichb::core
