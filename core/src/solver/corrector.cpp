// The continuation's correctors (corrector.hpp).
#include "solver/corrector.hpp"

#include <sstream>
#include <string>
#include <utility>

#include "frichb/core/support/interrupt.hpp"

namespace frichb::core {

using Eigen::Index;
using Eigen::VectorXd;

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

Correction newton_correct(const ScaledProblem& problem, const VectorXd& ys0,
                          const NewtonOptions& opt, const VectorXd* tangent,
                          const VectorXd* predictor) {
  const Index n = problem.equations();
  const bool keller = tangent != nullptr;
  const Index m = keller ? n + 1 : n;

  // Residual of the system being solved and the full scaled Jacobian, from one evaluation.
  auto system = [&](const VectorXd& ys, VectorXd* r, Jacobian* js, std::string* msg) {
    VectorXd es;
    if (!problem.evaluate(ys, &es, js, msg)) return false;
    r->resize(m);
    r->head(n) = es;
    if (keller) (*r)(n) = tangent->dot(ys - *predictor);
    return true;
  };

  Correction out;
  out.ys = ys0;
  if (opt.stop.stop_requested()) {
    out.message = opt.stop.reason();
    return out;
  }
  VectorXd r;
  if (!system(out.ys, &r, &out.js, &out.message)) {
    out.first_evaluation_failed = true;
    return out;
  }
  out.residual_norm = r.lpNorm<Eigen::Infinity>();
  if (out.residual_norm <= 1e-3 * opt.residual_tolerance) {
    out.converged = true;
    return out;
  }
  // Iterations since the best residual last halved, once it meets the tolerance:
  // a non-smooth residual (a contact sample switching between stick and slip) has a floor
  // where Newton cycles between pieces with updates that never shrink. At fixed lambda a
  // point whose residual meets the tolerance there is a solution to that tolerance; on the
  // Keller hyperplane the corrector fails there (below).
  // The cycle may visit iterates above the tolerance: the best iterate is kept, and
  // returned once the best residual has not halved for that many iterations (its Jacobian
  // is then evaluated again rather than kept from every improvement).
  int since_best = 0;
  bool floor_brackets_root = false;
  double floor_residual = out.residual_norm;
  VectorXd floor_ys = out.ys;
  const std::unique_ptr<LinearSolver> lu = make_linear_solver(problem.linear());
  Jacobian trial_js, best_js;
  while (out.iterations < opt.max_iterations) {
    if (opt.stop.stop_requested()) {
      out.message = opt.stop.reason();
      return out;
    }
    if (keller)
      lu->prepare_bordered(out.js, *tangent);
    else
      lu->prepare(out.js);
    if (!lu->invertible()) {
      out.message = "singular Jacobian at " + problem.describe_lambda(out.ys);
      return out;
    }
    VectorXd dz = lu->solve_update(-r);
    if (!dz.allFinite()) {
      out.message = "non-finite Newton update at " + problem.describe_lambda(out.ys);
      if (!lu->failure().empty()) out.message += " (" + lu->failure() + ")";
      return out;
    }
    ++out.iterations;
    VectorXd dy = VectorXd::Zero(n + 1);
    dy.head(m) = dz;

    // Halve the update while it increases the residual; if no trial improves, take the best
    // one rather than stalling, since Newton may need to cross a residual hill.
    double best_norm = kInf;
    double best_factor = 0.0;
    VectorXd best_r;
    std::string trial_message;
    double factor = 1.0;
    for (int h = 0; h <= opt.max_line_search_halvings; ++h, factor *= 0.5) {
      VectorXd tr;
      if (!system(out.ys + factor * dy, &tr, &trial_js, &trial_message)) continue;
      const double tn = tr.lpNorm<Eigen::Infinity>();
      if (tn < best_norm) {
        best_norm = tn;
        best_factor = factor;
        best_r = std::move(tr);
        best_js.swap(trial_js);
      }
      if (tn <= out.residual_norm) break;
    }
    if (best_factor == 0.0) {
      out.message = trial_message;
      return out;
    }
    // The residual reversing between iterates near the tolerance brackets a root: the
    // floor is a jump of the residual across the curve, not a miss of it.
    if (floor_residual <= opt.residual_tolerance && best_r.head(n).dot(r.head(n)) < 0.0)
      floor_brackets_root = true;
    out.ys += best_factor * dy;
    r = std::move(best_r);
    out.js.swap(best_js);
    out.residual_norm = best_norm;
    const double update_norm = best_factor * dy.lpNorm<Eigen::Infinity>();
    if ((out.residual_norm <= opt.residual_tolerance && update_norm <= opt.step_tolerance) ||
        out.residual_norm <= 1e-3 * opt.residual_tolerance) {
      out.converged = true;
      return out;
    }
    const bool halved = out.residual_norm < 0.5 * floor_residual;
    if (out.residual_norm < floor_residual) {
      floor_residual = out.residual_norm;
      floor_ys = out.ys;
    }
    // Counted only once the best residual meets the tolerance.
    since_best = (floor_residual > opt.residual_tolerance || halved) ? 0 : since_best + 1;
    if (floor_residual <= opt.residual_tolerance && since_best >= opt.residual_floor_iterations) {
      // On the Keller hyperplane a floor is also where the hyperplane passes just beyond a
      // fold of the curve: the floor point then lies off the curve, and accepting it walks
      // the curve into the region past the fold where no solution is. There the residual
      // keeps its direction from iterate to iterate (a minimum of |e| on the hyperplane);
      // across a jump it reverses. A floor on the hyperplane that brackets no root is
      // refused: the caller shortens the step, or steps past the kink.
      if (keller && !floor_brackets_root && !opt.floor_on_hyperplane) {
        std::ostringstream msg;
        msg << "Newton stalled on a residual floor of " << floor_residual << " at "
            << problem.describe_lambda(floor_ys);
        out.message = msg.str();
        return out;
      }
      if (floor_ys != out.ys) {
        VectorXd floor_r;
        if (!system(floor_ys, &floor_r, &out.js, &out.message)) return out;
        out.ys = floor_ys;
      }
      out.residual_norm = floor_residual;
      out.converged = true;
      out.at_residual_floor = true;
      return out;
    }
  }
  std::ostringstream msg;
  msg << "Newton did not converge in " << opt.max_iterations << " iterations (residual "
      << out.residual_norm << ") at " << problem.describe_lambda(out.ys);
  out.message = msg.str();
  return out;
}

Correction chord_correct(const ScaledProblem& problem, const KellerFactor& factor,
                         const NewtonOptions& opt, const VectorXd& tangent,
                         const VectorXd& predictor, int max_chord) {
  constexpr double kMaxContraction = 0.5;
  const Index n = problem.equations();
  Correction out;
  out.ys = predictor;
  VectorXd es;
  VectorXd r(n + 1);
  if (!problem.evaluate(out.ys, &es, nullptr, &out.message)) return out;
  r.head(n) = es;
  r(n) = 0.0;
  out.residual_norm = r.lpNorm<Eigen::Infinity>();
  double update_norm = kInf;
  while (!(out.residual_norm <= 1e-3 * opt.residual_tolerance ||
           (out.residual_norm <= opt.residual_tolerance && update_norm <= opt.step_tolerance))) {
    if (out.chord_iterations >= max_chord || opt.stop.stop_requested()) return out;
    const VectorXd dz = factor.solve(-r);
    if (!dz.allFinite()) return out;
    const VectorXd trial = out.ys + dz;
    if (!problem.evaluate(trial, &es, nullptr, &out.message)) return out;
    ++out.chord_iterations;
    r.head(n) = es;
    r(n) = tangent.dot(trial - predictor);
    const double norm = r.lpNorm<Eigen::Infinity>();
    if (!(norm <= kMaxContraction * out.residual_norm)) return out;
    out.ys = trial;
    out.residual_norm = norm;
    update_norm = dz.lpNorm<Eigen::Infinity>();
  }
  if (!problem.evaluate(out.ys, &es, &out.js, &out.message)) return out;
  out.iterations = out.chord_iterations;
  out.converged = true;
  return out;
}

}  // namespace frichb::core
