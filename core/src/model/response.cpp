#include "frichb/core/model/response.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>
#include <vector>

namespace frichb::core {

namespace {

// Local maxima of the sampled squared norm within this share of the largest sample are polished
// (a lower one cannot overtake the largest by more than the grid's error, far below it).
constexpr double kCandidateBand = 1e-2;
constexpr int kMaxPolishIterations = 30;
// Maxima whose norms agree to this share are tied (their gradients are averaged), and two
// polished maxima this close in phase (rad) are the same one.
constexpr double kTiedMaxima = 1e-9;
constexpr double kSamePhase = 1e-6;

}  // namespace

AmplitudeSampler::AmplitudeSampler(const std::vector<int>& harmonics, int samples)
    : layout_(harmonics, samples), aft_(layout_) {}

double AmplitudeSampler::peak_amplitude(const std::vector<Eigen::VectorXcd>& per_harmonic,
                                        const std::vector<Eigen::Index>& components) {
  const int n = layout_.samples();
  const auto& h = layout_.harmonics();
  const auto kept = static_cast<Eigen::Index>(h.size());
  const auto d = static_cast<Eigen::Index>(components.size());
  squared_.setZero(n);
  samples_.resize(n);
  coefficients_.setZero(layout_.coefficient_count());
  cos_.resize(kept, d);
  sin_.resize(kept, d);
  for (Eigen::Index a = 0; a < d; ++a) {
    for (Eigen::Index k = 0; k < kept; ++k) {
      const std::complex<double> x = per_harmonic[static_cast<std::size_t>(k)](components[a]);
      cos_(k, a) = x.real();
      sin_(k, a) = -x.imag();
      coefficients_(layout_.cos_index(static_cast<std::size_t>(k))) = cos_(k, a);
      if (h[static_cast<std::size_t>(k)] > 0)
        coefficients_(layout_.sin_index(static_cast<std::size_t>(k))) = sin_(k, a);
    }
    aft_.to_time(coefficients_.data(), samples_.data());
    squared_ += samples_.cwiseAbs2();
  }
  const double top = squared_.maxCoeff();
  peak_ = 0.0;
  if (!(top > 0)) return 0.0;

  // |x|^2 and its first two derivatives in the phase tau = omega t, from the series.
  Eigen::VectorXd cn(kept), sn(kept);
  const auto evaluate = [&](double tau, double* value, double* slope, double* curvature) {
    for (Eigen::Index k = 0; k < kept; ++k) {
      const double nk = h[static_cast<std::size_t>(k)];
      cn(k) = std::cos(nk * tau);
      sn(k) = std::sin(nk * tau);
    }
    *value = *slope = *curvature = 0.0;
    for (Eigen::Index a = 0; a < d; ++a) {
      double x = 0, x1 = 0, x2 = 0;
      for (Eigen::Index k = 0; k < kept; ++k) {
        const double nk = h[static_cast<std::size_t>(k)];
        const double c = cos_(k, a), s = sin_(k, a);
        x += c * cn(k) + s * sn(k);
        x1 += nk * (s * cn(k) - c * sn(k));
        x2 -= nk * nk * (c * cn(k) + s * sn(k));
      }
      *value += x * x;
      *slope += 2 * x * x1;
      *curvature += 2 * (x1 * x1 + x * x2);
    }
  };
  const double spacing = 2 * std::numbers::pi / n;
  double best = top;
  // Each candidate's polished maximum: (|x|^2, phase). The largest sample is always a candidate.
  std::vector<std::pair<double, double>> maxima;
  for (int j = 0; j < n; ++j) {
    const double here = squared_(j);
    if (here < (1 - kCandidateBand) * top || here < squared_((j + n - 1) % n) ||
        here < squared_((j + 1) % n))
      continue;
    // Newton on d|x|^2/dtau = 0 from the sample, kept within one spacing of it (the maximum
    // it belongs to lies there) and stopped where the curvature says it is no maximum.
    const double tau0 = spacing * j;
    double tau = tau0, value = 0, slope = 0, curvature = 0;
    std::pair<double, double> found{here, tau0};
    for (int it = 0; it < kMaxPolishIterations; ++it) {
      evaluate(tau, &value, &slope, &curvature);
      if (value > found.first) found = {value, tau};
      if (!(curvature < 0)) break;
      const double step = -slope / curvature;
      if (std::abs(tau + step - tau0) > spacing || std::abs(step) <= 1e-15 * (1 + std::abs(tau)))
        break;
      tau += step;
    }
    best = std::max(best, found.first);
    maxima.push_back(found);
  }
  // The maxima tied with the largest (the two of a motion symmetric over half a period), once
  // each.
  peak_phases_.clear();
  for (const auto& maximum : maxima) {
    const double phase = maximum.second;
    if (maximum.first < (1 - 2 * kTiedMaxima) * best) continue;
    const bool seen = std::any_of(peak_phases_.begin(), peak_phases_.end(), [&](double other) {
      const double apart = std::remainder(phase - other, 2 * std::numbers::pi);
      return std::abs(apart) < kSamePhase;
    });
    if (!seen) peak_phases_.push_back(phase);
  }
  peak_ = std::sqrt(best);
  return peak_;
}

std::vector<Eigen::VectorXcd> AmplitudeSampler::peak_gradient() const {
  const auto& h = layout_.harmonics();
  const auto kept = static_cast<Eigen::Index>(h.size());
  const Eigen::Index d = cos_.cols();
  std::vector<Eigen::VectorXcd> out(h.size(), Eigen::VectorXcd::Zero(d));
  if (!(peak_ > 0) || peak_phases_.empty()) return out;
  // A = |x(tau*)|, x_a = sum_k c_ka cos(n_k tau) + s_ka sin(n_k tau), X = c - i s:
  // dA/dc = x_a cos / A, dA/ds = x_a sin / A, and q = dA/dc - i dA/ds. Tied maxima: the mean
  // of their gradients, which is what central differences of the measure see.
  const double share = 1.0 / (peak_ * static_cast<double>(peak_phases_.size()));
  for (const double phase : peak_phases_) {
    for (Eigen::Index a = 0; a < d; ++a) {
      double x = 0;
      for (Eigen::Index k = 0; k < kept; ++k) {
        const double angle = h[static_cast<std::size_t>(k)] * phase;
        x += cos_(k, a) * std::cos(angle) + sin_(k, a) * std::sin(angle);
      }
      for (Eigen::Index k = 0; k < kept; ++k) {
        const double angle = h[static_cast<std::size_t>(k)] * phase;
        out[static_cast<std::size_t>(k)](a) +=
            std::complex<double>(x * std::cos(angle) * share, -x * std::sin(angle) * share);
      }
    }
  }
  return out;
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
