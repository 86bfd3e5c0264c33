// The continuation's step controller (step_controller.hpp).
#include "step_controller.hpp"

#include <algorithm>
#include <cmath>

namespace frichb::core {

StepController::StepController(const ContinuationOptions& options)
    : options_(options), step_(options.initial_step) {}

double StepController::propose(double lambda, double tangent_lambda, double lambda_scale) const {
  double step = step_;
  if (steep_left_ > 0)
    step = std::min(
        step, std::max(options_.min_step, options_.steep_branch_step_factor * options_.max_step));
  if (refining_) step = std::min(step, refine_cap_);
  const double slope = std::max(std::abs(tangent_lambda), 1e-12);
  const double band = std::max(options_.band_advance(lambda, tangent_lambda) / lambda_scale / slope,
                               options_.min_step);
  return std::min(step, band);
}

bool StepController::on_reject(double step) {
  if (step <= options_.min_step) return false;
  step_ = std::max(0.5 * step, options_.min_step);
  return true;
}

void StepController::on_fold(double step) {
  refining_ = true;
  refine_cap_ = std::max(options_.min_step, options_.turning_point_refinement * step);
  refine_left_ = static_cast<int>(
      std::ceil((options_.turning_point_backtrack + 2) / options_.turning_point_refinement));
  step_ = refine_cap_;
}

bool StepController::on_accept(double step, double effective_iterations, bool passed_fold,
                               bool steep) {
  // The fine step ends with an accepted fold, or when its bound runs out.
  if (refining_ && !passed_fold) --refine_left_;
  if (passed_fold || refine_left_ <= 0) refining_ = false;
  if (steep_left_ > 0) --steep_left_;
  const bool cap_started = options_.steep_branch_control && steep;
  if (cap_started) steep_left_ = options_.steep_branch_points;
  // Eq. 4.13 of the thesis; an exact predictor (0 iterations) counts as 1 so that the growth
  // cap decides.
  const double ratio =
      static_cast<double>(options_.target_newton_iterations) / std::max(effective_iterations, 1.0);
  step_ = std::clamp(std::min(step * std::sqrt(ratio), 2.0 * step), options_.min_step,
                     options_.max_step);
  return cap_started;
}

}  // namespace frichb::core
