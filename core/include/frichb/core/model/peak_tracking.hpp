// The resonance peak of a forced response, continued in a design parameter (a contact law's
// parameter, the excitation amplitude): the harmonic balance and the peak's stationarity
// solved together, so that one curve in the parameter replaces a response curve per value.
//
// Unknowns y = (x, w, lambda): the harmonic-balance unknowns x, the circular frequency w
// (rad/s) and the continuation parameter lambda, which is the design parameter p itself or,
// on a logarithmic axis, ln p (p > 0). Equations (n + 1):
//   R(x, w; p) = 0                       the harmonic balance (HarmonicBalanceModel, n rows)
//   g(x, w; p) = grad A(z) . t(z; p) = 0 the peak's stationarity along the response curve
// where z = (x, w), A is the response measure of one node (AmplitudeSampler::peak_amplitude of
// HarmonicBalanceModel::kept_response: the continuous-time maximum of its displacement norm,
// the measure of a run's peak) and t is the response curve's tangent at fixed p, normalised
// against a reference direction c (scaled: the scaled t has c . t = 1):
//   [R_z; c^T] t = e_(n+1).
// Written along the response curve's tangent rather than as dA/dw = 0, the condition holds at
// a peak beside a fold of the response curve as well, where dw/ds -> 0. c is the previous
// accepted point's unit tangent (point_record), so that t stays well defined as the peak
// moves; rescaling c rescales g by a positive factor and keeps its zeros and its sign.
//
// The Jacobian (formed, n + 1 by n + 2):
//   rows of R      R_z analytic (the model's quasi-analytical Jacobian);
//   row of g       dg/dz = t^T (d2A/dz2) - l^T (d/ds R_z(z + s t)), with [R_z; c^T]^T l = grad A:
//                  the second derivatives of R enter only along t, by a central directional
//                  difference of the quasi-analytical Jacobian (two Jacobian evaluations), and
//                  d2A/dz2 along t by the same difference of grad A; grad A is analytic: the
//                  measure's derivative in the node's harmonics at the instant of its maximum
//                  (AmplitudeSampler::peak_gradient) times their derivatives in z
//                  (HarmonicBalanceModel::kept_response_jacobian: the contacts' force blocks of
//                  the evaluation at z, no further trace). Where that is not finite (the node
//                  outside a reduced flexibility's response rows) it falls back to central
//                  differences of the measure, 2 (n + 1) traces each;
//   column of lambda  central differences of the residual between the models at
//                  lambda +- kParameterStep (ParameterModels: the plugin ABI has no derivative
//                  in a law's parameter, so the laws are instantiated again at each value);
//                  one-sided where the scene refuses one of the two values (p at a bound of
//                  its range, such as a normal load of 0).
// Residual-only evaluations compute g from the same analytic gradient (no trace beyond R_z's).
//
// Failure: an evaluation the model or the scene refuses (a parameter value a law rejects, a
// trace that fails) is a failed evaluation (false with the message), which the continuation
// treats as a failed step. Threading: one problem per thread; it calls its ParameterModels,
// whose models are not thread-safe.
#pragma once

#include <Eigen/Dense>
#include <memory>
#include <string>
#include <vector>

#include "frichb/core/model/harmonic_balance.hpp"
#include "frichb/core/model/response.hpp"
#include "frichb/core/solver/continuation.hpp"

namespace frichb::core {

// Steps of the central differences, in the continuation's scaled unknowns (lambda's scale for
// kParameterStep).
inline constexpr double kMeasureStep = 1e-5;    // A's central differences (sensitivities)
inline constexpr double kCurvatureStep = 1e-4;  // grad A and R_z along t
inline constexpr double kParameterStep = 1e-5;  // the laws at lambda +- this

// The Newton tolerances (scaled) of the peak condition: the contacts' traces, periodic to about
// 1e-11, and the central differences of its Jacobian's second derivatives bound what Newton
// converges to; the peak is placed along the response curve to about 1e-8 in the scaled
// arclength.
inline constexpr double kPeakResidualTolerance = 1e-9;
inline constexpr double kPeakStepTolerance = 1e-7;

// The harmonic-balance models of one scene at values of its design parameter p.
class ParameterModels {
 public:
  virtual ~ParameterModels() = default;
  // The model at p (the design parameter, not lambda). The reference is valid until the next
  // call. Throws what the scene or a plugin throws for a value it refuses (SceneError,
  // PluginError, std::invalid_argument).
  virtual const HarmonicBalanceModel& at(double p) const = 0;
};

class PeakCondition final : public CurveProblem {
 public:
  // `models` outlives the problem. `kept`: the node's kept DOF indices; `harmonics` and
  // `samples`: the AmplitudeSampler's (the run's, for the same measure); `z_scale`: the
  // continuation's scales of (x, w) (n + 1 entries), in which the tangent is normalised;
  // `logarithmic`: lambda = ln p. The reference direction starts as the response curve's
  // tangent with a positive w component (set_reference changes it).
  PeakCondition(const ParameterModels& models, std::vector<Eigen::Index> kept,
                const std::vector<int>& harmonics, int samples, Eigen::VectorXd z_scale,
                bool logarithmic, double lambda_scale);
  ~PeakCondition() override;

