// Pseudo-arclength continuation (Keller) of a curve e(x, lambda) = 0, physics-free.
//
// The module knows nothing of friction or harmonics: it traces the solution curve of any
// n equations in n + 1 unknowns y = [x; lambda] for which a callable returns the residual
// and its dense Jacobian. It implements the thesis' chapter 4:
//   - tangent predictor  y1 = y_i + ds * v_i                       (eq. 4.8)
//   - first tangent from w = e_x^-1 e_lambda, v = +-(-w, 1)/|(1, w)| (eq. 4.9), sign from
//     the sweep direction; later tangents from [A; v_{i-1}^T] v = [0; 1], normalised (4.10)
//   - Keller corrector: Newton on [e(y) = 0; v_i^T (y - y1) = 0]      (eq. 4.6, 4.12)
//   - step adaptation ds_i = ds_{i-1} * sqrt(N* / N_i), clamped to [min_step, max_step]
//     and to a growth factor of at most 2 per step                   (eq. 4.13)
//   - turning-point fine control: when the lambda component of the tangent changes sign
//     between consecutive points, discard the last `turning_point_backtrack` points and
//     retrace from there at `turning_point_refinement` times the step; a fold already
//     approached with the refined step is accepted (each fold is refined once)
//   - steep-branch cap: when |v_x,i| > alpha |v_x,i-1| the step is capped at
//     steep_branch_step_factor * max_step for the following points   (eq. 4.14)
//   - corners (beyond the thesis): a correction longer than the step is taken across a
//     corner of a piecewise-smooth branch when the tangent lines meet on the branch or the
//     correction shrinks with the step; after four failed corrections from a point, each
//     further try also steps past the kink along the next piece's tangent, oriented by the
//     sign of det [e_y; v^T] (ContinuationSummary::kink_steps)
//   - orientation: every point carries sign det [e_y; v^T], the same on all pieces of a
//     curve; a new point whose tangent, oriented along the travel (v . v_prev > 0), turned by
//     more than about 26 degrees and has the other sign lies past a fold the step jumped:
//     its tangent is reversed (ContinuationSummary::reversed_tangents)
//   - bounds: the curve ends (kLeftBounds) where it leaves [lambda_min, lambda_max]
// All of it works on scaled unknowns y_s = y / scale so that the arclength is well
// conditioned whether displacements are 1e-9 m or 1 m.
//
// Failure is a result, never an exception: the summary says why the curve ended, with the
// last converged point. Not thread-safe per call; distinct calls may run concurrently if the
// problem's evaluate() is thread-safe.
#pragma once

#include <Eigen/Dense>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "frichb/core/support/interrupt.hpp"

