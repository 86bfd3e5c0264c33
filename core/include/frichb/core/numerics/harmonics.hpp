// Harmonic layout and the alternating frequency-time (AFT) transforms.
//
// Convention (docs/theory.md): a periodic scalar q(t) of fundamental w is
//   q(t) = c0 + sum_{n in kept, n>=1} (c_n cos(n w t) + s_n sin(n w t)),
// stored as the real coefficient vector [c0, c_n1, s_n1, c_n2, s_n2, ...] over the kept
// harmonics in ascending order (c0 only when harmonic 0 is kept). Time samples are taken at
// theta_j = 2 pi j / N, j = 0..N-1, over one period.
#pragma once

#include <fftw3.h>

#include <Eigen/Dense>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace frichb::core {

// The sampling rule of the AFT (Nyquist): N samples per period resolve the harmonics up to H
// when N >= 2 H + 1. In double: a scene's max_harmonic is checked before it is known to fit
// an int.
constexpr double min_samples_per_period(double max_harmonic) {
  return 2 * max_harmonic + 1;
}
// "" when `samples` resolves `max_harmonic`; else why not, as "value N violates
// samples_per_period >= 2 * max_harmonic + 1 = B (aliasing)".
std::string sampling_violation(int samples, double max_harmonic);

// The Hurwitz zeta function zeta(s, a) = sum_{n >= 0} (n + a)^(-s), continued analytically to
// s <= 0, for a in [0, 1] (zeta(s, 0) = zeta(s, 1) there): the Euler-Maclaurin sum with ten
// terms and six Bernoulli corrections, about 1e-14 absolute. For a force that starts like
// |t - t*|^p from t*, the trapezoidal sum less the integral is h^(p+1) zeta(-p, a) (a the
// distance from t* to the first sample on the force's side, in samples); p = 1, a kink,
// gives zeta(-1, a) = -B2(a) / 2.
double hurwitz_zeta(double s, double a);

class HarmonicLayout {
 public:
  // `harmonics`: distinct non-negative temporal harmonic numbers (any order; kept sorted).
  // `samples_per_period` N must satisfy N >= 2 * max_harmonic + 1 (Nyquist); throws
  // std::invalid_argument otherwise, saying which rule failed.
  HarmonicLayout(std::vector<int> harmonics, int samples_per_period);

  const std::vector<int>& harmonics() const { return harmonics_; }
  int samples() const { return samples_; }
  int max_harmonic() const { return harmonics_.back(); }
  bool has_static() const { return harmonics_.front() == 0; }
  // Number of real coefficients per scalar signal.
  int coefficient_count() const { return coefficient_count_; }
  // Index of the cosine (sine) coefficient of the k-th kept harmonic; sine is -1 for n = 0.
  int cos_index(std::size_t k) const { return cos_index_[k]; }
  int sin_index(std::size_t k) const { return sin_index_[k]; }
  // Value of coefficient c's basis function at sample j (cos(n theta_j), sin(...), or 1).
  double basis(int sample, int coefficient) const;

 private:
  std::vector<int> harmonics_;
  int samples_;
  int coefficient_count_ = 0;
  std::vector<int> cos_index_, sin_index_;
  std::vector<int> coefficient_harmonic_;
  std::vector<bool> coefficient_is_sine_;
};

// FFTW-based transforms between coefficient vectors and time samples of one layout.
// Plans are made once at construction (FFTW_ESTIMATE, under a process-wide lock because the
// FFTW planner is not thread-safe). An Aft owns work buffers: use one per thread.
class Aft {
 public:
  explicit Aft(const HarmonicLayout& layout);
  ~Aft();
  Aft(const Aft&) = delete;
  Aft& operator=(const Aft&) = delete;

  const HarmonicLayout& layout() const { return layout_; }
  // coefficients[coefficient_count] -> samples[N]
  void to_time(const double* coefficients, double* samples);
  // samples[N] -> coefficients[coefficient_count] (Galerkin projection on the kept harmonics;
  // harmonics not kept are dropped).
  void to_coefficients(const double* samples, double* coefficients);

 private:
  HarmonicLayout layout_;
  double* real_buffer_ = nullptr;
  fftw_complex* spectrum_ = nullptr;
  fftw_plan forward_ = nullptr;
  fftw_plan backward_ = nullptr;
};

// Harmonics 0..max_harmonic of a contact force sampled over one period (`force`: samples x
// components, N, equally spaced in phase; `components`: each column's local axis, 0 = t1,
// 1 = t2, 2 = n). `rows[n]` = {n, then per component: cos, sin, amplitude} (f = c cos + s sin
// of n w t), `header` names those columns (f_<axis>_cos_N ...), `amplitude[a][n]` the
// amplitude of component a. Requires the samples to resolve max_harmonic >= 1; throws
// std::invalid_argument otherwise.
struct ForceHarmonics {
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;
  std::vector<std::vector<double>> amplitude;
};
ForceHarmonics force_harmonics(const Eigen::MatrixXd& force, std::span<const int> components,
                               int max_harmonic);

// The names of a contact's local axes by index: t1, t2, n.
extern const char* const kContactAxisNames[3];

}  // namespace frichb::core
