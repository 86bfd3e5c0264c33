#include "frichb/core/numerics/harmonics.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <mutex>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>

namespace frichb::core {

namespace {
std::mutex& fftw_planner_mutex() {
  static std::mutex m;
  return m;
}
}  // namespace

const char* const kContactAxisNames[3] = {"t1", "t2", "n"};

double hurwitz_zeta(double s, double a) {
  constexpr int kTerms = 10;
  double sum = 0;
  for (int n = 0; n < kTerms; ++n) sum += n + a > 0 ? std::pow(n + a, -s) : 0.0;
  const double x = kTerms + a;
  sum += std::pow(x, 1 - s) / (s - 1) + 0.5 * std::pow(x, -s);
  // B_2k / (2k)! s (s + 1) ... (s + 2k - 2) x^(-s - 2k + 1), k = 1..6.
  constexpr double kBernoulli[] = {1.0 / 6,   -1.0 / 30, 1.0 / 42,
                                   -1.0 / 30, 5.0 / 66,  -691.0 / 2730};
  double factorial = 1, rising = 1;
  for (int k = 1; k <= 6; ++k) {
    factorial *= (2.0 * k - 1) * (2.0 * k);
    rising *= k == 1 ? s : (s + 2 * k - 3) * (s + 2 * k - 2);
    sum += kBernoulli[k - 1] / factorial * rising * std::pow(x, -s - 2 * k + 1);
  }
  return sum;
}

std::string sampling_violation(int samples, double max_harmonic) {
  const double needed = min_samples_per_period(max_harmonic);
  if (samples >= needed) return {};
  std::ostringstream bound;
  bound << std::setprecision(15) << needed;
  return "value " + std::to_string(samples) +
         " violates samples_per_period >= 2 * max_harmonic + 1 = " + bound.str() + " (aliasing)";
}

HarmonicLayout::HarmonicLayout(std::vector<int> harmonics, int samples_per_period)
    : harmonics_(std::move(harmonics)), samples_(samples_per_period) {
  if (harmonics_.empty()) throw std::invalid_argument("no harmonic is kept");
  std::sort(harmonics_.begin(), harmonics_.end());
  if (std::adjacent_find(harmonics_.begin(), harmonics_.end()) != harmonics_.end())
    throw std::invalid_argument("a harmonic is listed twice");
  if (harmonics_.front() < 0) throw std::invalid_argument("harmonic numbers must be >= 0");
  if (const auto why = sampling_violation(samples_, harmonics_.back()); !why.empty())
    throw std::invalid_argument(why);
  for (int n : harmonics_) {
    cos_index_.push_back(coefficient_count_++);
    coefficient_harmonic_.push_back(n);
    coefficient_is_sine_.push_back(false);
    if (n == 0) {
      sin_index_.push_back(-1);
    } else {
      sin_index_.push_back(coefficient_count_++);
      coefficient_harmonic_.push_back(n);
      coefficient_is_sine_.push_back(true);
    }
  }
}

double HarmonicLayout::basis(int sample, int coefficient) const {
  const int n = coefficient_harmonic_[static_cast<std::size_t>(coefficient)];
  if (n == 0) return 1.0;
  const double theta = 2.0 * std::numbers::pi * n * sample / samples_;
  return coefficient_is_sine_[static_cast<std::size_t>(coefficient)] ? std::sin(theta)
                                                                     : std::cos(theta);
}

Aft::Aft(const HarmonicLayout& layout) : layout_(layout) {
  const int n = layout_.samples();
  real_buffer_ = fftw_alloc_real(static_cast<std::size_t>(n));
  spectrum_ = fftw_alloc_complex(static_cast<std::size_t>(n) / 2 + 1);
  std::lock_guard<std::mutex> lock(fftw_planner_mutex());
  forward_ = fftw_plan_dft_r2c_1d(n, real_buffer_, spectrum_, FFTW_ESTIMATE);
  backward_ = fftw_plan_dft_c2r_1d(n, spectrum_, real_buffer_, FFTW_ESTIMATE);
  if (!forward_ || !backward_) {
    if (forward_) fftw_destroy_plan(forward_);
    if (backward_) fftw_destroy_plan(backward_);
    fftw_free(real_buffer_);
    fftw_free(spectrum_);
    throw std::runtime_error("FFTW could not make a plan");
  }
}

Aft::~Aft() {
  std::lock_guard<std::mutex> lock(fftw_planner_mutex());
  if (forward_) fftw_destroy_plan(forward_);
  if (backward_) fftw_destroy_plan(backward_);
  fftw_free(real_buffer_);
  fftw_free(spectrum_);
}

void Aft::to_time(const double* coefficients, double* samples) {
  const int n = layout_.samples();
  const int bins = n / 2 + 1;
  for (int b = 0; b < bins; ++b) spectrum_[b][0] = spectrum_[b][1] = 0.0;
  const auto& h = layout_.harmonics();
  // Re((c - i s) e^{i n theta}) = c cos + s sin; the c2r transform doubles bins 1..N/2-1.
  for (std::size_t k = 0; k < h.size(); ++k) {
    const double c = coefficients[layout_.cos_index(k)];
    if (h[k] == 0) {
      spectrum_[0][0] = c;
      continue;
    }
    const double s = coefficients[layout_.sin_index(k)];
    spectrum_[h[k]][0] = 0.5 * c;
    spectrum_[h[k]][1] = -0.5 * s;
  }
  fftw_execute(backward_);
  std::copy(real_buffer_, real_buffer_ + n, samples);
}

void Aft::to_coefficients(const double* samples, double* coefficients) {
  const int n = layout_.samples();
  std::copy(samples, samples + n, real_buffer_);
  fftw_execute(forward_);
  const auto& h = layout_.harmonics();
  const double inv_n = 1.0 / n;
  for (std::size_t k = 0; k < h.size(); ++k) {
    if (h[k] == 0) {
      coefficients[layout_.cos_index(k)] = spectrum_[0][0] * inv_n;
      continue;
    }
    coefficients[layout_.cos_index(k)] = 2.0 * spectrum_[h[k]][0] * inv_n;
    coefficients[layout_.sin_index(k)] = -2.0 * spectrum_[h[k]][1] * inv_n;
  }
}

ForceHarmonics force_harmonics(const Eigen::MatrixXd& force, std::span<const int> components,
                               int max_harmonic) {
  const int samples = static_cast<int>(force.rows());
  if (max_harmonic < 1 || !sampling_violation(samples, max_harmonic).empty() ||
      static_cast<std::size_t>(force.cols()) != components.size())
    throw std::invalid_argument("force_harmonics: " + std::to_string(samples) +
                                " samples cannot resolve harmonic " + std::to_string(max_harmonic) +
                                " of " + std::to_string(force.cols()) + " columns");
  std::vector<int> harmonics;
  for (int h = 0; h <= max_harmonic; ++h) harmonics.push_back(h);
  const HarmonicLayout layout(harmonics, samples);
  Aft aft(layout);
  ForceHarmonics out;
  out.header = {"harmonic"};
  for (int k : components)
    for (const char* part : {"cos", "sin", "amplitude"})
      out.header.push_back(std::string("f_") + kContactAxisNames[k] + "_" + part + "_N");
  out.rows.resize(static_cast<std::size_t>(max_harmonic) + 1);
  Eigen::VectorXd coefficients(layout.coefficient_count()), column(samples);
  for (Eigen::Index a = 0; a < force.cols(); ++a) {
    column = force.col(a);
    aft.to_coefficients(column.data(), coefficients.data());
    std::vector<double> amplitude(static_cast<std::size_t>(max_harmonic + 1));
    for (int h = 0; h <= max_harmonic; ++h) {
      const auto k = static_cast<std::size_t>(h);
      const double cc = coefficients(layout.cos_index(k));
      const double ss = h ? coefficients(layout.sin_index(k)) : 0.0;
      amplitude[k] = std::hypot(cc, ss);
      if (out.rows[k].empty()) out.rows[k].push_back(h);
      out.rows[k].insert(out.rows[k].end(), {cc, ss, amplitude[k]});
    }
    out.amplitude.push_back(std::move(amplitude));
  }
  return out;
}

}  // namespace frichb::core