namespace frichb::core {

class JacobianOperator;

// An approximate inverse M^-1 of a JacobianOperator's square part e_x (n x n), made once and
// applied to any number of vectors. Immutable after construction, so that one made at an
// earlier point may precondition later systems; solve() may be called concurrently.
class JacobianPreconditioner {
 public:
  virtual ~JacobianPreconditioner() = default;
  // x = M^-1 b (both of size n, unscaled: b in residual units, x in unknown units).
  virtual void solve(const Eigen::Ref<const Eigen::VectorXd>& b,
                     Eigen::Ref<Eigen::VectorXd> x) const = 0;
  // Estimate of M's 1-norm condition number (infinite when M is singular to working precision).
  virtual double condition() const = 0;
  // This preconditioner brought to the operator `op` of a later point at a cost well below a
  // new make_preconditioner() (it may share this one's factors), or null when it cannot follow
  // `op` (the default). What follows and what stays that of the earlier point is the
  // preconditioner's to say (it is meant to approximate `op` better than this one does).
  virtual std::unique_ptr<JacobianPreconditioner> follow(const JacobianOperator& op) const {
    (void)op;
    return nullptr;
  }
};

// The Jacobian [e_x, e_lambda] of one point, applied rather than formed: for problems whose e_x
// has a structure that makes products and an approximate inverse cheap (O(n) to O(n^2) where a
// dense LU is O(n^3)). Immutable once made, unscaled; it owns the point's data it needs and may
// share read-only data with the problem that made it, which must outlive it.
class JacobianOperator {
 public:
  virtual ~JacobianOperator() = default;
  // n, the number of equations.
  virtual Eigen::Index rows() const = 0;
  // y = e_x x for the columns of the n x k block x (y: n x k, not aliasing x).
  virtual void apply(const Eigen::Ref<const Eigen::MatrixXd>& x,
                     Eigen::Ref<Eigen::MatrixXd> y) const = 0;
  // e_x formed into `out` (n x n): by default e_x applied to the identity; an operator whose
  // structure allows it forms the matrix at less cost.
  virtual void form(Eigen::Ref<Eigen::MatrixXd> out) const {
    Eigen::MatrixXd formed(rows(), rows());
    apply(Eigen::MatrixXd::Identity(rows(), rows()), formed);
    out = formed;
  }
  // e_lambda (size n).
  virtual const Eigen::VectorXd& parameter_column() const = 0;
  // An approximation of e_x and its inverse, owning all it needs (it may outlive this object).
  virtual std::unique_ptr<JacobianPreconditioner> make_preconditioner() const = 0;
};

// n equations in n + 1 unknowns; the continuation parameter is the LAST unknown.
class CurveProblem {
 public:
  virtual ~CurveProblem() = default;
  // n, the number of equations (the number of unknowns is n + 1).
  virtual Eigen::Index equation_count() const = 0;
  // Writes residual (size n) and, when `jacobian` is not null, the n x (n + 1) Jacobian
  // [de/dx, de/dlambda] at y (size n + 1), in UNSCALED variables. Returns false when the
  // residual cannot be evaluated at y (then `message` says why); the corrector treats that
  // as a failed step.
  virtual bool evaluate(const Eigen::VectorXd& y, Eigen::VectorXd& residual,
                        Eigen::MatrixXd* jacobian, std::string* message) const = 0;
  // True when evaluate_operator is implemented (LinearSolverKind::kMatrixFree can be used).
  virtual bool has_jacobian_operator() const { return false; }
  // As evaluate, with the Jacobian as an operator instead of a dense matrix.
  virtual bool evaluate_operator(const Eigen::VectorXd& y, Eigen::VectorXd& residual,
                                 std::shared_ptr<const JacobianOperator>* jacobian,
                                 std::string* message) const {
    (void)y;
    (void)residual;
    (void)jacobian;
    if (message != nullptr) *message = "this problem cannot apply its Jacobian as an operator";
    return false;
  }
  // What the problem keeps of an accepted point for its post-processing (stored in
  // ContinuationPoint::record): called once per accepted point, on the tracer's thread, right
  // after the point is accepted, when the problem's last evaluation is normally at y itself. The
  // default keeps nothing (an empty vector); a problem that keeps something must return it only
  // when it belongs to y, since the caller cannot check.
  virtual Eigen::VectorXd point_record(const Eigen::VectorXd& y) const {
    (void)y;
    return {};
  }
};

// The linear solver of the continuation's systems (ContinuationOptions::linear_solver).
enum class LinearSolverKind { kAuto, kDenseLu, kGmres, kMatrixFree };
const char* to_string(LinearSolverKind kind);

struct NewtonOptions {
  int max_iterations = 25;
  // Converged when the scaled residual's infinity norm is <= residual_tolerance AND the
  // scaled Newton update's infinity norm is <= step_tolerance (or the residual is <= 1e-3
  // times residual_tolerance).
  double residual_tolerance = 1e-9;
  double step_tolerance = 1e-9;
  // Damping: an update that increases the residual norm is halved up to this many times.
  int max_line_search_halvings = 6;
  // Also converged when the residual has met residual_tolerance for this many iterations in
  // a row without halving: the floor of a non-smooth residual, where Newton cycles between
  // pieces and its update never shrinks (counted in ContinuationSummary). On the Keller
  // hyperplane only where the residual reversed between iterates (a jump across the curve):
  // a floor where it keeps its direction is the closest the hyperplane comes to a curve that
  // folds back before it, a point off the curve, and the corrector fails there (the step is
  // shortened, or taken past the kink). At fixed lambda (the start point, the landing on
  // lambda_end) any floor within the tolerance is accepted.
  int residual_floor_iterations = 3;
  // Accept a floor within the tolerance on the Keller hyperplane as well, whichever way the
  // residual turns (ChordSolver does: its planes cross the curve between two of its points).
  bool floor_on_hyperplane = false;
  // The stop token of the call (support/interrupt.hpp): a stop requested on it ends a solve
  // unconverged at its next iteration, and a trace (cancelled) at its next step.
  StopToken stop;
};

// How messages write lambda: lambda / per_unit followed by unit ("291.5 Hz" for lambda in
// rad/s with per_unit = 2 pi rad/s per Hz); an empty unit writes "lambda = <value>". per_unit
// is lambda's units per display unit, finite and > 0 (validate_options refuses others).
struct LambdaDisplay {
  double per_unit = 1.0;
  std::string unit;
};

struct ContinuationOptions {
  double lambda_start = 0.0;
  double lambda_end = 1.0;  // the sweep direction is sign(lambda_end - lambda_start)
  // Arclength steps, in scaled units.
  double initial_step = 1e-2;
  double min_step = 1e-6;
  double max_step = 1e-1;
  int target_newton_iterations = 4;  // N* of eq. 4.13
  int max_points = 2000;
  double max_wall_seconds = 600.0;
  // How messages write lambda (LambdaDisplay).
  LambdaDisplay lambda_display;