  Eigen::Index equation_count() const override { return n_ + 1; }
  bool evaluate(const Eigen::VectorXd& y, Eigen::VectorXd& residual, Eigen::MatrixXd* jacobian,
                std::string* message) const override;
  // Sets the reference direction to the response curve's unit tangent at y (the sign kept);
  // keeps nothing (empty).
  Eigen::VectorXd point_record(const Eigen::VectorXd& y) const override;

  // p at lambda, and lambda at p.
  double parameter(double lambda) const;
  double lambda(double p) const;
  bool logarithmic() const { return logarithmic_; }
  // The measure A at y (its model at y's parameter), m.
  double amplitude(const Eigen::VectorXd& y) const;
  // grad A in z = (x, w) at y (n + 1 entries, unscaled), as the peak condition uses it; false
  // (with the message) when the model refuses y.
  bool amplitude_gradient(const Eigen::VectorXd& y, Eigen::VectorXd& out,
                          std::string* message) const;
  // dA along the direction dy (unscaled, n + 2 entries): the central difference of A over
  // +- kMeasureStep dy / |dy|_scaled, divided by that step (one-sided where the scene refuses
  // the parameter's value on one side; throws what it throws where it refuses both). For the
  // peak's sensitivities
  // along the peak curve's tangent.
  double directional_amplitude(const Eigen::VectorXd& y, const Eigen::VectorXd& dy) const;
  // What a point of the peak curve says beyond its position, from one evaluation with the
  // Jacobian: `curvature`, dg/ds along the response curve (g's derivative, the Jacobian's row
  // with the tangent's own change, along the tangent t: A's second derivative along the curve
  // times a positive factor, not along the straight tangent line, which leaves the curve at
  // second order): negative at a maximum, positive where the stationary point traced is a
  // minimum; and `dy_dlambda` along the peak curve (n + 2 entries, the last 1) by the implicit
  // function theorem on the extended Jacobian, [R_z R_l; g_z g_l] (dz/dlambda, 1) = 0, empty
  // where its z block is singular (a fold of the peak curve in the parameter, where the
  // sensitivities are infinite). False (with the message) when the model refuses y.
  struct PointShape {
    double curvature = 0.0;
    Eigen::VectorXd dy_dlambda;
  };
  bool shape(const Eigen::VectorXd& y, PointShape& out, std::string* message) const;
  // The response curve's tangent at y in scaled variables (n + 1 entries), normalised against
  // the reference; false (with the message) when the model refuses y or the system is
  // singular.
  bool response_tangent(const Eigen::VectorXd& y, Eigen::VectorXd& tangent,
                        std::string* message) const;
  // Sets the reference direction (scaled, n + 1 entries; normalised here).
  void set_reference(const Eigen::VectorXd& scaled_direction) const;

 private:
  struct Local;  // R, R_z and the tangent at one (z, p)
  bool local(const HarmonicBalanceModel& model, const Eigen::VectorXd& z, Local& out,
             std::string* message) const;
  double measure(const HarmonicBalanceModel& model, const Eigen::VectorXd& z) const;
  double slope(const HarmonicBalanceModel& model, const Eigen::VectorXd& z,
               const Eigen::VectorXd& t) const;
  // grad A at z: analytic; `model`'s last evaluation must have been at z with the Jacobian.
  Eigen::VectorXd gradient(const HarmonicBalanceModel& model, const Eigen::VectorXd& z) const;
  // grad A at z by central differences of the measure (any model state).
  Eigen::VectorXd difference_gradient(const HarmonicBalanceModel& model,
                                      const Eigen::VectorXd& z) const;

  const ParameterModels& models_;
  std::vector<Eigen::Index> kept_;
  Eigen::Index n_ = 0;
  Eigen::VectorXd z_scale_;
  bool logarithmic_ = false;
  double lambda_scale_ = 1.0;
  mutable Eigen::VectorXd reference_;  // scaled unit direction; empty: +w
  mutable std::unique_ptr<AmplitudeSampler> sampler_;
};

}  // namespace frichb::core
