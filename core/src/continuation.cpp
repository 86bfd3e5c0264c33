#include "frichb/core/continuation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>
#include <utility>

#include "continuation/step_controller.hpp"
#include "frichb/core/dense_lu.hpp"

namespace frichb::core {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

constexpr double kInf = std::numeric_limits<double>::infinity();
// Weight of a chord iteration in the step adaptation (eq. 4.13), against a Newton iteration.
constexpr double kChordIterationWeight = 0.5;

std::string FormatLambda(double lambda) {
  std::ostringstream out;
  out.precision(12);
  out << "lambda = " << lambda;
  return out.str();
}

bool Fail(std::string* why, const std::string& reason) {
  if (why != nullptr) *why = reason;
  return false;
}

bool PositiveFinite(double v) {
  return std::isfinite(v) && v > 0.0;
}

// Scale vectors resolved to their full sizes (empty option = all ones).
struct Scaling {
  VectorXd unknown;   // n + 1
  VectorXd residual;  // n
};

bool MakeScaling(const ContinuationOptions& options, Index n, Scaling* scaling, std::string* why) {
  scaling->unknown =
      options.unknown_scale.size() == 0 ? VectorXd::Ones(n + 1) : options.unknown_scale;
  scaling->residual =
      options.residual_scale.size() == 0 ? VectorXd::Ones(n) : options.residual_scale;
  if (scaling->unknown.size() != n + 1) return Fail(why, "unknown_scale must have n + 1 entries");
  if (scaling->residual.size() != n) return Fail(why, "residual_scale must have n entries");
  return true;
}

// Evaluates the problem at scaled unknowns and returns the scaled residual and the scaled
// n x (n + 1) Jacobian. Non-finite output counts as a failed evaluation so that NaN can never
// leak into an accepted point.
// The profile of the solve running on this thread (trace_curve, solve_fixed_parameter), or
// none. Each thread runs its own solves, so the pointer is per thread.
thread_local SolveProfile* current_profile = nullptr;

class ProfileScope {
 public:
  explicit ProfileScope(SolveProfile* profile) : previous_(current_profile) {
    current_profile = profile;
  }
  ~ProfileScope() { current_profile = previous_; }
  ProfileScope(const ProfileScope&) = delete;
  ProfileScope& operator=(const ProfileScope&) = delete;

 private:
  SolveProfile* previous_;
};

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

bool EvaluateScaled(const CurveProblem& problem, const Scaling& s, const VectorXd& ys, VectorXd* es,
                    MatrixXd* js, std::string* message) {
  const Index n = s.residual.size();
  const VectorXd y = ys.cwiseProduct(s.unknown);
  VectorXd e(n);
  // The Jacobian is written into js's own storage (kept between calls of the same size).
  if (js != nullptr) js->resize(n, n + 1);
  std::string why;
  const auto start = std::chrono::steady_clock::now();
  const bool evaluated = problem.evaluate(y, e, js, &why);
  if (current_profile != nullptr) {
    ++current_profile->evaluations;
    current_profile->evaluation_seconds += SecondsSince(start);
    if (js == nullptr) ++current_profile->residual_only_evaluations;
  }
  if (!evaluated) {
    *message = "evaluation failed at " + FormatLambda(y(n)) + (why.empty() ? "" : ": " + why);
    return false;
  }
  if (e.size() != n || (js != nullptr && (js->rows() != n || js->cols() != n + 1))) {
    *message = "evaluate() returned wrongly sized residual or Jacobian";
    return false;
  }
  if (!e.allFinite() || (js != nullptr && !js->allFinite())) {
    *message = "non-finite residual or Jacobian at " + FormatLambda(y(n));
    return false;
  }
  *es = e.cwiseQuotient(s.residual);
  if (js != nullptr) {
    // Rows by the residual scales and columns by the unknown scales, in one pass.
    const VectorXd inverse_residual_scale = s.residual.cwiseInverse();
    for (Index c = 0; c <= n; ++c)
      js->col(c) = js->col(c).cwiseProduct(inverse_residual_scale) * s.unknown(c);
  }
  return true;
}

// Dense LU with partial pivoting (blocked, the fast factorisation of large Newton matrices)
// and its reciprocal condition estimate (LAPACK-style, O(n^2) on top). A matrix is taken as
// singular when that estimate is below machine precision or not finite. One object is
// refactorised in place over the iterations of a solve (its storage is allocated once).
class Lu {
 public:
  Lu() = default;
  explicit Lu(const Eigen::Ref<const MatrixXd>& a) { factorise(a); }
  void factorise(const Eigen::Ref<const MatrixXd>& a) {
    const auto start = std::chrono::steady_clock::now();
    lu_.compute(a);
    Account(start, true);
  }
  // [top; last_row^T]
  void factorise_bordered(const Eigen::Ref<const MatrixXd>& top,
                          const Eigen::Ref<const VectorXd>& last_row) {
    const auto start = std::chrono::steady_clock::now();
    lu_.compute_bordered(top, last_row);
    Account(start, true);
  }
  VectorXd solve(const VectorXd& b) const {
    const auto start = std::chrono::steady_clock::now();
    VectorXd x = lu_.solve(b);
    Account(start, false);
    return x;
  }
  bool invertible() const {
    return std::isfinite(lu_.rcond()) && lu_.rcond() > std::numeric_limits<double>::epsilon();
  }
  double condition() const { return lu_.rcond() > 0.0 ? 1.0 / lu_.rcond() : kInf; }
  int determinant_sign() const { return lu_.determinant_sign(); }