  bool turning_point_control = true;
  int turning_point_backtrack = 2;
  double turning_point_refinement = 0.1;

  bool steep_branch_control = true;
  double steep_branch_alpha = 30.0;
  double steep_branch_step_factor = 0.1;
  int steep_branch_points = 5;  // how many following points keep the cap

  // Sharp resonances where the advance in lambda is bounded: from a point at lambda moving
  // towards a centre the predictor moves lambda by at most step + growth |lambda - centre|
  // (from a distance d a step ends no nearer than (1 - growth) d - step on the same side, so it
  // cannot jump over the centre from afar and passes it in steps of `step`); moving away from it,
  // by at most step + leaving_growth |lambda - centre|. The tightest band wins. The arclength step
  // is that over |tangent_lambda| (where the curve climbs a peak the arclength goes into the
  // displacements), never below min_step. centre and step in unscaled lambda units.
  struct StepBand {
    double centre = 0.0, step = 0.0, growth = 0.5, leaving_growth = 0.5;
  };
  // The largest advance in lambda the bands allow from `lambda` in `direction` (the sign of
  // the change of lambda; infinite without bands).
  double band_advance(double lambda, double direction) const;
  std::vector<StepBand> step_bands;

  // Scale of each unknown (size n + 1, last entry lambda's); empty means all ones.
  // The scaled unknown is y_i / unknown_scale_i.
  Eigen::VectorXd unknown_scale;
  // Scale of each residual component (size n); empty means all ones.
  Eigen::VectorXd residual_scale;

  NewtonOptions newton;

  // Chord corrector: from this many equations n on (0 = never), each step is first corrected
  // by chord iterations on the factorisation of the last point's Keller matrix, kept from its
  // tangent - one residual evaluation without Jacobian and two triangular solves each, where
  // a Newton iteration evaluates the Jacobian and factorises it (O(n^3)). The full Newton
  // corrector takes over when the residual stops halving or after max_chord_iterations; the
  // step adaptation (eq. 4.13) counts a chord iteration as half a Newton iteration. Converged
  // points solve the same equations to the same tolerances either way.
  Eigen::Index reuse_factorisation_from = 1000;
  int max_chord_iterations = 16;

