// Tracing one contact law over one period of a multiharmonic relative motion (the "time"
// half of AFT), with the quasi-analytical Jacobian propagated through time in the same pass.
//
// Input: the harmonic coefficients of the used local relative-displacement components,
// laid out component-major: U[a * C + c] (a over the law's used components in the order
// t1, t2, n; c over the layout's coefficients). Output: the force coefficients in the same
// layout and, on request, dF/dU ((d*C) x (d*C), column-major Eigen matrix).
//
// Periodicity: the period is traced repeatedly from the law's initial state until the state
// at the start of a pass repeats at its end (relative tolerance). For a law with tangents, a
// pass that does not repeat its start is followed by a Newton step onto the fixed point of the
// pass's map (its monodromy M from the tangents; TraceOptions::newton_on_periodic_state).
// The Jacobian is the exact derivative of the computed periodic forces. For a law with
// tangents (and the Newton steps allowed) the passes up to the periodic state carry no
// derivative: a pass that repeats its start carries the derivative with respect to the
// unknowns (B) and to its start state (M), and the periodic state's derivative is the fixed
// point D* = (I - M)^-1 B; that pass's forces are moved onto the periodic state along the
// Newton step (I - M)^-1 (s1 - s0) by their start-state derivatives (to second order in the
// pass's change, itself within relative_tolerance). Where the derivative depends on the
// warm-up instead (I - M singular: a direction the contact never slips in; a state component
// the first pass leaves at its initial value; a multiplier of M beyond 1), and for laws
// without the Newton steps, the derivative is carried through every pass from the
// U-independent initial state, warm-up included, until it repeats too.
// A contact that never slips keeps its initial state, so its mean tangential force is kt
// times the mean relative displacement (docs/theory.md, "full stick convention").
//
// Laws that step along the motion (ABI 1.3, traits.traces_motion) receive, with each step's
// end samples, the rates du/ds of the harmonic series there (s the step's fraction), so they
// integrate along the series' cubic Hermite interpolant between samples; they also report the
// force's kinks inside the steps (stick to slip, opening, closing), and the force coefficients
// then correct the trapezoidal rule at each kink. A force F ~ A |s - s*|^p on one side of
// the kink (s the step's fraction, s* the kink's) leaves the trapezoidal sum a term short:
//   integral = trapezoidal sum - h A zeta(-p, a) g(theta*),
// zeta the Hurwitz zeta function, a the distance in steps from the kink to the first sample
// on the force's side, h the sample spacing in phase, g the basis function and theta* the
// kink's phase (Navot's generalised Euler-Maclaurin term). A jump J in dF/ds is the onset
// J (s - s*) after the kink, p = 1, whose term is (h / 2) J B2(sigma) g(theta*), B2(x) =
// x^2 - x + 1/6, sigma the kink's fraction (third order after it); a kink may also carry an
// onset of its own (Hertz: p = 1.5 where the contact closes or opens). The Jacobian carries
// the corrections' derivatives through the kinks' reported derivatives.
//
// The force entering the equations is the law's force minus its force at u = 0 in the
// initial state (the preload balanced by the static equilibrium the unknowns are measured
// from); `force` in ContactTrace is the law's raw force.
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "frichb/core/numerics/harmonics.hpp"
#include "frichb/core/plugin_host/registry.hpp"

namespace frichb::core {

enum class JacobianMode { kNone, kAnalytic, kFiniteDifference };

struct TraceOptions {
  int max_passes = 200;               // bound on passes for the state, then for its derivative
  double relative_tolerance = 1e-11;  // on the state (and derivative) change over one pass
  // Newton steps on the periodic state between passes, from the monodromy of the law's
  // tangents (laws that provide them); false: plain passes only. Either way the trace ends on
  // a pass that repeats its start to relative_tolerance.
  bool newton_on_periodic_state = true;
  // Laws that step along the motion do so (false: their sample-only step(), e.g. to compare).
  bool along_motion = true;
};

struct ContactTrace {
  Eigen::MatrixXd displacement;        // N x d, local relative displacement samples (m)
  Eigen::MatrixXd rate;                // N x d, du/ds at the samples, m per sample step
  Eigen::MatrixXd force;               // N x d, raw law force samples (N)
  Eigen::MatrixXd state;               // N x S, the law's state after each sample (last pass)
  Eigen::VectorXd force_coefficients;  // d*C, of (force - reference force)
  Eigen::MatrixXd jacobian;            // d*C x d*C when requested
  int passes = 0;                      // passes until the state (and its derivative) repeated
  int derivative_passes = 0;           // of those, passes that carried the derivative
  int newton_passes = 0;               // of those, passes followed by a Newton step on the state
  bool periodic = true;                // false: max_passes reached (the diagnostic says so)
  bool used_finite_differences = false;
  std::string diagnostic;
  int kinks = 0;  // force kinks inside steps in the last pass (laws that step along the motion)
  // The energy the contact dissipates per cycle (J): the closed integral of f . du over every
  // axis the law uses, from the harmonics, pi sum_k k (F_ck U_sk - F_sk U_ck). The motion is
  // its harmonic series, so this is the integral of the force's exact Fourier coefficients
  // (as accurate as force_coefficients) and the energy the harmonic balance equations put in.
  double energy_per_cycle = 0;
};

// The shares of a traced period (fractions of its samples, summing to 1) a contact spends
// open, stuck and slipping. A sample is open when the law uses the normal direction
// (`components` holds 2) and its normal force is <= 0; else stuck when the law's state did not
// change from the sample before (within 1e-9 of the largest displacement: a slider that did not
// move), else slipping. A law without state is stuck whenever it is closed.
struct SlipShares {
  double stuck = 0, slipping = 0, open = 0;
};
SlipShares slip_shares(const ContactTrace& trace, const std::vector<int>& components);

// Not thread-safe: a tracer keeps its buffers between traces; use one per thread (the
// harmonic balance model has one per contact, and a thread traces its own contacts).
class PeriodicTracer {
 public:
  PeriodicTracer(const ContactLawInstance& law, const HarmonicLayout& layout,
                 TraceOptions options = {});

