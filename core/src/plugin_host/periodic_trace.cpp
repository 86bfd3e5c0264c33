#include "frichb/core/plugin_host/periodic_trace.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

namespace frichb::core {

namespace {

// Pivots of the rank-revealing decomposition of I - M below this share of the largest are
// taken as zero (a direction the contact never slips in; see run_passes); and a multiplier of
// M (an eigenvalue) above 1 by more than this makes the fixed point repelling.
constexpr double kPeriodicStateRankThreshold = 1e-10;
// A Newton step on the periodic state longer than this many times the trace's scale (the
// largest displacement or state) is not taken.
constexpr double kMaxPeriodicStateStep = 1e3;
// Passes that did not change the state by less than the pass before them (each takes no Newton
// step on the periodic state; see run_passes_from_initial_state) before the passes go on
// without steps.
constexpr int kMaxRefusedPeriodicStateSteps = 8;
// Room for force kinks inside one step (a law reports at most this many).
constexpr std::size_t kMaxKinksPerStep = 8;

// No multiplier of the monodromy M beyond 1: a fixed point the passes are attracted to.
bool attracting(const Eigen::MatrixXd& monodromy) {
  const Eigen::EigenSolver<Eigen::MatrixXd> multipliers(monodromy, false);
  return multipliers.info() == Eigen::Success &&
         multipliers.eigenvalues().cwiseAbs().maxCoeff() <= 1.0 + kPeriodicStateRankThreshold;
}

}  // namespace

PeriodicTracer::PeriodicTracer(const ContactLawInstance& law, const HarmonicLayout& layout,
                               TraceOptions options)
    : law_(law), layout_(layout), options_(options), aft_(layout_) {
  const auto& t = law_.traits();
  for (int a = 0; a < t.tangential_dimensions; ++a) components_.push_back(a);
  if (t.uses_normal) components_.push_back(2);
  state_size_ = t.state_size;
  const int n = layout_.samples(), c = layout_.coefficient_count();
  basis_.resize(n, c);
  for (int j = 0; j < n; ++j)
    for (int k = 0; k < c; ++k) basis_(j, k) = layout_.basis(j, k);
  along_ = options_.along_motion && law_.traces_motion();
  if (along_) {
    const std::size_t rows = kMaxKinksPerStep, inputs = static_cast<std::size_t>(state_size_) + 12;
    kink_report_ = {std::vector<double>(rows),          std::vector<double>(3 * rows),
                    std::vector<double>(rows * inputs), std::vector<double>(3 * rows * inputs),
                    std::vector<double>(3 * rows),      std::vector<double>(rows),
                    std::vector<double>(rows),          std::vector<double>(3 * rows * inputs)};
  }
  // d/ds of the basis (s: the fraction of a sample step, h = 2 pi / N of phase).
  dbasis_ = Eigen::MatrixXd::Zero(n, c);
  const double h = 2 * std::numbers::pi / n;
  for (std::size_t k = 0; k < layout_.harmonics().size(); ++k) {
    const int harmonic = layout_.harmonics()[k];
    if (harmonic == 0) continue;
    for (int j = 0; j < n; ++j) {
      const double phase = harmonic * h * j;
      dbasis_(j, layout_.cos_index(k)) = -harmonic * h * std::sin(phase);
      dbasis_(j, layout_.sin_index(k)) = harmonic * h * std::cos(phase);
    }
  }
  // Force of the unloaded contact in its initial state: the static preload.
  Eigen::VectorXd s0(state_size_), s1(state_size_);
  law_.initial_state(s0.data());
  const double zero[3] = {0, 0, 0};
  std::string error;
  if (!law_.step(s0.data(), zero, zero, reference_force_.data(), s1.data(), nullptr, &error))
    throw PluginError(error);
}

// The kinks a law reported in step j (`count` of them, in kink_report_) appended to `kinks`,
// with their derivatives with respect to the derivative's columns (the unknowns, then any
// others the caller carries in dstate) when `dstate` is carried.
void PeriodicTracer::record_kinks(std::size_t count, int j, const Eigen::MatrixXd* dstate,
                                  KinkList& kinks) const {
  const int n = layout_.samples(), c = layout_.coefficient_count(), d = dimension();
  const int s = state_size_, jp = (j + n - 1) % n;
  const bool derivative = dstate != nullptr;
  const Eigen::Index columns = derivative ? dstate->cols() : 0;
  const auto inputs = static_cast<std::size_t>(s) + 12;
  const KinkReport& report = kink_report_;
  for (std::size_t k = 0; k < std::min(count, kMaxKinksPerStep); ++k) {
    Kink& kink = kinks.append();
    kink.sample = j;
    kink.fraction = report.fraction[k];
    kink.jump.resize(d);
    for (int a = 0; a < d; ++a) kink.jump(a) = report.jump[3 * k + components_[a]];
    kink.onset_power = report.onset_power[k];
    kink.onset_side = report.onset_side[k];
    kink.onset.resize(d);
    for (int a = 0; a < d; ++a)
      kink.onset(a) = kink.onset_power > 0 ? report.onset[3 * k + components_[a]] : 0.0;
    if (derivative) {
      // Chain rule as for the force below, from the step's inputs to the unknowns.
      auto chain = [&](const double* di, auto&& row) {
        row.setZero();
        for (int l = 0; l < s; ++l) row += di[l] * dstate->row(l);
        for (int b = 0; b < d; ++b) {
          const int cb = components_[b];
          row.segment(b * c, c) += di[s + cb] * basis_.row(jp) + di[s + 3 + cb] * basis_.row(j) +
                                   di[s + 6 + cb] * dbasis_.row(jp) +
                                   di[s + 9 + cb] * dbasis_.row(j);
        }
      };
      auto component_row = [&](const std::vector<double>& rows, int a) {
        return rows.data() + (3 * k + static_cast<std::size_t>(components_[a])) * inputs;
      };
      kink.dfraction.resize(columns);
      chain(report.dfraction.data() + k * inputs, kink.dfraction);
      kink.djump.resize(d, columns);
      for (int a = 0; a < d; ++a) chain(component_row(report.djump, a), kink.djump.row(a));
      if (kink.onset_power > 0) {
        kink.donset.resize(d, columns);
        for (int a = 0; a < d; ++a) chain(component_row(report.donset, a), kink.donset.row(a));
      }
    }
  }
}

bool PeriodicTracer::run_period(const ContactTrace& motion, Eigen::VectorXd& state,
                                Eigen::MatrixXd* dstate, Eigen::MatrixXd& force,
                                Eigen::MatrixXd& states, std::vector<SampleRows>* dforce,
                                Eigen::MatrixXd* monodromy, KinkList* kinks, std::string* error) {
  const Eigen::MatrixXd& u = motion.displacement;
  const int n = layout_.samples(), c = layout_.coefficient_count(), d = dimension();
  const int s = state_size_;
  Eigen::VectorXd next(s);
  // Tangent blocks, row-major as the ABI defines them.
  using RowMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  RowMat df_dun(3, 3), df_dup(3, 3), df_ds(3, std::max(s, 1)), ds_dun(std::max(s, 1), 3),
      ds_dup(std::max(s, 1), 3), ds_ds(std::max(s, 1), std::max(s, 1));
  RowMat df_dvp(3, 3), df_dvn(3, 3), ds_dvp(std::max(s, 1), 3), ds_dvn(std::max(s, 1), 3);
  frichb_step_tangents tangents{df_dun.data(), df_dup.data(), df_ds.data(),
                                ds_dun.data(), ds_dup.data(), ds_ds.data()};
  frichb_motion_tangents motion_tangents{df_dvp.data(), df_dvn.data(), ds_dvp.data(),
                                         ds_dvn.data()};
  // A pass that carries only the monodromy asks a law stepping along the motion for the
  // state's own derivative alone (ABI 1.3).
  frichb_step_tangents state_tangent{nullptr, nullptr, nullptr, nullptr, nullptr, ds_ds.data()};
  const bool derivative = dstate != nullptr;
  const bool tangents_wanted = derivative || monodromy != nullptr;
  if (monodromy != nullptr) monodromy->setIdentity(s, s);
  // Kinks of this pass: fraction, jump (3 per kink) and, with the derivative, their
  // derivatives with respect to the step's inputs [state_prev, u_prev, u_now, rate_prev,
  // rate_now] (record_kinks).
  KinkReport& report = kink_report_;
  frichb_force_kinks kink_buffer{sizeof(frichb_force_kinks),
                                 kMaxKinksPerStep,
                                 0,
                                 report.fraction.data(),
                                 report.jump.data(),
                                 derivative ? report.dfraction.data() : nullptr,
                                 derivative ? report.djump.data() : nullptr,
                                 report.onset.data(),
                                 report.onset_power.data(),
                                 report.onset_side.data(),
                                 derivative ? report.donset.data() : nullptr};
  if (kinks != nullptr) kinks->count = 0;
  Eigen::MatrixXd dnext, mnext;
  double u_now[3], u_prev[3], v_now[3], v_prev[3], f[3];
  for (int j = 0; j < n; ++j) {
    const int jp = (j + n - 1) % n;
    for (int a = 0; a < 3; ++a) u_now[a] = u_prev[a] = v_now[a] = v_prev[a] = 0.0;
    for (int a = 0; a < d; ++a) {
      u_now[components_[a]] = u(j, a);
      u_prev[components_[a]] = u(jp, a);
      if (along_) {
        v_now[components_[a]] = motion.rate(j, a);
        v_prev[components_[a]] = motion.rate(jp, a);
      }
    }
    if (tangents_wanted) {
      // A law may write only its nonzero entries: start every step from zero blocks.
      df_dun.setZero();
      df_dup.setZero();
      df_ds.setZero();
      ds_dun.setZero();
      ds_dup.setZero();
      ds_ds.setZero();
      if (along_) {
        df_dvp.setZero();
        df_dvn.setZero();
        ds_dvp.setZero();
        ds_dvn.setZero();
      }
    }
    if (along_) {
      const frichb_step_motion step_motion{sizeof(frichb_step_motion), v_prev, v_now};
      kink_buffer.count = 0;
      std::fill(report.onset_power.begin(), report.onset_power.end(), 0.0);
      const frichb_step_tangents* wanted =
          derivative ? &tangents : (tangents_wanted ? &state_tangent : nullptr);
      if (!law_.step_along(state.data(), u_prev, u_now, step_motion, f, next.data(), wanted,
                           derivative ? &motion_tangents : nullptr,
                           kinks != nullptr ? &kink_buffer : nullptr, error))
        return false;
    } else if (!law_.step(state.data(), u_prev, u_now, f, next.data(),
                          tangents_wanted ? &tangents : nullptr, error)) {
      return false;
    }
    if (kinks != nullptr) record_kinks(kink_buffer.count, j, dstate, *kinks);
    if (monodromy != nullptr) {
      mnext.noalias() = ds_ds.topLeftCorner(s, s).lazyProduct(*monodromy);
      monodromy->swap(mnext);
    }
    for (int a = 0; a < d; ++a) force(j, a) = f[components_[a]];
    if (s > 0) states.row(j) = next.transpose();  // a law without state has no columns
    if (derivative) {
      // Chain rule: u_now depends on U through basis row j, u_prev through row j-1, and the
      // rates (laws that step along the motion) through the basis' derivative rows.
      // lazyProduct: these operands are tiny; the GEMM dispatch of operator* costs more than
      // the arithmetic.
      dnext.noalias() = ds_ds.topLeftCorner(s, s).lazyProduct(*dstate);
      for (int a = 0; a < d; ++a) {
        auto row = (*dforce)[static_cast<std::size_t>(a)].row(j);
        row.noalias() = df_ds.row(components_[a]).head(s).lazyProduct(*dstate);
        for (int b = 0; b < d; ++b) {
          const int ca = components_[a], cb = components_[b];
          row.segment(b * c, c) += df_dun(ca, cb) * basis_.row(j) + df_dup(ca, cb) * basis_.row(jp);
          if (along_)
            row.segment(b * c, c) +=
                df_dvn(ca, cb) * dbasis_.row(j) + df_dvp(ca, cb) * dbasis_.row(jp);
        }
      }
      // The state depends on each used displacement component once (not once per force).
      // Row by row: Eigen's outer products of dynamic blocks cost more than these axpys.
      for (int b = 0; b < d && s > 0; ++b) {
        const int cb = components_[b];
        for (int l = 0; l < s; ++l) {
          auto row = dnext.row(l).segment(b * c, c);
          row += ds_dun(l, cb) * basis_.row(j) + ds_dup(l, cb) * basis_.row(jp);
          if (along_) row += ds_dvn(l, cb) * dbasis_.row(j) + ds_dvp(l, cb) * dbasis_.row(jp);
        }
      }
      dstate->swap(dnext);
    }
    state.swap(next);
  }
  return true;
}

// Passes from the law's initial state until the state (and its derivative, when carried)
// repeats. A law with tangents also gives the monodromy M = d(state at a pass's end) /
// d(state at its start); where a pass did not repeat the state, the fixed point of the
// pass's map is taken by a Newton step, s* = s0 + (I - M)^+ (s1 - s0), and the derivative's by
// the same step, D* = D0 + (I - M)^+ (D1 - D0), D carried through a pass as D1 = M D0 + B. A
// contact that slips for a short part of its period contracts by little per pass (M near I:
// hundreds of plain passes to 1e-11); the Newton steps reach the fixed point in a few. The
// rank-revealing solve leaves alone the directions where I - M vanishes (a direction the
// contact never slips in, where M is the identity), so the state there stays where the
// warm-up put it. A step is only taken while the passes keep shrinking their change, towards
// a fixed point that attracts (no multiplier of M beyond 1), and is checked by the next pass:
// the trace ends, as without steps, on a pass that repeats its start. A pass that does not
// shrink the change takes no step, and the steps resume from the next pass that does (a
// slider whose slow direction contracts by 1 - 5.6e-4 per period while its multiplier rises
// from 0.7 as the state approaches: the first steps fall short, and the direction it slips
// fully in jumps after each); after kMaxRefusedPeriodicStateSteps such passes, plain passes.
bool PeriodicTracer::run_passes_from_initial_state(ContactTrace& out, bool with_derivative,
                                                   std::string* error) {
  const int n = layout_.samples(), p = unknown_count(), s = state_size_;
  Eigen::VectorXd state(s), start(s);
  law_.initial_state(state.data());
  out.force.resize(n, dimension());
  out.state.resize(n, s);
  const double u_scale = std::max(out.displacement.cwiseAbs().maxCoeff(), 1e-300);
  const double tol = options_.relative_tolerance;
  out.passes = 0;
  out.derivative_passes = 0;
  out.newton_passes = 0;
  out.periodic = true;
  out.diagnostic.clear();
  // The derivative is carried through the very passes that produce the value, from the
  // U-independent initial state: the Jacobian is then the derivative of the computed forces
  // even where the warm-up itself depends on U (e.g. a slip to a static offset followed by
  // stick). Passes end when the state and, if carried, its derivative repeat.
  std::vector<SampleRows> dforce;
  Eigen::MatrixXd dstate, dstart, monodromy;
  if (with_derivative) {
    dforce.assign(static_cast<std::size_t>(dimension()), SampleRows::Zero(n, p));
    dstate = Eigen::MatrixXd::Zero(s, p);
  }
  bool newton = options_.newton_on_periodic_state && s > 0 && law_.traits().provides_tangent != 0;
  double change_before = std::numeric_limits<double>::infinity();
  int refused_steps = 0;
  for (;;) {
    start = state;
    if (with_derivative) dstart = dstate;
    // The first pass (the warm-up, which often reaches the periodic state already) runs
    // without the monodromy: the law's tangents cost a value-only pass about as much again.
    const bool track = newton && out.passes > 0;
    if (!run_period(out, state, with_derivative ? &dstate : nullptr, out.force, out.state,
                    with_derivative ? &dforce : nullptr, track ? &monodromy : nullptr,
                    along_ ? &kinks_ : nullptr, error))
      return false;
    ++out.passes;
    const double change = s ? (state - start).cwiseAbs().maxCoeff() : 0.0;
    const double scale = std::max(u_scale, s ? state.cwiseAbs().maxCoeff() : 0.0);
    const double dchange = with_derivative && s ? (dstate - dstart).cwiseAbs().maxCoeff() : 0.0;
    const double dscale = with_derivative && s ? std::max(1.0, dstate.cwiseAbs().maxCoeff()) : 1.0;
    if (change <= tol * scale && dchange <= tol * dscale) break;
    if (out.passes >= options_.max_passes) {
      out.periodic = false;
      // %g, not std::to_string's fixed six decimals (which print 1e-9 as 0.000000).
      auto number = [](double x) {
        char text[32];
        std::snprintf(text, sizeof text, "%.3g", x);
        return std::string(text);
      };
      out.diagnostic =
          "state did not repeat after " + std::to_string(out.passes) +
          " passes (last relative change " + number(change / scale) +
          (with_derivative ? ", of its derivative " + number(dchange / dscale) : std::string()) +
          ", tolerance " + number(tol) + ")";
      break;
    }
    if (!track) continue;
    // A pass that changed the state by no less than the pass before it (after a Newton step:
    // the directions the contact slips fully in follow the step within a pass; a step from a
    // monodromy where the samples switch between stick and slip may overshoot): no step from
    // it, the next pass is compared with it, and after kMaxRefusedPeriodicStateSteps of these
    // plain passes from here on. The state alone is watched: its derivative jumps while the
    // samples settle, and once the state repeats a step gives the derivative's fixed point
    // exactly (M and B no longer change).
    const double relative_change = change / scale;
    if (relative_change > tol && !(relative_change < change_before)) {
      change_before = relative_change;
      if (++refused_steps > kMaxRefusedPeriodicStateSteps) newton = false;
      continue;
    }
    change_before = relative_change;
    // A fixed point where M has a multiplier beyond 1 repels the passes: they would never
    // reach it, so no step goes there (a law whose passes diverge is left to the pass bound).
    if (!attracting(monodromy)) {
      newton = false;
      continue;
    }
    Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> fixed_point;
    fixed_point.setThreshold(kPeriodicStateRankThreshold);
    fixed_point.compute(Eigen::MatrixXd::Identity(s, s) - monodromy);
    const Eigen::VectorXd step = fixed_point.solve(state - start);
    Eigen::MatrixXd dstep;
    if (with_derivative) dstep = fixed_point.solve(dstate - dstart);
    if (!step.allFinite() || step.cwiseAbs().maxCoeff() > kMaxPeriodicStateStep * scale ||
        (with_derivative && !dstep.allFinite())) {
      newton = false;
      continue;
    }
    state = start + step;
    if (with_derivative) dstate = dstart + dstep;
    ++out.newton_passes;
  }
  if (with_derivative) out.derivative_passes = out.passes;
  out.kinks = along_ ? static_cast<int>(kinks_.count) : 0;
  transform_forces(out, with_derivative ? &dforce : nullptr, kinks_);
  return true;
}

bool PeriodicTracer::run_passes(ContactTrace& out, bool with_derivative, std::string* error) {
  if (with_derivative && state_size_ > 0 && law_.traits().provides_tangent != 0 &&
      options_.newton_on_periodic_state) {
    bool settled = false;
    if (!run_passes_to_periodic_derivative(out, settled, error)) return false;
    if (settled) return true;
    const int spent = out.passes;
    if (!run_passes_from_initial_state(out, true, error)) return false;
    out.passes += spent;
    return true;
  }
  return run_passes_from_initial_state(out, with_derivative, error);
}

// Value passes from the law's initial state, with Newton steps on the periodic state as in
// run_passes_from_initial_state, where the pass after the warm-up, every pass after a Newton
// step and every pass after one that repeated its start carry the derivative of the state with
// respect to the unknowns and to the pass's start state: from D0 = [0 | I] the pass ends on
// [B | M] (B the derivative of the pass's map with respect to the unknowns, M its monodromy).
// Where such a pass repeats its start, the periodic state's derivative is the fixed point of
// D -> M D + B, D* = (I - M)^-1 B, and every derivative of the pass (forces, kinks) is that of
// the start [D* | I], its unknowns' columns plus its start-state columns times D*: one pass
// with the derivative instead of the derivative carried through every pass. The pass's forces
// and kinks are moved onto the periodic state's by the same start-state columns. `settled` is
// false, and the caller carries the derivative from the initial state instead, where that
// derivative may depend on the warm-up: a warm-up that left a component of the state at its
// initial value throughout (a contact stuck in that direction from the start, whose periodic
// state then keeps that direction's value: I - M singular there), a periodic state with a
// direction the contact never slips in (I - M singular) or a multiplier beyond 1; and where
// the passes reach options_.max_passes. The first of these is known after the warm-up, before
// any pass with the derivative.
bool PeriodicTracer::run_passes_to_periodic_derivative(ContactTrace& out, bool& settled,
                                                       std::string* error) {
  settled = false;
  const int n = layout_.samples(), p = unknown_count(), s = state_size_, d = dimension();
  Eigen::VectorXd state(s), start(s);
  law_.initial_state(state.data());
  start = state;
  out.force.resize(n, d);
  out.state.resize(n, s);
  out.passes = 0;
  out.derivative_passes = 0;
  out.newton_passes = 0;
  out.periodic = true;
  out.diagnostic.clear();
  KinkList* kinks = along_ ? &kinks_ : nullptr;
  if (!run_period(out, state, nullptr, out.force, out.state, nullptr, nullptr, kinks, error))
    return false;
  out.passes = 1;
  // The caller then traces this same pass again, from the same start, with the derivative: it
  // counts once.
  if (out.state.cols() == 0 ||
      (out.state.rowwise() - start.transpose()).cwiseAbs().colwise().maxCoeff().minCoeff() == 0.0) {
    out.passes = 0;
    return true;
  }
  const double u_scale = std::max(out.displacement.cwiseAbs().maxCoeff(), 1e-300);
  const double tol = options_.relative_tolerance;
  std::vector<SampleRows> dforce(static_cast<std::size_t>(d), SampleRows(n, p + s));
  Eigen::MatrixXd dstate, monodromy;
  bool newton = true, carry = true;
  double change_before = std::numeric_limits<double>::infinity();
  int refused_steps = 0;
  for (;;) {
    start = state;
    if (carry) {
      dstate.setZero(s, p + s);
      dstate.rightCols(s).setIdentity();
    }
    if (!run_period(out, state, carry ? &dstate : nullptr, out.force, out.state,
                    carry ? &dforce : nullptr, !carry && newton ? &monodromy : nullptr, kinks,
                    error))
      return false;
    ++out.passes;
    if (carry) {
      ++out.derivative_passes;
      monodromy = dstate.rightCols(s);
    }
    const double change = (state - start).cwiseAbs().maxCoeff();
    const double scale = std::max(u_scale, state.cwiseAbs().maxCoeff());
    const bool repeated = change <= tol * scale;
    if (repeated && carry) break;
    if (out.passes >= options_.max_passes) return true;
    carry = repeated;
    if (repeated || !newton) continue;
    // The Newton step of run_passes_from_initial_state, on the state alone.
    const double relative_change = change / scale;
    if (!(relative_change < change_before)) {
      change_before = relative_change;
      if (++refused_steps > kMaxRefusedPeriodicStateSteps) newton = false;
      continue;
    }
    if (!attracting(monodromy)) {
      newton = false;
      continue;
    }
    change_before = relative_change;
    Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> fixed_point;
    fixed_point.setThreshold(kPeriodicStateRankThreshold);
    fixed_point.compute(Eigen::MatrixXd::Identity(s, s) - monodromy);
    const Eigen::VectorXd step = fixed_point.solve(state - start);
    if (!step.allFinite() || step.cwiseAbs().maxCoeff() > kMaxPeriodicStateStep * scale) {
      newton = false;
      continue;
    }
    state = start + step;
    ++out.newton_passes;
    carry = true;
  }
  if (!attracting(monodromy)) return true;
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> fixed_point;
  fixed_point.setThreshold(kPeriodicStateRankThreshold);
  fixed_point.compute(Eigen::MatrixXd::Identity(s, s) - monodromy);
  if (fixed_point.rank() < s) return true;
  const Eigen::VectorXd to_periodic = fixed_point.solve(state - start);
  const Eigen::MatrixXd periodic_dstate = fixed_point.solve(dstate.leftCols(p));
  if (!to_periodic.allFinite() || !periodic_dstate.allFinite()) return true;
  // The pass started within the tolerance of the periodic state, not on it: its forces and
  // kinks are moved onto the periodic state's by their derivatives with respect to the start
  // state along the Newton step s* - s0 = (I - M)^-1 (s1 - s0), which leaves them second order
  // in the pass's change from the periodic state's.
  for (int a = 0; a < d; ++a)
    out.force.col(a).noalias() += dforce[static_cast<std::size_t>(a)].rightCols(s) * to_periodic;
  for (std::size_t index = 0; kinks != nullptr && index < kinks->count; ++index) {
    Kink& kink = kinks->items[index];
    kink.fraction =
        std::clamp(kink.fraction + (kink.dfraction.tail(s) * to_periodic).value(), 0.0, 1.0);
    kink.jump.noalias() += kink.djump.rightCols(s) * to_periodic;
    if (kink.onset_power > 0) kink.onset.noalias() += kink.donset.rightCols(s) * to_periodic;
  }
  for (auto& df : dforce) df.leftCols(p).noalias() += df.rightCols(s) * periodic_dstate;
  for (std::size_t index = 0; kinks != nullptr && index < kinks->count; ++index) {
    Kink& kink = kinks->items[index];
    kink.dfraction.head(p).noalias() += kink.dfraction.tail(s) * periodic_dstate;
    kink.djump.leftCols(p).noalias() += kink.djump.rightCols(s) * periodic_dstate;
    if (kink.onset_power > 0)
      kink.donset.leftCols(p).noalias() += kink.donset.rightCols(s) * periodic_dstate;
  }
  settled = true;
  out.kinks = along_ ? static_cast<int>(kinks_.count) : 0;
  transform_forces(out, &dforce, kinks_);
  return true;
}

void PeriodicTracer::transform_forces(ContactTrace& out, const std::vector<SampleRows>* dforce,
                                      const KinkList& kinks) {
  const int n = layout_.samples(), c = layout_.coefficient_count(), d = dimension();
  out.force_coefficients.resize(d * c);
  Eigen::VectorXd column(n);
  for (int a = 0; a < d; ++a) {
    column = out.force.col(a).array() - reference_force_(components_[a]);
    aft_.to_coefficients(column.data(), out.force_coefficients.data() + a * c);
  }
  const int p = unknown_count();
  if (dforce) {
    out.jacobian.resize(p, p);
    Eigen::VectorXd coefficients(c), samples(n);
    for (int a = 0; a < d; ++a) {
      const SampleRows& df = (*dforce)[static_cast<std::size_t>(a)];
      for (int q = 0; q < p; ++q) {
        samples = df.col(q);
        aft_.to_coefficients(samples.data(), coefficients.data());
        out.jacobian.block(a * c, q, c, 1) = coefficients;
      }
    }
  }
  // The trapezoidal rule's error at each kink (see the header). A force F ~ A |s - s*|^p on one
  // side of the kink errs by h A zeta(-p, a) g(theta*) per unit weight, a the distance in steps
  // from the kink to the first sample on that side (after it for a closing, before it for an
  // opening); the coefficients gain its opposite, w_k = 1 / (2 pi) for the mean, 1 / pi else.
  // A jump J of dF/ds is the onset J (s - s*) after the kink (p = 1): -zeta(-1, 1 - sigma) =
  // B2(sigma) / 2, the Euler-Maclaurin term of a derivative jump.
  const double h = 2 * std::numbers::pi / n;
  Eigen::VectorXd g(c), dg(c), weight(c);
  for (int k = 0; k < c; ++k) weight(k) = 1.0 / std::numbers::pi;
  if (layout_.has_static()) weight(0) = 0.5 / std::numbers::pi;
  for (std::size_t index = 0; index < kinks.count; ++index) {
    const Kink& kink = kinks.items[index];
    const double sigma = kink.fraction;
    const double theta = (kink.sample - 1 + sigma) * h;
    g.setZero();
    dg.setZero();
    for (std::size_t q = 0; q < layout_.harmonics().size(); ++q) {
      const int harmonic = layout_.harmonics()[q];
      if (harmonic == 0) {
        g(layout_.cos_index(q)) = 1.0;
        continue;
      }
      g(layout_.cos_index(q)) = std::cos(harmonic * theta);
      g(layout_.sin_index(q)) = std::sin(harmonic * theta);
      dg(layout_.cos_index(q)) = -harmonic * std::sin(harmonic * theta);
      dg(layout_.sin_index(q)) = harmonic * std::cos(harmonic * theta);
    }
    auto subtract_onset = [&](const Eigen::VectorXd& amplitude, const Eigen::MatrixXd& damplitude,
                              double power, bool after) {
      const double distance = after ? 1.0 - sigma : sigma;
      const double zeta = hurwitz_zeta(-power, distance);
      // d zeta(-p, a) / da = p zeta(1 - p, a), its limit a -> 0+ for a kink at the step's end
      // (or start): zeta(0, 0+) = 1/2 where hurwitz_zeta takes zeta(s, 0) = zeta(s, 1).
      const double zeta_below =
          power == 1.0 && distance == 0.0 ? 0.5 : hurwitz_zeta(1.0 - power, distance);
      const double dzeta_dsigma = (after ? -1.0 : 1.0) * power * zeta_below;
      for (int a = 0; a < d; ++a) {
        out.force_coefficients.segment(a * c, c) -=
            h * amplitude(a) * zeta * weight.cwiseProduct(g);
        if (!dforce) continue;
        // d/dU of h A zeta(-p, a(sigma)) g(theta*), theta* = (j - 1 + sigma) h.
        const Eigen::VectorXd along_sigma =
            h * amplitude(a) * weight.cwiseProduct(dzeta_dsigma * g + zeta * h * dg);
        out.jacobian.middleRows(a * c, c) -=
            h * zeta * weight.cwiseProduct(g) * damplitude.row(a).head(p) +
            along_sigma * kink.dfraction.head(p);
      }
    };
    subtract_onset(kink.jump, kink.djump, 1.0, true);
    if (kink.onset_power > 0)
      subtract_onset(kink.onset, kink.donset, kink.onset_power, kink.onset_side > 0);
  }
}

double PeriodicTracer::energy_per_cycle(const Eigen::VectorXd& u_coefficients,
                                        const Eigen::VectorXd& force_coefficients) const {
  const int c = layout_.coefficient_count();
  double energy = 0;
  for (int a = 0; a < dimension(); ++a) {
    for (std::size_t q = 0; q < layout_.harmonics().size(); ++q) {
      const int harmonic = layout_.harmonics()[q];
      if (harmonic == 0) continue;
      const int ic = a * c + layout_.cos_index(q), is = a * c + layout_.sin_index(q);
      energy += harmonic * (force_coefficients(ic) * u_coefficients(is) -
                            force_coefficients(is) * u_coefficients(ic));
    }
  }
  return std::numbers::pi * energy;
}

void PeriodicTracer::sample_motion(const Eigen::VectorXd& u_coefficients, ContactTrace& out) {
  const int n = layout_.samples(), c = layout_.coefficient_count(), d = dimension();
  out.displacement.resize(n, d);
  for (int a = 0; a < d; ++a)
    aft_.to_time(u_coefficients.data() + a * c, out.displacement.col(a).data());
  if (!along_) {
    out.rate.resize(0, 0);
    return;
  }
  out.rate.resize(n, d);
  for (int a = 0; a < d; ++a)
    out.rate.col(a).noalias() = dbasis_ * u_coefficients.segment(a * c, c);
}

bool PeriodicTracer::trace(const Eigen::VectorXd& u_coefficients, JacobianMode mode,
                           ContactTrace& out, std::string* error) {
  sample_motion(u_coefficients, out);
  out.used_finite_differences = false;
  out.energy_per_cycle = 0;
  const bool analytic = mode == JacobianMode::kAnalytic && law_.traits().provides_tangent != 0;
  if (!run_passes(out, analytic, error)) return false;
  out.energy_per_cycle = energy_per_cycle(u_coefficients, out.force_coefficients);
  if (mode == JacobianMode::kNone || analytic) return true;

  // Finite differences local to this contact: central differences on each coefficient.
  out.used_finite_differences = true;
  const int p = unknown_count();
  out.jacobian.resize(p, p);
  const double h = 1e-6 * std::max(u_coefficients.cwiseAbs().maxCoeff(), 1e-12);
  ContactTrace plus, minus;
  Eigen::VectorXd shifted = u_coefficients;
  for (int q = 0; q < p; ++q) {
    for (int sign : {+1, -1}) {
      shifted(q) = u_coefficients(q) + sign * h;
      ContactTrace& t = sign > 0 ? plus : minus;
      sample_motion(shifted, t);
      if (!run_passes(t, false, error)) return false;
    }
    shifted(q) = u_coefficients(q);
    out.jacobian.col(q) = (plus.force_coefficients - minus.force_coefficients) / (2 * h);
  }
  return true;
}

SlipShares slip_shares(const ContactTrace& trace, const std::vector<int>& components) {
  SlipShares shares;
  const Eigen::Index samples = trace.force.rows();
  if (samples == 0) return shares;
  const auto normal = std::find(components.begin(), components.end(), 2);
  const Eigen::Index normal_column =
      normal == components.end() ? -1 : static_cast<Eigen::Index>(normal - components.begin());
  const double tolerance = 1e-9 * trace.displacement.cwiseAbs().maxCoeff();
  for (Eigen::Index j = 0; j < samples; ++j) {
    const Eigen::Index before = (j + samples - 1) % samples;
    if (normal_column >= 0 && trace.force(j, normal_column) <= 0) {
      shares.open += 1;
    } else if (trace.state.cols() == 0 ||
               (trace.state.row(j) - trace.state.row(before)).cwiseAbs().maxCoeff() <= tolerance) {
      shares.stuck += 1;
    } else {
      shares.slipping += 1;
    }
  }
  const auto n = static_cast<double>(samples);
  shares.stuck /= n;
  shares.slipping /= n;
  shares.open /= n;
  return shares;
}

}  // namespace frichb::core