  // How the Newton and tangent systems are solved (ContinuationSummary::profile says which,
  // and why):
  //   kDenseLu  every matrix is factorised (dense LU): O(n^3) per Newton iteration and per
  //             point's tangent;
  //   kGmres    GMRES on the matrix, right-preconditioned by the LU of an earlier matrix of
  //             the same size, kept while it works: a solve costs a few matrix-vector products
  //             and triangular solves (O(n^2) each). A solve that takes more than
  //             gmres_refresh_iterations iterations has the next matrix factorised afresh; one
  //             that has not converged in gmres_max_iterations is solved by factorising its own
  //             matrix (counted as a fallback; a singular one gives no solution). Its
  //             tolerance: a tangent's true residual |b - A x|_2 is at most
  //             gmres_tolerance |b|_2; a Newton or chord update's at most
  //             gmres_update_tolerance |b|_2 (an inexact Newton step: the corrector's
  //             acceptance tests the evaluated residual, so accepted points meet the same
  //             residual bound either way);
  //   kMatrixFree  GMRES as kGmres, on the problem's JacobianOperator
  //             (CurveProblem::evaluate_operator): e_y is never formed; each product costs
  //             what the operator's structure allows, and the preconditioner is the
  //             operator's own approximate inverse (JacobianPreconditioner), made from an
  //             earlier point's operator, brought to each new point where it can follow it
  //             (JacobianPreconditioner::follow), and kept while solves take at most
  //             gmres_refresh_iterations iterations. A solve that has not converged in
  //             gmres_max_iterations is tried again with the preconditioner of its own point;
  //             if that fails too, the matrix is formed and factorised when it fits in
  //             matrix_free_dense_limit equations (counted as a fallback), else there is no
  //             solution (non-finite entries: the corrector fails with a message). A problem
  //             without an operator is solved by kGmres instead (the profile says so);
  //   kAuto     where the problem has an operator, kMatrixFree from matrix_free_from
  //             equations (the summary's unknowns, lambda excluded) on; without one, kGmres
  //             from gmres_from on; kDenseLu below.
  // Orientation: a point whose tangent's matrix was not factorised inherits its predecessor's
  // sign det [e_y; v^T] unless its tangent turned by more than about 26 degrees, where
  // keep_orientation compares signs: then its matrix is factorised and its own sign is
  // compared, as on the dense path. Limitation: the sign also changes, with a small turn, at
  // a branch point or inside a kink surface; the dense path records the new sign there, the
  // gmres path keeps the old one, so a later comparison past a jumped fold, or a step past a
  // kink, may take the wrong orientation on a curve that passed a branch point. On the
  // matrix_free path the determinant is that of the formed matrix (formed for it, when it fits
  // in matrix_free_dense_limit equations); above that limit a point always inherits.
  LinearSolverKind linear_solver = LinearSolverKind::kAuto;
  Eigen::Index gmres_from = 5000;
  Eigen::Index matrix_free_from = 500;
  double gmres_tolerance = 1e-10;
  double gmres_update_tolerance = 1e-4;
  int gmres_max_iterations = 60;
  int gmres_refresh_iterations = 12;
  Eigen::Index matrix_free_dense_limit = 12000;

  // The curve ends (kLeftBounds) at a corrected point with lambda outside
  // [lambda_min, lambda_max]; that point is not kept. E.g. lambda_min = 0 for a frequency: a
  // curve that walks its branch backwards down to zero frequency stops there with a reason.
  double lambda_min = -std::numeric_limits<double>::infinity();
  double lambda_max = std::numeric_limits<double>::infinity();