  // Used local components (subset of {0: t1, 1: t2, 2: n}), ascending.
  const std::vector<int>& components() const { return components_; }
  int dimension() const { return static_cast<int>(components_.size()); }
  int unknown_count() const { return dimension() * layout_.coefficient_count(); }
  const HarmonicLayout& layout() const { return layout_; }
  const Eigen::Vector3d& reference_force() const { return reference_force_; }
  // True when the law steps along the motion between samples (and TraceOptions allow it).
  bool along_motion() const { return along_; }

  // Returns false with `error` when the law fails. kAnalytic on a law without tangents falls
  // back to finite differences (out.used_finite_differences).
  bool trace(const Eigen::VectorXd& u_coefficients, JacobianMode mode, ContactTrace& out,
             std::string* error);

 private:
  // One force kink of the last pass: its phase, jump of dF/ds per used component, and with
  // the Jacobian their derivatives with respect to the unknowns (rows of length d*C).
  struct Kink {
    int sample = 0;  // the step ends at this sample
    double fraction = 0;
    Eigen::VectorXd jump;          // d
    Eigen::RowVectorXd dfraction;  // d*C
    Eigen::MatrixXd djump;         // d x d*C
    // The force's onset at the kink (frichb_force_kinks): power 0 for none.
    double onset_power = 0, onset_side = 0;
    Eigen::VectorXd onset;   // d
    Eigen::MatrixXd donset;  // d x d*C
  };
  // The kinks of a pass: the first `count` of `items` (kept between passes and traces, so
  // that their rows are not allocated again).
  struct KinkList {
    std::vector<Kink> items;
    std::size_t count = 0;
    Kink& append() {
      if (count == items.size()) items.emplace_back();
      return items[count++];
    }
  };
  // Per-sample rows (samples x columns, row-major): what a pass writes one sample at a time.
  using SampleRows = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  // The law's kink report of one step (frichb_force_kinks' arrays), sized once for the law.
  struct KinkReport {
    std::vector<double> fraction, jump, dfraction, djump, onset, onset_power, onset_side, donset;
  };
  void sample_motion(const Eigen::VectorXd& u_coefficients, ContactTrace& out);
  double energy_per_cycle(const Eigen::VectorXd& u_coefficients,
                          const Eigen::VectorXd& force_coefficients) const;
  bool run_passes(ContactTrace& out, bool with_derivative, std::string* error);
  bool run_passes_from_initial_state(ContactTrace& out, bool with_derivative, std::string* error);
  bool run_passes_to_periodic_derivative(ContactTrace& out, bool& settled, std::string* error);
  bool run_period(const ContactTrace& motion, Eigen::VectorXd& state, Eigen::MatrixXd* dstate,
                  Eigen::MatrixXd& force, Eigen::MatrixXd& states, std::vector<SampleRows>* dforce,
                  Eigen::MatrixXd* monodromy, KinkList* kinks, std::string* error);
  void record_kinks(std::size_t count, int j, const Eigen::MatrixXd* dstate, KinkList& kinks) const;
  void transform_forces(ContactTrace& out, const std::vector<SampleRows>* dforce,
                        const KinkList& kinks);

  const ContactLawInstance& law_;
  HarmonicLayout layout_;
  TraceOptions options_;
  Aft aft_;
  std::vector<int> components_;
  int state_size_;
  SampleRows basis_;   // N x C
  SampleRows dbasis_;  // N x C, d basis / ds (per sample step)
  bool along_ = false;
  KinkReport kink_report_;
  KinkList kinks_;
  Eigen::Vector3d reference_force_ = Eigen::Vector3d::Zero();
};

}  // namespace frichb::core
