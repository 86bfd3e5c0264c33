// The continuation options of a frequency sweep (continuation_setup.hpp).
#include "frichb/core/model/continuation_setup.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "frichb/core/support/format.hpp"

namespace frichb::core {

std::vector<ContinuationOptions::StepBand> resonance_bands(
    const std::vector<LinearResonance>& resonances) {
  std::vector<ContinuationOptions::StepBand> bands;
  bands.reserve(resonances.size());
  for (const LinearResonance& r : resonances)
    bands.push_back(
        {r.centre, kCentreStepInHalfWidths * r.half_width, kApproachGrowth, kLeavingGrowth});
  return bands;
}

ContinuationSetup derive_continuation(const Scene& scene, const HarmonicBalanceModel& model) {
  ContinuationSetup setup;
  const YamlContext ctx{scene.file.string()};
  YAML::Node root = scene.root;  // non-const: a missing key then gives an undefined node
  const auto& C = scene.continuation;
  const double unit = C.to_rad_per_s();
  const double w_from = C.from * unit, w_to = C.to * unit;
  const Eigen::Index n = model.equation_count();

  double peak = 0.0;
  for (int i = 0; i <= kContactFreeSamples; ++i) {
    const double w = w_from + (w_to - w_from) * i / static_cast<double>(kContactFreeSamples);
    const Eigen::VectorXd u0 = model.linear_response(w);
    if (!u0.allFinite())
      ctx.fail(root["structure"], "structure",
               "the contact-free response is not finite at " + format_number(w / unit) + " " +
                   unit_name(C.unit) +
                   " (harmonic 0 with a rigid-body mode, or an undamped resonance): ground the "
                   "structure, drop harmonic 0, or add damping");
    if (u0.size()) peak = std::max(peak, u0.cwiseAbs().maxCoeff());
  }
  if (peak == 0.0) peak = 1e-6;
  setup.peak = peak;
  setup.span = std::abs(C.to - C.from);

  ContinuationOptions& options = setup.options;
  options.lambda_start = w_from;
  options.lambda_end = w_to;
  const double margin = kBoundsMargin * std::abs(w_to - w_from);
  options.lambda_min = std::max(0.0, std::min(w_from, w_to) - margin);
  options.lambda_max = std::max(w_from, w_to) + margin;
  setup.resonances = linear_resonances(scene, model, options.lambda_min, options.lambda_max);
  double width = setup.span;
  for (const LinearResonance& r : setup.resonances)
    if (r.harmonic == 1 && r.centre >= std::min(w_from, w_to) && r.centre <= std::max(w_from, w_to))
      width = std::min(width, kWideWindowFactor * r.centre / unit);
  setup.u_unit = C.displacement_scale > 0 ? C.displacement_scale : peak / (kTallness * width);
  options.initial_step = C.initial_step;
  options.min_step = C.min_step;
  options.max_step = C.max_step;
  options.target_newton_iterations = C.target_newton_iterations;
  options.max_points = C.max_points;
  options.max_wall_seconds = C.max_wall_seconds;
  options.lambda_display = {unit, unit_name(C.unit)};
  options.reuse_factorisation_from = C.reuse_factorisation_from;
  options.linear_solver = C.linear_solver == "gmres"         ? LinearSolverKind::kGmres
                          : C.linear_solver == "matrix_free" ? LinearSolverKind::kMatrixFree
                          : C.linear_solver == "dense_lu"    ? LinearSolverKind::kDenseLu
                                                             : LinearSolverKind::kAuto;
  options.gmres_from = C.gmres_from;
  options.matrix_free_from = C.matrix_free_from;
  options.turning_point_control = C.turning_point_control;
  options.steep_branch_alpha = C.steep_branch_alpha;
  options.newton.max_iterations = C.max_newton_iterations;
  options.newton.residual_tolerance = C.tolerance;
  options.newton.step_tolerance = C.tolerance;
  options.step_bands = resonance_bands(setup.resonances);
  options.unknown_scale = Eigen::VectorXd::Constant(n + 1, setup.u_unit);
  options.unknown_scale(n) = unit;
  options.residual_scale = Eigen::VectorXd::Constant(n, peak);
  return setup;
}

}  // namespace frichb::core