  // When the curve passes lambda_end, the last point is corrected onto lambda = lambda_end
  // exactly (a fixed-parameter Newton solve) before stopping.
  bool land_on_end = true;

  // Returns false and says why when an option is out of range.
  bool IsValid(std::string* why) const;
};

// The linear solver `options.linear_solver` resolves to for n equations (lambda excluded) of
// a problem with or without a Jacobian operator (CurveProblem::has_jacobian_operator), never
// kAuto, and why (auto's rule above; kMatrixFree without an operator becomes kGmres).
struct LinearSolverChoice {
  LinearSolverKind kind = LinearSolverKind::kDenseLu;
  std::string reason;
};
LinearSolverChoice choose_linear_solver(const ContinuationOptions& options, Eigen::Index n,
                                        bool has_operator);

// Bytes the linear solver of that choice holds beside the problem itself, for a problem of n
// equations with `components` contact components and `harmonics` complex receptance blocks
// (the harmonic-balance model's m and H + 1; used by kMatrixFree only):
//   kDenseLu, kGmres  the Jacobian, its LU and the bordered Keller matrix, 3 (n + 1)^2 doubles;
//   kMatrixFree       the preconditioner, harmonics m x m single-precision complex LUs (and
//                     one double-precision block while it is built), the GMRES basis and its
//                     preconditioned copy, and, up to matrix_free_dense_limit equations, the
//                     formed matrix with its LU (the orientation's determinant, fallbacks).
double linear_solver_bytes(const ContinuationOptions& options, LinearSolverKind kind,
                           Eigen::Index n, Eigen::Index components, Eigen::Index harmonics);

// Where a solve spent its time (wall seconds, summed): the problem's evaluations (residual
// and Jacobian), the dense LU factorisations of the Newton and tangent matrices with their
// solves and condition estimates, and how many of each. The rest of a solve's wall time is
// the continuation's own bookkeeping (scaling, copies, step control).
struct SolveProfile {
  long evaluations = 0;
  double evaluation_seconds = 0.0;
  long factorisations = 0;
  double factorisation_seconds = 0.0;
  long residual_only_evaluations = 0;  // of the evaluations, those without Jacobian
  // The linear solver used (to_string(LinearSolverKind), never "auto") and why.
  std::string linear_solver;
  std::string linear_solver_reason;
  // kGmres: solves by GMRES, their iterations in total and their wall time (products,
  // preconditioner solves, orthogonalisation; the factorisations are counted above), and the
  // solves that did not converge and were solved by a factorisation of their own matrix.
  long krylov_solves = 0;
  long krylov_iterations = 0;
  double krylov_seconds = 0.0;
  long krylov_fallbacks = 0;
  // kMatrixFree: preconditioners made (JacobianOperator::make_preconditioner) and their wall
  // time, and the matrices formed from an operator (for a fallback or a determinant).
  long preconditioner_builds = 0;
  double preconditioner_seconds = 0.0;
  long formed_matrices = 0;
};

struct ContinuationPoint {
  Eigen::VectorXd y;        // unscaled unknowns, lambda last
  Eigen::VectorXd tangent;  // unit tangent in scaled variables, oriented along the sweep
  int newton_iterations = 0;
  double step = 0.0;               // arclength step that reached this point (scaled)
  double residual_norm = 0.0;      // scaled infinity norm at convergence
  bool at_residual_floor = false;  // converged on the residual alone (NewtonOptions)
  bool passed_corner = false;      // reached across a corner of the branch (trace_curve)
  bool passed_kink = false;        // of those, along the next piece's tangent (kink_steps)
  // Sign of det [e_x e_lambda; tangent^T] (scaled): the curve's orientation, the same on all
  // its pieces between branch points; 0 if unknown. With linear_solver gmres or matrix_free, a
  // point whose matrix was not factorised inherits it from its predecessor
  // (ContinuationOptions::linear_solver).
  int orientation = 0;
  // Estimate of the 1-norm condition number of the Newton matrix at the point, in scaled
  // variables: the bordered Keller matrix [e_x e_lambda; tangent^T] (e_x alone at the start
  // point), from the factorisation that gives the tangent. About log10(condition) of the
  // 16 significant digits are lost in a Newton update there; infinite when singular. With
  // linear_solver gmres, of the kept factorisation the tangent was solved with (that of an
  // earlier point's matrix unless this one was factorised); with matrix_free, of the kept
  // preconditioner (JacobianPreconditioner::condition) unless the matrix was formed.
  double condition = 0.0;
  // CurveProblem::point_record at y (empty when the problem keeps nothing of the point).
  Eigen::VectorXd record;
};

enum class TerminationType {
  kReachedEnd,        // lambda_end reached
  kMaxPoints,         // max_points converged points
  kStepTooSmall,      // corrector kept failing down to min_step
  kStartFailed,       // Newton at lambda_start did not converge
  kEvaluationFailed,  // evaluate() reported failure at the start point
  kTimeLimit,         // max_wall_seconds elapsed
  kLeftBounds,        // a point fell outside [lambda_min, lambda_max] (not kept)
  kCancelled,         // the point callback asked to stop, or a stop on newton.stop (interrupt.hpp)
  kInvalidOptions,
};

const char* to_string(TerminationType t);

struct ContinuationSummary {
  TerminationType termination = TerminationType::kInvalidOptions;
  std::string message;  // human-readable reason, with the last point's lambda
  std::vector<ContinuationPoint> points;
  int rejected_steps = 0;         // corrector failures and steps undone
  int turning_points = 0;         // sign changes of the tangent's lambda component accepted
  int fine_control_restarts = 0;  // times the turning-point control stepped back
  int steep_branch_caps = 0;      // times the steep-branch cap was applied
  int residual_floor_points = 0;  // points accepted at a residual floor (NewtonOptions)
  int corners = 0;            // points reached across a corner of the branch: a correction longer
                              // than the step whose ratio to the step repeated over three halvings
  int kink_steps = 0;         // of them, points reached along the tangent of the piece past a kink
                              // (its Jacobian evaluated beyond the kink) after four failed
                              // corrections from the last point: a corner turning by more than 90
                              // degrees (no solution on the Keller hyperplane ahead), or a cluster
                              // of kinks where Newton cycles between pieces
  int reversed_tangents = 0;  // tangents reversed to keep the orientation (points undone by
                              // the turning-point control included)
  int total_newton_iterations = 0;      // chord iterations included
  int chord_points = 0;                 // points corrected by chord iterations alone
  int chord_iterations = 0;             // chord iterations, those of the fallbacks included
  int chord_fallbacks = 0;              // steps where the chord iterations gave way to full Newton
  double max_condition = 0.0;           // the largest ContinuationPoint::condition
  std::size_t max_condition_point = 0;  // the index of that point
  double wall_seconds = 0.0;
  SolveProfile profile;
  bool reached_end() const { return termination == TerminationType::kReachedEnd; }
};

struct NewtonResult {
  bool converged = false;
  int iterations = 0;
  double residual_norm = 0.0;      // scaled infinity norm at the last iterate
  Eigen::VectorXd y;               // last iterate, unscaled, lambda last
  bool at_residual_floor = false;  // converged on the residual alone (NewtonOptions)
  std::string message;
  SolveProfile profile;
};

// Solves e(x, lambda) = 0 for x at the lambda given in y_guess (last entry, held fixed).
// Scaling as in `options` (unknown_scale / residual_scale of ContinuationOptions).
// A stop requested on options.newton.stop ends the solve unconverged at its next iteration.
NewtonResult solve_fixed_parameter(const CurveProblem& problem, const Eigen::VectorXd& y_guess,
                                   const ContinuationOptions& options);

// Fixed-parameter solves one after another on the same problem (a peak refinement, the
// friction loops of a curve), as solve_fixed_parameter each, sharing what the linear solver
// keeps between solves: on the matrix-free path the preconditioner, built once for all of
// them and rebuilt only where it has become slow (ContinuationOptions::
// gmres_refresh_iterations), rather than once per solve. Holds references: `problem` must
// outlive it. profile() counts every solve so far. Not thread-safe.
class FixedParameterSolver {
 public:
  // Throws std::invalid_argument when the scales of `options` do not fit the problem.
  FixedParameterSolver(const CurveProblem& problem, const ContinuationOptions& options);
  ~FixedParameterSolver();
  FixedParameterSolver(const FixedParameterSolver&) = delete;
  FixedParameterSolver& operator=(const FixedParameterSolver&) = delete;