 private:
  static void Account(std::chrono::steady_clock::time_point start, bool factorisation) {
    if (current_profile == nullptr) return;
    current_profile->factorisation_seconds += SecondsSince(start);
    if (factorisation) ++current_profile->factorisations;
  }
  DenseLu lu_;
};

// The factorisation of the Keller matrix A = [J; v_prev^T] at an accepted point, kept for the
// next step's chord iterations, with t = A^-1 e_n (the point's tangent v = t / |t|).
// The next corrector's matrix is B = [J; v^T] = A + e_n d^T with d = v - v_prev; B^-1 comes
// from A's factors by the Sherman-Morrison formula: B^-1 b = x - t (d . x) / (1 + d . t),
// x = A^-1 b (and 1 + d . t = |t| in exact arithmetic).
struct KellerFactor {
  Lu lu;
  VectorXd t;
  VectorXd d;
  double denominator = 1.0;
  VectorXd solve(const VectorXd& b) const {
    const VectorXd x = lu.solve(b);
    return x - t * (d.dot(x) / denominator);
  }
};

struct CoreResult {
  bool converged = false;
  bool first_evaluation_failed = false;
  int iterations = 0;
  int chord_iterations = 0;  // of them, chord iterations on a kept factorisation
  double residual_norm = kInf;
  bool at_residual_floor = false;  // accepted on the residual alone (see DampedNewton)
  VectorXd ys;                     // scaled, lambda last
  MatrixXd js;                     // scaled full Jacobian at ys
  std::string message;
};

// Damped Newton in scaled variables. Without a tangent, lambda stays fixed and the n
// equations are solved for x; with a tangent v and predictor y1, the Keller system
// [e; v^T (y - y1)] = 0 is solved for all n + 1 unknowns.
// Memory: besides the problem's own, at most three n x (n + 1) Jacobians (current, trial,
// best trial of the line search) and one factorisation, each allocated once per call.
CoreResult DampedNewton(const CurveProblem& problem, const Scaling& s, const VectorXd& ys0,
                        const NewtonOptions& opt, const VectorXd* tangent = nullptr,
                        const VectorXd* predictor = nullptr) {
  const Index n = s.residual.size();
  const bool keller = tangent != nullptr;
  const Index m = keller ? n + 1 : n;

  // Residual of the system being solved and the full scaled Jacobian, from one evaluation.
  auto system = [&](const VectorXd& ys, VectorXd* r, MatrixXd* js, std::string* msg) {
    VectorXd es;
    if (!EvaluateScaled(problem, s, ys, &es, js, msg)) return false;
    r->resize(m);
    r->head(n) = es;
    if (keller) (*r)(n) = tangent->dot(ys - *predictor);
    return true;
  };

  CoreResult out;
  out.ys = ys0;
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
  Lu lu;
  MatrixXd trial_js, best_js;
  while (out.iterations < opt.max_iterations) {
    if (keller)
      lu.factorise_bordered(out.js, *tangent);
    else
      lu.factorise(out.js.leftCols(n));
    if (!lu.invertible()) {
      out.message = "singular Jacobian at " + FormatLambda(out.ys(n) * s.unknown(n));
      return out;
    }
    VectorXd dz = lu.solve(-r);
    if (!dz.allFinite()) {
      out.message = "non-finite Newton update at " + FormatLambda(out.ys(n) * s.unknown(n));
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
      if (keller && !floor_brackets_root) {
        std::ostringstream msg;
        msg << "Newton stalled on a residual floor of " << floor_residual << " at "
            << FormatLambda(floor_ys(n) * s.unknown(n));
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
      << out.residual_norm << ") at " << FormatLambda(out.ys(n) * s.unknown(n));
  out.message = msg.str();
  return out;
}

// Keller corrector by chord iterations on the factorisation kept from the last point
// (KellerFactor): each iteration costs one residual evaluation (no Jacobian) and two
// triangular solves instead of an evaluation with the Jacobian and a factorisation. Gives up
// - returning not converged with ys its best iterate, for the full Newton corrector to take
// over from there - when
// the residual does not at least halve per iteration (the Jacobian has changed too much:
// a contact changed regime, or the step is long) or after `max_chord` iterations. Converged:
// the Jacobian at the solution is evaluated once (the tangent needs it).
CoreResult ChordKeller(const CurveProblem& problem, const Scaling& s, const KellerFactor& factor,
                       const NewtonOptions& opt, const VectorXd& tangent, const VectorXd& predictor,
                       int max_chord) {
  constexpr double kMaxContraction = 0.5;
  const Index n = s.residual.size();
  CoreResult out;
  out.ys = predictor;
  VectorXd es;
  VectorXd r(n + 1);
  if (!EvaluateScaled(problem, s, out.ys, &es, nullptr, &out.message)) return out;
  r.head(n) = es;
  r(n) = 0.0;
  out.residual_norm = r.lpNorm<Eigen::Infinity>();
  double update_norm = kInf;
  while (!(out.residual_norm <= 1e-3 * opt.residual_tolerance ||
           (out.residual_norm <= opt.residual_tolerance && update_norm <= opt.step_tolerance))) {
    if (out.chord_iterations >= max_chord) return out;
    const VectorXd dz = factor.solve(-r);
    if (!dz.allFinite()) return out;
    const VectorXd trial = out.ys + dz;
    if (!EvaluateScaled(problem, s, trial, &es, nullptr, &out.message)) return out;
    ++out.chord_iterations;
    r.head(n) = es;
    r(n) = tangent.dot(trial - predictor);
    const double norm = r.lpNorm<Eigen::Infinity>();
    if (!(norm <= kMaxContraction * out.residual_norm)) return out;
    out.ys = trial;
    out.residual_norm = norm;
    update_norm = dz.lpNorm<Eigen::Infinity>();
  }
  if (!EvaluateScaled(problem, s, out.ys, &es, &out.js, &out.message)) return out;
  out.iterations = out.chord_iterations;
  out.converged = true;
  return out;
}

// Eq. 4.9: w = e_x^-1 e_lambda, v = dir * (-w, 1) / |(1, w)|. `condition`: estimate of
// the 1-norm condition number of e_x.
bool FirstTangent(const MatrixXd& js, double direction, VectorXd* v, double* condition,
                  int* orientation) {
  const Index n = js.rows();
  const Lu lu(js.leftCols(n));
  *condition = lu.condition();
  if (!lu.invertible()) return false;
  const VectorXd w = lu.solve(js.col(n));
  VectorXd t(n + 1);
  t.head(n) = -w;
  t(n) = 1.0;
  *v = direction * t / t.norm();
  // det [e_x e_lambda; v^T] = det e_x (1 + w . w) direction / |(1, w)|.
  if (orientation != nullptr)
    *orientation = direction > 0 ? lu.determinant_sign() : -lu.determinant_sign();
  return v->allFinite();
}

// Eq. 4.10: [A; v_prev^T] v = [0; 1]; the last row keeps v . v_prev > 0, i.e. no reversal.
// `condition` (optional): estimate of the 1-norm condition number of the bordered matrix,
// the Keller corrector's Newton matrix at the point. `keep` (optional): receives the
// factorisation for the next step's chord iterations.
bool NextTangent(const MatrixXd& js, const VectorXd& previous, VectorXd* v,
                 double* condition = nullptr, KellerFactor* keep = nullptr,
                 int* orientation = nullptr) {
  const Index n = js.rows();
  KellerFactor local;
  KellerFactor& f = keep != nullptr ? *keep : local;
  f.lu.factorise_bordered(js, previous);
  if (condition != nullptr) *condition = f.lu.condition();
  if (!f.lu.invertible()) return false;
  f.t = f.lu.solve(VectorXd::Unit(n + 1, n));
  *v = f.t / f.t.norm();
  if (!v->allFinite()) return false;
  // [J; v^T] = [J; p^T] + e_n (v - p)^T has determinant det [J; p^T] |t| (v . t = |t|).
  if (orientation != nullptr) *orientation = f.lu.determinant_sign();
  f.d = *v - previous;
  f.denominator = 1.0 + f.d.dot(f.t);
  return std::isfinite(f.denominator) && std::abs(f.denominator) > 0.0;
}

// Reverses a tangent from NextTangent (and the Sherman-Morrison terms kept with it).
void ReverseTangent(VectorXd* v, KellerFactor* keep) {
  if (keep != nullptr) {
    const VectorXd bordering = *v - keep->d;  // the row p the factorised matrix was bordered by
    keep->d = -*v - bordering;
    keep->denominator = 1.0 + keep->d.dot(keep->t);
  }
  *v = -*v;
}

// The tangent oriented along the travel (v . v_prev > 0) is the curve's own direction unless
// the point lies past a fold the step jumped (the corrector landed on a piece that runs back
// towards the last point): that orientation walks the curve backwards. The orientation sign
// det [J; v^T] is the same on all pieces of the curve; where the new point's sign differs
// from `reference` (the last point's) across a turn of more than about 26 degrees from
// `along`, the tangent is reversed and true returned. Below that turn - an ordinary step -
// the travel decides: the sign also changes at a branch point and where the curve runs
// inside a kink surface. `keep`: the factorisation kept with the tangent (chord corrector).
bool KeepOrientation(int reference, const VectorXd& along, ContinuationPoint* point,
                     KellerFactor* keep) {
  constexpr double kKeepOrientationCosine = 0.9;
  if (reference == 0 || point->orientation == 0 || point->orientation == reference ||
      point->tangent.dot(along) >= kKeepOrientationCosine)
    return false;
  ReverseTangent(&point->tangent, keep);
  point->orientation = reference;
  return true;
}

// A corrector that lands farther from the predictor than the step either jumped to another
// branch or crossed a corner of this one (a contact sample changing regime makes the
// residual's derivative jump, so the branch is piecewise smooth). It is a corner when the
// two tangent lines - the last point's (y1, v1) and the landed point's (y2, v2) - meet,
// ahead of the last point and behind the landed one, at a point that is itself on the
// branch: two straight pieces meeting at a kink. A jump to another branch has tangent lines
// that miss each other, or meet away from any solution. Lengths are relative to the path
// through the corner. `min_cosine` bounds the turn.
bool CornerBetween(const CurveProblem& problem, const Scaling& scaling, const NewtonOptions& newton,
                   const VectorXd& y1, const VectorXd& v1, const VectorXd& y2, const VectorXd& v2,
                   double min_cosine) {
  constexpr double kRelativeTolerance = 0.05;
  const double c = v1.dot(v2);
  if (c < min_cosine || 1.0 - c * c < 1e-8) return false;  // too sharp, or parallel lines
  // Closest points y1 + a v1 and y2 + b v2 of the two lines.
  const VectorXd w = y1 - y2;
  const double d = v1.dot(w), f = v2.dot(w);
  const double a = (c * f - d) / (1.0 - c * c);
  const double b = f + a * c;
  const double path = a - b;
  if (!(a >= 0.0 && b <= 0.0 && path > 0.0)) return false;
  const VectorXd p1 = y1 + a * v1, p2 = y2 + b * v2;
  if ((p1 - p2).norm() > kRelativeTolerance * path) return false;
  // The kink estimate must lie on the branch: corrected on the hyperplane through it
  // normal to the bisector of the two tangents, it moves by a small part of the path.
  const VectorXd kink = 0.5 * (p1 + p2);
  const VectorXd bisector = (v1 - v2).norm() > 1e-12 ? VectorXd((v1 - v2).normalized()) : v1;
  const CoreResult onto = DampedNewton(problem, scaling, kink, newton, &bisector, &kink);
  return onto.converged && (onto.ys - kink).norm() <= kRelativeTolerance * path;
}

// Whether the scaled point y lies on the curve already traced: within `tolerance` of one of
// the chords between its last points (scaled, oldest first).
bool OnTracedCurve(const VectorXd& y, const std::vector<VectorXd>& traced, double tolerance) {
  for (std::size_t i = 1; i < traced.size(); ++i) {
    const VectorXd chord = traced[i] - traced[i - 1];
    const double length_squared = chord.squaredNorm();
    const double along = length_squared > 0.0
                             ? std::clamp((y - traced[i - 1]).dot(chord) / length_squared, 0.0, 1.0)
                             : 0.0;
    if ((y - traced[i - 1] - along * chord).norm() <= tolerance) return true;
  }
  return false;
}

// A step past a kink of the branch along the next piece's own tangent, for where the Keller
// corrector along the last tangent v fails at every step: a corner turning by more than 90
// degrees (e.g. a fold that falls on a contact sample changing regime, the lambda component
// of the tangent flipping across the kink) leaves no solution on the hyperplane ahead; a
// cluster of kinks (the micro-folds of a non-smooth force on a time grid) can make Newton
// cycle between pieces on it. At the failed predictor q = y + ds v, past the kink, the
// Jacobian J2 is the next piece's: its null vector v2 is that piece's direction up to sign.
// The sign is the one that keeps the curve's orientation, sign det [J2; w^T] =
// sign det [J1; v^T] (the orientation of a piecewise-smooth solution curve is the same on all
// its pieces; v . v_prev > 0, which orients the tangents between ordinary points, fails past
// a turn of more than 90 degrees, and the other sign walks the branch backwards). The residual
// stays flat along v up to the kink (J1 v = 0) and grows as J2 v past it, so the kink lies at
// y + t v with ds - t = (J2 v) . (e(q) - e(y)) / |J2 v|^2 (clamped to [0, ds]). The step from
// there along w is corrected on the hyperplane normal to w and taken when it converges
// without jumping, does not land on the line of the piece just traced and does not land on
// the curve traced before (`traced`: its last points, scaled) - a walk backwards along the
// branch. `travel` receives w.
// What StepPastKink needs of the last point, the same for every step tried from it (so
// evaluated once per point): its residual, the curve's orientation there, sign det [J1; v^T],
// and the curve traced up to it (its last points, scaled). `usable` false: the evaluation
// failed or the orientation is unknown, and no kink step is tried from this point.
struct KinkReference {
  bool usable = false;
  VectorXd residual;
  int orientation = 0;
  std::vector<VectorXd> traced;
};

KinkReference MakeKinkReference(const CurveProblem& problem, const Scaling& s,
                                const std::vector<ContinuationPoint>& points) {
  constexpr std::size_t kTracedPoints = 64;  // the curve a kink step must not land on
  KinkReference ref;
  const ContinuationPoint& last = points.back();
  const VectorXd ys_last = last.y.cwiseQuotient(s.unknown);
  std::string message;
  if (!EvaluateScaled(problem, s, ys_last, &ref.residual, nullptr, &message)) return ref;
  ref.orientation = last.orientation;  // sign det [J; v^T], kept with the point
  for (std::size_t i = points.size() > kTracedPoints ? points.size() - kTracedPoints : 0;
       i < points.size(); ++i)
    ref.traced.push_back(points[i].y.cwiseQuotient(s.unknown));
  ref.usable = ref.orientation != 0;
  return ref;
}

bool StepPastKink(const CurveProblem& problem, const Scaling& s, const NewtonOptions& newton,
                  const VectorXd& ys_last, const VectorXd& v, double step,
                  const KinkReference& reference, CoreResult* out, VectorXd* travel) {
  constexpr double kMinSineToOldPiece = 0.25;  // within ~14 degrees of +-v: the old piece
  constexpr double kOnTracedCurve = 0.05;      // of the step taken: on a chord traced before
  if (!reference.usable) return false;
  const VectorXd q = ys_last + step * v;
  VectorXd e_q;
  MatrixXd j_q;
  std::string message;
  if (!EvaluateScaled(problem, s, q, &e_q, &j_q, &message)) return false;
  Lu past;
  past.factorise_bordered(j_q, v);
  if (!past.invertible()) return false;
  // [J2; v^T] t = e_n: J2 t = 0, and det [J2; t^T] has the sign of det [J2; v^T] (t . t > 0).
  const VectorXd t = past.solve(VectorXd::Unit(v.size(), v.size() - 1));
  if (!t.allFinite() || t.norm() == 0.0) return false;
  const VectorXd direction =
      (past.determinant_sign() == reference.orientation ? 1.0 : -1.0) * t / t.norm();
  const VectorXd growth = j_q * v;  // J2 v
  const double growth_squared = growth.squaredNorm();
  double beyond =
      growth_squared > 0.0 ? growth.dot(e_q - reference.residual) / growth_squared : 0.0;
  if (!std::isfinite(beyond)) beyond = 0.0;
  const VectorXd kink = ys_last + (step - std::clamp(beyond, 0.0, step)) * v;
  const VectorXd predictor = kink + step * direction;
  CoreResult corr = DampedNewton(problem, s, predictor, newton, &direction, &predictor);
  if (!corr.converged || (corr.ys - predictor).norm() > step) return false;
  const VectorXd d = corr.ys - ys_last;
  if ((d - d.dot(v) * v).norm() < kMinSineToOldPiece * d.norm()) return false;
  // Nor back onto the pieces traced before it (a walk backwards along the branch).
  if (OnTracedCurve(corr.ys, reference.traced, kOnTracedCurve * d.norm())) return false;
  *out = std::move(corr);
  *travel = direction;
  return true;
}

}  // namespace

const char* to_string(TerminationType t) {
  switch (t) {
    case TerminationType::kReachedEnd:
      return "reached_end";
    case TerminationType::kMaxPoints:
      return "max_points";
    case TerminationType::kStepTooSmall:
      return "step_too_small";
    case TerminationType::kStartFailed:
      return "start_failed";
    case TerminationType::kEvaluationFailed:
      return "evaluation_failed";
    case TerminationType::kTimeLimit:
      return "time_limit";
    case TerminationType::kLeftBounds:
      return "left_bounds";
    case TerminationType::kCancelled:
      return "cancelled";
    case TerminationType::kInvalidOptions:
      return "invalid_options";
  }
  return "unknown";
}

bool ContinuationOptions::IsValid(std::string* why) const {
  if (!std::isfinite(lambda_start) || !std::isfinite(lambda_end))
    return Fail(why, "lambda_start and lambda_end must be finite");
  if (lambda_start == lambda_end) return Fail(why, "lambda_end must differ from lambda_start");
  if (!PositiveFinite(min_step) || !PositiveFinite(max_step) || !PositiveFinite(initial_step))
    return Fail(why, "initial_step, min_step and max_step must be positive");
  if (min_step > max_step) return Fail(why, "min_step must not exceed max_step");
  if (std::isnan(lambda_min) || std::isnan(lambda_max) || !(lambda_min < lambda_max))
    return Fail(why, "lambda_min must be below lambda_max");
  if (lambda_start < lambda_min || lambda_start > lambda_max || lambda_end < lambda_min ||
      lambda_end > lambda_max)
    return Fail(why, "lambda_start and lambda_end must lie in [lambda_min, lambda_max]");
  if (initial_step < min_step || initial_step > max_step)
    return Fail(why, "initial_step must lie in [min_step, max_step]");
  if (target_newton_iterations < 1) return Fail(why, "target_newton_iterations must be >= 1");
  if (max_points < 1) return Fail(why, "max_points must be >= 1");
  if (!(max_wall_seconds > 0.0)) return Fail(why, "max_wall_seconds must be positive");
  if (turning_point_control) {
    if (turning_point_backtrack < 1) return Fail(why, "turning_point_backtrack must be >= 1");
    if (!(turning_point_refinement > 0.0 && turning_point_refinement < 1.0))
      return Fail(why, "turning_point_refinement must lie in (0, 1)");
  }
  if (steep_branch_control) {
    if (!(steep_branch_alpha > 1.0) || !std::isfinite(steep_branch_alpha))
      return Fail(why, "steep_branch_alpha must be > 1");
    if (!(steep_branch_step_factor > 0.0 && steep_branch_step_factor <= 1.0))
      return Fail(why, "steep_branch_step_factor must lie in (0, 1]");
    if (steep_branch_points < 0) return Fail(why, "steep_branch_points must be >= 0");
  }
  if (!unknown_scale.allFinite() || (unknown_scale.array() <= 0.0).any())
    return Fail(why, "unknown_scale entries must be positive and finite");
  if (!residual_scale.allFinite() || (residual_scale.array() <= 0.0).any())
    return Fail(why, "residual_scale entries must be positive and finite");
  if (newton.max_iterations < 1) return Fail(why, "newton.max_iterations must be >= 1");
  if (!PositiveFinite(newton.residual_tolerance) || !PositiveFinite(newton.step_tolerance))
    return Fail(why, "newton tolerances must be positive");
  if (reuse_factorisation_from < 0) return Fail(why, "reuse_factorisation_from must be >= 0");
  if (max_chord_iterations < 1) return Fail(why, "max_chord_iterations must be >= 1");
  if (newton.max_line_search_halvings < 0)
    return Fail(why, "newton.max_line_search_halvings must be >= 0");
  return true;
}

NewtonResult solve_fixed_parameter(const CurveProblem& problem, const VectorXd& y_guess,
                                   const ContinuationOptions& options) {
  NewtonResult result;
  result.y = y_guess;
  const Index n = problem.equation_count();
  Scaling s;
  if (y_guess.size() != n + 1) {
    result.message = "y_guess must have n + 1 entries";
    return result;
  }
  if (!MakeScaling(options, n, &s, &result.message)) return result;
  const ProfileScope profile(&result.profile);
  const CoreResult core =
      DampedNewton(problem, s, y_guess.cwiseQuotient(s.unknown), options.newton);
  result.converged = core.converged;
  result.iterations = core.iterations;
  result.residual_norm = core.residual_norm;
  result.at_residual_floor = core.at_residual_floor;
  result.y = core.ys.cwiseProduct(s.unknown);
  result.y(n) = y_guess(n);  // unscaling must not perturb the fixed parameter
  result.message = core.message;
  return result;
}

double ContinuationOptions::band_advance(double lambda, double direction) const {
  double limit = std::numeric_limits<double>::infinity();
  for (const auto& band : step_bands) {
    const bool approaching = direction * (band.centre - lambda) > 0;
    limit = std::min(limit, band.step + (approaching ? band.growth : band.leaving_growth) *
                                            std::abs(lambda - band.centre));
  }
  return limit;
}

ContinuationSummary trace_curve(const CurveProblem& problem, const VectorXd& y_guess,
                                const ContinuationOptions& options, const PointCallback& on_point) {
  const auto clock_start = std::chrono::steady_clock::now();
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - clock_start).count();
  };
  ContinuationSummary summary;
  const ProfileScope profile(&summary.profile);
  const Index n = problem.equation_count();
  auto finish = [&](TerminationType t, const std::string& reason) {
    summary.termination = t;
    summary.message = reason;
    if (!summary.points.empty())
      summary.message += " (last point at " + FormatLambda(summary.points.back().y(n)) + ")";
    summary.turning_points = 0;
    summary.residual_floor_points = 0;
    summary.corners = 0;
    summary.kink_steps = 0;
    summary.max_condition = 0.0;
    summary.max_condition_point = 0;
    for (std::size_t i = 0; i < summary.points.size(); ++i) {
      const auto& point = summary.points[i];
      summary.residual_floor_points += point.at_residual_floor;
      summary.corners += point.passed_corner;
      summary.kink_steps += point.passed_kink;
      if (point.condition > summary.max_condition) {
        summary.max_condition = point.condition;
        summary.max_condition_point = i;
      }
    }
    for (std::size_t i = 1; i < summary.points.size(); ++i)
      if (summary.points[i - 1].tangent(n) * summary.points[i].tangent(n) < 0.0)
        ++summary.turning_points;
    summary.wall_seconds = elapsed();
    return summary;
  };

  std::string why;
  if (!options.IsValid(&why)) return finish(TerminationType::kInvalidOptions, why);
  Scaling s;
  if (n < 1) return finish(TerminationType::kInvalidOptions, "problem has no equations");
  if (y_guess.size() != n + 1)
    return finish(TerminationType::kInvalidOptions, "y_guess must have n + 1 entries");
  if (!MakeScaling(options, n, &s, &why)) return finish(TerminationType::kInvalidOptions, why);

  const double direction = options.lambda_end > options.lambda_start ? 1.0 : -1.0;
  const NewtonOptions& newton = options.newton;
  auto unscale = [&](const VectorXd& ys) { return VectorXd(ys.cwiseProduct(s.unknown)); };
  auto emit = [&](const ContinuationPoint& p) {
    summary.points.push_back(p);
    return !on_point || on_point(summary.points.back(), summary.points.size() - 1);
  };

  // Start point: fixed-parameter Newton at lambda_start.
  VectorXd ys0 = y_guess.cwiseQuotient(s.unknown);
  ys0(n) = options.lambda_start / s.unknown(n);
  const CoreResult start = DampedNewton(problem, s, ys0, newton);
  summary.total_newton_iterations += start.iterations;
  if (start.first_evaluation_failed)
    return finish(TerminationType::kEvaluationFailed, "start point: " + start.message);
  if (!start.converged)
    return finish(TerminationType::kStartFailed, "start point: " + start.message);
  ContinuationPoint first;
  first.y = unscale(start.ys);
  first.y(n) = options.lambda_start;
  if (!FirstTangent(start.js, direction, &first.tangent, &first.condition, &first.orientation))
    return finish(TerminationType::kStartFailed,
                  "start point: singular e_x, no tangent at " + FormatLambda(first.y(n)));
  first.newton_iterations = start.iterations;
  first.residual_norm = start.residual_norm;
  first.at_residual_floor = start.at_residual_floor;
  if (!emit(first)) return finish(TerminationType::kCancelled, "cancelled by callback");

  StepController steps(options);
  // Correction / step of the last too-long correction, and how many times in a row it
  // repeated (within 10 %) as the step was halved at this point.
  double corner_ratio = kInf;
  int corner_repeats = 0;
  constexpr double kMaxCornerRatio = 1e3;  // a turn of at most 89.94 degrees
  // Failed corrections from one point after which a step past a kink is tried.
  constexpr int kKinkStepAfterFailures = 4;
  int failures_here = 0;                        // failed corrections since the last accepted point
  std::optional<KinkReference> kink_reference;  // of the last point, once a kink step is tried
  std::size_t fold_floor = 0;  // restarts never undo an accepted fold (no ping-pong)
  const long max_attempts = 64L * options.max_points + 1000L;
  // Chord corrector (ContinuationOptions::reuse_factorisation_from): the factorisation of the
  // Keller matrix at the point of index kept_index, and the one of a candidate point.
  const bool chord = options.reuse_factorisation_from > 0 && n >= options.reuse_factorisation_from;
  KellerFactor kept, candidate;
  std::size_t kept_index = std::numeric_limits<std::size_t>::max();

  for (long attempt = 0;; ++attempt) {
    if (summary.points.size() >= static_cast<std::size_t>(options.max_points))
      return finish(TerminationType::kMaxPoints, "max_points reached");
    if (attempt >= max_attempts)
      return finish(TerminationType::kMaxPoints, "step attempt budget exhausted");
    if (elapsed() > options.max_wall_seconds)
      return finish(TerminationType::kTimeLimit, "max_wall_seconds elapsed");

    const ContinuationPoint& last = summary.points.back();
    const double step = steps.propose(last.y(n), last.tangent(n), s.unknown(n));

    const VectorXd ys_last = last.y.cwiseQuotient(s.unknown);
    const VectorXd predictor = ys_last + step * last.tangent;
    CoreResult corr;
    if (chord && kept_index == summary.points.size() - 1) {
      corr = ChordKeller(problem, s, kept, newton, last.tangent, predictor,
                         options.max_chord_iterations);
      summary.chord_iterations += corr.chord_iterations;
      if (corr.converged) {
        ++summary.chord_points;
      } else {
        ++summary.chord_fallbacks;
        const int chord_iterations = corr.chord_iterations;
        const VectorXd best = corr.ys;
        corr = DampedNewton(problem, s, best, newton, &last.tangent, &predictor);
        corr.iterations += chord_iterations;
        corr.chord_iterations = chord_iterations;
      }
    } else {
      corr = DampedNewton(problem, s, predictor, newton, &last.tangent, &predictor);
    }
    summary.total_newton_iterations += corr.iterations;
    ContinuationPoint p;
    bool sign_change = false;
    bool ok = corr.converged;
    // A correction longer than the step cannot come from the branch's own curvature: the
    // corrector has jumped onto another branch - unless the branch has a corner here (a
    // contact changing regime, the tangent turning by more than 45 degrees). A corner is
    // recognised at once when the tangent lines meet on the branch (CornerBetween), or when
    // the correction shrinks in proportion as the step is halved: once the ratio of
    // correction to step has repeated over three halvings the point across it is taken.
    bool corner = false;
    if (ok && (corr.ys - predictor).norm() > step) {
      const double ratio = (corr.ys - predictor).norm() / step;
      corner_repeats = std::abs(ratio / corner_ratio - 1.0) < 0.1 ? corner_repeats + 1 : 0;
      corner_ratio = ratio;
      VectorXd landed_tangent;
      const bool repeated = corner_repeats >= 2 && ratio <= kMaxCornerRatio;
      corner = repeated || (NextTangent(corr.js, last.tangent, &landed_tangent) &&
                            CornerBetween(problem, s, newton, ys_last, last.tangent, corr.ys,
                                          landed_tangent, 1.0 / kMaxCornerRatio));
      if (!corner) {
        ok = false;
        corr.message = "corrector jumped away from the predictor";
      }
    }
    // The tangent at the new point is oriented along the direction of travel into it.
    VectorXd travel = last.tangent;
    // After a few failed corrections from the last point, each further step is also tried
    // past the kink along the next piece's tangent (StepPastKink); its point is taken like
    // any other.
    bool kink_step = false;
    if (!ok && (failures_here + 1 >= kKinkStepAfterFailures || step <= options.min_step)) {
      CoreResult across;
      VectorXd across_direction;
      if (!kink_reference) kink_reference = MakeKinkReference(problem, s, summary.points);
      if (StepPastKink(problem, s, newton, ys_last, last.tangent, step, *kink_reference, &across,
                       &across_direction)) {
        summary.total_newton_iterations += across.iterations;
        corr = std::move(across);
        travel = across_direction;
        ok = true;
        corner = true;
        kink_step = true;
      }
    }
    if (ok && !NextTangent(corr.js, travel, &p.tangent, &p.condition, chord ? &candidate : nullptr,
                           &p.orientation)) {
      ok = false;
      corr.message = "singular bordered Jacobian, no tangent";
    }
    if (ok && KeepOrientation(last.orientation, travel, &p, chord ? &candidate : nullptr))
      ++summary.reversed_tangents;

    if (ok) {
      p.y = unscale(corr.ys);
      const bool past_end = (p.y(n) - options.lambda_end) * direction >= 0.0;
      if (!past_end && (p.y(n) < options.lambda_min || p.y(n) > options.lambda_max)) {
        std::ostringstream msg;
        msg << "the curve left [" << options.lambda_min << ", " << options.lambda_max << "] at "
            << FormatLambda(p.y(n));
        return finish(TerminationType::kLeftBounds, msg.str());
      }
      p.newton_iterations = corr.iterations;
      p.step = step;
      p.residual_norm = corr.residual_norm;
      p.at_residual_floor = corr.at_residual_floor;
      p.passed_corner = corner;
      p.passed_kink = kink_step;

      sign_change = last.tangent(n) * p.tangent(n) < 0.0;
      // A fold at a kink is accepted at once: no finer step gets around it.
      if (sign_change && options.turning_point_control && !steps.refining() && !kink_step) {
        // Points kept: at least up to the last accepted fold; the new point is always undone.
        const std::size_t total = summary.points.size() + 1;
        const std::size_t backtrack = static_cast<std::size_t>(options.turning_point_backtrack);
        const std::size_t keep =
            std::max(fold_floor + 1, total > backtrack ? total - backtrack : std::size_t{1});
        summary.rejected_steps += static_cast<int>(total - keep);
        summary.points.resize(keep);
        ++summary.fine_control_restarts;
        failures_here = 0;
        kink_reference.reset();
        corner_repeats = 0;  // the corner test starts afresh from the restart point
        corner_ratio = kInf;
        steps.on_fold(step);
        continue;
      }

      if ((p.y(n) - options.lambda_end) * direction >= 0.0) {
        if (!options.land_on_end) {
          emit(p);
          return finish(TerminationType::kReachedEnd, "passed lambda_end");
        }
        // Land exactly on lambda_end from the chord between the last two points.
        const double t = (options.lambda_end - last.y(n)) / (p.y(n) - last.y(n));
        VectorXd guess = last.y + t * (p.y - last.y);
        guess(n) = options.lambda_end;
        const VectorXd guess_s = guess.cwiseQuotient(s.unknown);
        const CoreResult land = DampedNewton(problem, s, guess_s, newton);
        summary.total_newton_iterations += land.iterations;
        ContinuationPoint end;
        if (land.converged && (land.ys - guess_s).norm() <= step &&
            NextTangent(land.js, p.tangent, &end.tangent, &end.condition, nullptr,
                        &end.orientation)) {
          if (KeepOrientation(last.orientation, p.tangent, &end, nullptr))
            ++summary.reversed_tangents;
          end.y = unscale(land.ys);
          end.y(n) = options.lambda_end;
          end.newton_iterations = land.iterations;
          end.step = (land.ys - ys_last).norm();
          end.residual_norm = land.residual_norm;
          end.at_residual_floor = land.at_residual_floor;
          emit(end);
          return finish(TerminationType::kReachedEnd, "reached lambda_end");
        }
        ok = false;
        corr.message = "landing on lambda_end failed" +
                       (land.message.empty() ? std::string() : ": " + land.message);
      }
    }

    if (!ok) {
      ++summary.rejected_steps;
      ++failures_here;
      if (!steps.on_reject(step)) {
        std::ostringstream msg;
        msg << "step below min_step " << options.min_step << ": " << corr.message;
        return finish(TerminationType::kStepTooSmall, msg.str());
      }
      continue;
    }

    // The point is accepted from here on.
    failures_here = 0;
    kink_reference.reset();
    corner_repeats = 0;
    corner_ratio = kInf;
    if (sign_change) fold_floor = summary.points.size();
    // A chord iteration counts as half a Newton iteration: it contracts less, but costs one
    // residual and two triangular solves instead of a Jacobian and a factorisation.
    const double effective_iterations =
        (corr.iterations - corr.chord_iterations) + kChordIterationWeight * corr.chord_iterations;
    const bool steep =
        p.tangent.head(n).norm() > options.steep_branch_alpha * last.tangent.head(n).norm();
    if (steps.on_accept(step, effective_iterations, sign_change, steep))
      ++summary.steep_branch_caps;
    if (chord) {
      std::swap(kept, candidate);
      kept_index = summary.points.size();  // the index p takes
    }
    if (!emit(p)) return finish(TerminationType::kCancelled, "cancelled by callback");
  }
}

}  // namespace frichb::core