  // As solve_fixed_parameter(problem, y_guess, options); NewtonResult::profile is empty
  // (the solves are counted in profile()).
  NewtonResult solve(const Eigen::VectorXd& y_guess);
  const SolveProfile& profile() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// A point of a curve between two of its points, and the curve's velocity there
// (ChordSolver).
struct ChordPoint {
  bool converged = false;
  int iterations = 0;
  double residual_norm = 0.0;  // scaled infinity norm at the last iterate
  Eigen::VectorXd y;           // unscaled, lambda last
  Eigen::VectorXd velocity;    // dy/dtheta, unscaled
  Eigen::VectorXd record;      // CurveProblem::point_record at y (converged points)
  std::string message;         // why not, when not converged
};

// Points of a curve e(y) = 0 on the planes across the chord between two of its points a and b
// (unscaled, lambda last): y(theta) solves e(y) = 0 with (y - a - theta (b - a)) . (b - a) = 0
// in the continuation's scaled variables, theta = 0 at a and 1 at b, and its velocity
// dy/dtheta solves [e_y; (b - a)^T] dy/dtheta = [0; |b - a|^2] (scaled). Where the curve
// crosses each plane between a and b once - it does between neighbouring points of a trace,
// at a fold too, since the planes are not planes of constant lambda - theta is a parameter of
// the curve there, as smooth as the curve. Each solve is the continuation's Keller corrector
// (its tolerances and line search) from `guess`, sharing the linear solver's kept state with
// the solves before it as FixedParameterSolver does. A model without equations (n = 0) has
// y(theta) = a + theta (b - a). Holds references: `problem` must outlive it. Not thread-safe.
class ChordSolver {
 public:
  // Throws std::invalid_argument when the scales of `options` do not fit the problem.
  ChordSolver(const CurveProblem& problem, const ContinuationOptions& options);
  ~ChordSolver();
  ChordSolver(const ChordSolver&) = delete;
  ChordSolver& operator=(const ChordSolver&) = delete;

  // y(theta) and its velocity from `guess`; a stop requested on options.newton.stop ends the
  // solve unconverged. a, b and guess have n + 1 entries, a != b (else not converged).
  ChordPoint solve(const Eigen::VectorXd& a, const Eigen::VectorXd& b, double theta,
                   const Eigen::VectorXd& guess);
  // The theta of the plane through y: (y - a) . (b - a) / |b - a|^2, scaled.
  double theta(const Eigen::VectorXd& a, const Eigen::VectorXd& b, const Eigen::VectorXd& y) const;
  // Every solve so far.
  const SolveProfile& profile() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
  Eigen::Index equations_ = 0;
};

// Called after each accepted point with its index in summary.points; return false to stop.
using PointCallback = std::function<bool(const ContinuationPoint&, std::size_t index)>;

// Traces the curve from the solution near y_guess (lambda = y_guess's last entry, which
// should equal options.lambda_start) towards options.lambda_end.
ContinuationSummary trace_curve(const CurveProblem& problem, const Eigen::VectorXd& y_guess,
                                const ContinuationOptions& options,
                                const PointCallback& on_point = {});

}  // namespace frichb::core
