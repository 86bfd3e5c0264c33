#include "frichb/core/model/stability.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace frichb::core {

namespace {

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// The modal equations dq'' + C dq' + diag(w^2) dq = g(t) over one step of h with g linear
// between its end values g0, g1: [dq; dq'](h) = E [dq; dq'](0) + G0 g0 + G1 g1 (2n x 2n,
// 2n x n, 2n x n; q rows first), exact. From the exponential of the augmented system
// x' = A x + B w1, w1' = w2, w2' = 0 with w1(0) = g0, w2 = (g1 - g0) / h.
struct StepPropagator {
  Eigen::MatrixXd e, g0, g1;
};

StepPropagator propagate_modes(const Eigen::VectorXd& frequencies, const Eigen::MatrixXd& damping,
                               bool diagonal, double h) {
  const Eigen::Index n = frequencies.size();
  StepPropagator p{Eigen::MatrixXd::Zero(2 * n, 2 * n), Eigen::MatrixXd::Zero(2 * n, n),
                   Eigen::MatrixXd::Zero(2 * n, n)};
  // One augmented system of `k` modes (indices `modes`): [A B 0; 0 0 I; 0 0 0] h.
  auto augmented = [&](const std::vector<Eigen::Index>& modes) {
    const auto k = static_cast<Eigen::Index>(modes.size());
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(4 * k, 4 * k);
    for (Eigen::Index i = 0; i < k; ++i) {
      const Eigen::Index r = modes[static_cast<std::size_t>(i)];
      a(i, k + i) = 1.0;
      a(k + i, i) = -frequencies(r) * frequencies(r);
      for (Eigen::Index j = 0; j < k; ++j)
        a(k + i, k + j) = -damping(r, modes[static_cast<std::size_t>(j)]);
      a(k + i, 2 * k + i) = 1.0;  // B: the modal force drives the acceleration
      a(2 * k + i, 3 * k + i) = 1.0;
    }
    const Eigen::MatrixXd x = matrix_exponential(a * h);
    for (Eigen::Index i = 0; i < k; ++i)
      for (int half = 0; half < 2; ++half) {
        const Eigen::Index row = half * n + modes[static_cast<std::size_t>(i)];
        for (Eigen::Index j = 0; j < k; ++j) {
          const Eigen::Index col = modes[static_cast<std::size_t>(j)];
          p.e(row, col) = x(half * k + i, j);
          p.e(row, n + col) = x(half * k + i, k + j);
          const double s1 = x(half * k + i, 2 * k + j), s2 = x(half * k + i, 3 * k + j);
          p.g0(row, col) = s1 - s2 / h;
          p.g1(row, col) = s2 / h;
        }
      }
  };
  if (diagonal) {
    for (Eigen::Index r = 0; r < n; ++r) augmented({r});
  } else {
    std::vector<Eigen::Index> all(static_cast<std::size_t>(n));
    for (Eigen::Index r = 0; r < n; ++r) all[static_cast<std::size_t>(r)] = r;
    augmented(all);
  }
  return p;
}

// One contact's tangents of one step, restricted to its used components (d x d, d x S, ...).
struct StepTangents {
  RowMajor df_dun, df_dup, df_dz, dz_dun, dz_dup, dz_dz, df_drn, df_drp, dz_drn, dz_drp;
};

// One step of a contact's law from `state_prev` at u_prev to u_now (local frame, 3 each; the
// rates du/ds at both ends are read by laws that step along the motion only): its tangents
// restricted to the used components into t, its state after the step into state_now.
bool law_step(const ContactModel& contact, const Eigen::VectorXd& state_prev, const double* u_prev,
              const double* u_now, const double* r_prev, const double* r_now, StepTangents& t,
              Eigen::VectorXd& state_now, std::string* error) {
  const ContactLawInstance& law = *contact.law;
  const auto& components = contact.tracer->components();
  const auto d = static_cast<Eigen::Index>(components.size());
  const int s = law.traits().state_size;
  const int sd = std::max(s, 1);
  RowMajor fun = RowMajor::Zero(3, 3), fup = RowMajor::Zero(3, 3), fz = RowMajor::Zero(3, sd),
           zun = RowMajor::Zero(sd, 3), zup = RowMajor::Zero(sd, 3), zz = RowMajor::Zero(sd, sd),
           frp = RowMajor::Zero(3, 3), frn = RowMajor::Zero(3, 3), zrp = RowMajor::Zero(sd, 3),
           zrn = RowMajor::Zero(sd, 3);
  frichb_step_tangents tangents{fun.data(), fup.data(), fz.data(),
                                zun.data(), zup.data(), zz.data()};
  frichb_motion_tangents motion_tangents{frp.data(), frn.data(), zrp.data(), zrn.data()};
  state_now.resize(s);
  double force[3];
  const bool ok =
      contact.tracer->along_motion()
          ? law.step_along(state_prev.data(), u_prev, u_now,
                           frichb_step_motion{sizeof(frichb_step_motion), r_prev, r_now}, force,
                           state_now.data(), &tangents, &motion_tangents, nullptr, error)
          : law.step(state_prev.data(), u_prev, u_now, force, state_now.data(), &tangents, error);
  if (!ok) return false;
  auto pick = [&](const RowMajor& m, bool rows_used, bool cols_used) {
    const Eigen::Index rows = rows_used ? d : s, cols = cols_used ? d : s;
    RowMajor out(rows, cols);
    for (Eigen::Index r = 0; r < rows; ++r)
      for (Eigen::Index c = 0; c < cols; ++c)
        out(r, c) = m(rows_used ? components[static_cast<std::size_t>(r)] : r,
                      cols_used ? components[static_cast<std::size_t>(c)] : c);
    return out;
  };
  t.df_dun = pick(fun, true, true);
  t.df_dup = pick(fup, true, true);
  t.df_dz = pick(fz, true, false);
  t.dz_dun = pick(zun, false, true);
  t.dz_dup = pick(zup, false, true);
  t.dz_dz = pick(zz, false, false);
  t.df_drn = pick(frn, true, true);
  t.df_drp = pick(frp, true, true);
  t.dz_drn = pick(zrn, false, true);
  t.dz_drp = pick(zrp, false, true);
  return true;
}

// The same step, value only: the state after it.
bool law_state_step(const ContactModel& contact, const Eigen::VectorXd& state_prev,
                    const double* u_prev, const double* u_now, const double* r_prev,
                    const double* r_now, Eigen::VectorXd& state_now, std::string* error) {
  const ContactLawInstance& law = *contact.law;
  state_now.resize(law.traits().state_size);
  double force[3];
  return contact.tracer->along_motion()
             ? law.step_along(state_prev.data(), u_prev, u_now,
                              frichb_step_motion{sizeof(frichb_step_motion), r_prev, r_now}, force,
                              state_now.data(), nullptr, nullptr, nullptr, error)
             : law.step(state_prev.data(), u_prev, u_now, force, state_now.data(), nullptr, error);
}

// The traced state after sample j (empty for a law without state, whose rows have no entries).
Eigen::VectorXd traced_state(const ContactTrace& trace, int j) {
  if (trace.state.cols() == 0) return {};
  return trace.state.row(j).transpose();
}

// The tangents of step j of a contact's trace (from sample j - 1 to j, at its periodic state).
bool contact_step_tangents(const ContactModel& contact, const ContactTrace& trace, int j,
                           StepTangents& t, std::string* error) {
  const auto& components = contact.tracer->components();
  const int n = static_cast<int>(trace.displacement.rows());
  const int jp = (j + n - 1) % n;
  double u_now[3] = {0, 0, 0}, u_prev[3] = {0, 0, 0}, r_now[3] = {0, 0, 0}, r_prev[3] = {0, 0, 0};
  const bool along = contact.tracer->along_motion();
  for (std::size_t a = 0; a < components.size(); ++a) {
    const int c = components[a];
    const auto col = static_cast<Eigen::Index>(a);
    u_now[c] = trace.displacement(j, col);
    u_prev[c] = trace.displacement(jp, col);
    if (along) {
      r_now[c] = trace.rate(j, col);
      r_prev[c] = trace.rate(jp, col);
    }
  }
  const Eigen::VectorXd state_prev = traced_state(trace, jp);
  Eigen::VectorXd state_now;
  return law_step(contact, state_prev, u_prev, u_now, r_prev, r_now, t, state_now, error);
}

// A contact's relative displacement along the period from its harmonic coefficients (the
// harmonic balance unknowns): u and du/dphi at any phase phi (rad), local frame.
class ContactPath {
 public:
  ContactPath(const HarmonicLayout& layout, const Eigen::VectorXd& y, const ContactModel& contact)
      : layout_(layout), components_(contact.tracer->components()) {
    const Eigen::Index c = layout.coefficient_count();
    coefficients_ = y.segment(static_cast<Eigen::Index>(contact.offset) * c,
                              c * static_cast<Eigen::Index>(components_.size()));
  }
  void at(double phi, double* u, double* du) const {
    const Eigen::Index c = layout_.coefficient_count();
    const auto& harmonics = layout_.harmonics();
    // cos(n phi) and sin(n phi) by rotation from n = 0 to the highest harmonic.
    const auto highest = static_cast<std::size_t>(layout_.max_harmonic());
    cos_.resize(highest + 1);
    sin_.resize(highest + 1);
    const double c1 = std::cos(phi), s1 = std::sin(phi);
    cos_[0] = 1.0;
    sin_[0] = 0.0;
    for (std::size_t n = 1; n <= highest; ++n) {
      cos_[n] = cos_[n - 1] * c1 - sin_[n - 1] * s1;
      sin_[n] = sin_[n - 1] * c1 + cos_[n - 1] * s1;
    }
    for (int a = 0; a < 3; ++a) u[a] = du[a] = 0.0;
    for (std::size_t a = 0; a < components_.size(); ++a) {
      const double* x = coefficients_.data() + static_cast<Eigen::Index>(a) * c;
      double value = 0.0, rate = 0.0;
      for (std::size_t k = 0; k < harmonics.size(); ++k) {
        const double ac = x[layout_.cos_index(k)];
        if (harmonics[k] == 0) {
          value += ac;
          continue;
        }
        const auto n = static_cast<std::size_t>(harmonics[k]);
        const double as = x[layout_.sin_index(k)], cs = cos_[n], sn = sin_[n];
        value += ac * cs + as * sn;
        rate += static_cast<double>(n) * (as * cs - ac * sn);
      }
      u[components_[a]] = value;
      du[components_[a]] = rate;
    }
  }

 private:
  const HarmonicLayout& layout_;
  const std::vector<int>& components_;
  Eigen::VectorXd coefficients_;
  mutable std::vector<double> cos_, sin_;  // scratch of at()
};

// The largest entry of |a - b| relative to `scale` (0 when the scale is 0).
double relative_change(const RowMajor& a, const RowMajor& b, double scale) {
  return scale > 0 ? (a - b).cwiseAbs().maxCoeff() / scale : 0.0;
}

// A law switches regime inside a step (sticks, slips, opens, closes) where its tangent
// d force / d u_now changes by more than this fraction of its largest over the period (a
// smooth law's tangent changes by a few percent of it from one step to the next).
constexpr double kRegimeChange = 0.25;
// Straight sub-steps that follow the motion to a point inside a step, the bisections that
// locate a switch, and the short steps (fractions of a step) that probe the regime at a point
// and carry the switch itself.
constexpr int kPathSteps = 4;
constexpr int kBisections = 12;
constexpr double kProbe = 1e-7;
constexpr double kSwitchStep = 5e-4;

// Multipliers of `w` split as the header says: the `dropped` smallest (force samples), the
// `neutral` nearest 1, the rest largest first.
void classify(const Eigen::MatrixXd& w, Eigen::Index dropped, int neutral,
              FloquetMultipliers& out) {
  Eigen::EigenSolver<Eigen::MatrixXd> solver(w, false);
  std::vector<std::complex<double>> all(solver.eigenvalues().begin(), solver.eigenvalues().end());
  std::sort(all.begin(), all.end(),
            [](const auto& a, const auto& b) { return std::abs(a) < std::abs(b); });
  all.erase(all.begin(), all.begin() + std::min<std::ptrdiff_t>(dropped, std::ssize(all)));
  for (int k = 0; k < neutral && !all.empty(); ++k) {
    const auto nearest = std::min_element(all.begin(), all.end(), [](const auto& a, const auto& b) {
      return std::abs(a - 1.0) < std::abs(b - 1.0);
    });
    out.neutral.push_back(*nearest);
    all.erase(nearest);
  }
  std::sort(all.begin(), all.end(),
            [](const auto& a, const auto& b) { return std::abs(a) > std::abs(b); });
  out.multipliers = std::move(all);
  out.largest_modulus = out.multipliers.empty() ? 0.0 : std::abs(out.multipliers.front());
  for (const auto& mu : out.multipliers)
    if (std::abs(mu) > 1.0) {
      ++out.unstable_count;
      out.nearest_unstable = mu;  // largest first: the last one outside is the nearest
    }
}

}  // namespace

Eigen::MatrixXd matrix_exponential(const Eigen::MatrixXd& a) {
  const Eigen::Index n = a.rows();
  const double norm = a.cwiseAbs().rowwise().sum().maxCoeff();
  const int squarings = norm > 0.5 ? static_cast<int>(std::ceil(std::log2(norm / 0.5))) : 0;
  const Eigen::MatrixXd x = a / std::ldexp(1.0, squarings);
  constexpr int q = 6;
  double c = 0.5;
  const Eigen::MatrixXd identity = Eigen::MatrixXd::Identity(n, n);
  Eigen::MatrixXd numerator = identity + c * x, denominator = identity - c * x, power = x;
  for (int k = 2; k <= q; ++k) {
    c *= static_cast<double>(q - k + 1) / static_cast<double>(k * (2 * q - k + 1));
    power = x * power;
    numerator += c * power;
    denominator += (k % 2 == 0 ? c : -c) * power;
  }
  Eigen::MatrixXd e = denominator.partialPivLu().solve(numerator);
  for (int k = 0; k < squarings; ++k) e = e * e;
  return e;
}

FloquetMultipliers floquet_multipliers(const HarmonicBalanceModel& model,
                                       const Eigen::VectorXd& y) {
  FloquetMultipliers out;
  const auto& layout = model.layout();
  const auto& forms = model.receptance_forms();
  for (const auto& form : forms)
    if (form.harmonic_index != 0 || form.residual_flexibility) {
      out.failure = "stability is computed for a plain structure without residual flexibility only";
      return out;
    }
  const auto& basis = model.structure().basis(0);
  if (basis.rows.imag().cwiseAbs().maxCoeff() > 0) {
    out.failure = "stability needs real modes";
    return out;
  }
  const Eigen::Index modes = basis.rows.cols();
  const Eigen::Index m = model.component_count(), n2 = 2 * modes;
  // P = G Phi: contact components x modes.
  const Eigen::MatrixXd p =
      Eigen::MatrixXd(Eigen::MatrixXcd(model.gather(0)).real()) * basis.rows.real();
  const double w = y(y.size() - 1);

  // The contacts' traces at y, their state offsets and the tracing grid.
  const auto& contacts = model.contacts();
  std::vector<ContactTrace> traces(contacts.size());
  std::vector<Eigen::Index> state_offset(contacts.size());
  Eigen::Index states = 0;
  int samples = 0;
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    std::string error;
    if (!model.trace_contact(c, y, traces[c], &error)) {
      out.failure = "contact " + contacts[c].name + ": " + error;
      return out;
    }
    if (!contacts[c].law->traits().provides_tangent) {
      out.failure = "contact " + contacts[c].name + ": its law gives no tangents";
      return out;
    }
    state_offset[c] = states;
    states += contacts[c].law->traits().state_size;
    samples = static_cast<int>(traces[c].displacement.rows());
  }
  if (samples == 0) samples = layout.samples();
  const double h = 2 * std::numbers::pi / w / samples;
  out.steps = samples;

  const StepPropagator full_step =
      propagate_modes(basis.frequencies, basis.damping, basis.diagonal_damping, h);
  const Eigen::Index dim = n2 + m + states;
  Eigen::MatrixXd monodromy = Eigen::MatrixXd::Identity(dim, dim);
  std::vector<Eigen::MatrixXd> own(contacts.size());  // each contact's state monodromy
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const int s = contacts[c].law->traits().state_size;
    own[c] = Eigen::MatrixXd::Identity(s, s);
  }
  Eigen::MatrixXd k1(m, n2), k0(m, n2), kz(m, states), z1(states, n2), z0(states, n2),
      zz(states, states);
  // The variational map over a fraction `length` of a step, the contacts' tangents `t`.
  auto advance = [&](double length, const std::vector<StepTangents>& t) {
    const StepPropagator sub = length == 1.0 ? StepPropagator{}
                                             : propagate_modes(basis.frequencies, basis.damping,
                                                               basis.diagonal_damping, length * h);
    const StepPropagator& prop = length == 1.0 ? full_step : sub;
    const Eigen::MatrixXd gamma0 = -prop.g0 * p.transpose(), gamma1 = -prop.g1 * p.transpose();
    const double hl = length * h;
    k1.setZero();
    k0.setZero();
    kz.setZero();
    z1.setZero();
    z0.setZero();
    zz.setZero();
    for (std::size_t c = 0; c < contacts.size(); ++c) {
      const StepTangents& tc = t[c];
      const Eigen::Index r = contacts[c].offset, d = tc.df_dun.rows(), zo = state_offset[c],
                         s = tc.dz_dz.rows();
      const auto pc = p.middleRows(r, d);
      // u = P q and the rates du/ds = hl P q' at the step's ends.
      k1.block(r, 0, d, modes) = tc.df_dun * pc;
      k1.block(r, modes, d, modes) = hl * tc.df_drn * pc;
      k0.block(r, 0, d, modes) = tc.df_dup * pc;
      k0.block(r, modes, d, modes) = hl * tc.df_drp * pc;
      kz.block(r, zo, d, s) = tc.df_dz;
      z1.block(zo, 0, s, modes) = tc.dz_dun * pc;
      z1.block(zo, modes, s, modes) = hl * tc.dz_drn * pc;
      z0.block(zo, 0, s, modes) = tc.dz_dup * pc;
      z0.block(zo, modes, s, modes) = hl * tc.dz_drp * pc;
      zz.block(zo, zo, s, s) = tc.dz_dz;
      own[c] = tc.dz_dz * own[c];
    }
    const auto x = monodromy.topRows(n2);
    const auto f = monodromy.middleRows(n2, m);
    const auto z = monodromy.bottomRows(states);
    const Eigen::MatrixXd predicted = prop.e * x + gamma0 * f;
    const Eigen::MatrixXd rhs = k1 * predicted + k0 * x + kz * z;
    const Eigen::MatrixXd system = Eigen::MatrixXd::Identity(m, m) - k1 * gamma1;
    const Eigen::MatrixXd f_next = system.partialPivLu().solve(rhs);
    const Eigen::MatrixXd x_next = predicted + gamma1 * f_next;
    const Eigen::MatrixXd z_next = z1 * x_next + z0 * x + zz * z;
    monodromy << x_next, f_next, z_next;
  };

  // The tangents of every step at the traced states.
  std::vector<std::vector<StepTangents>> steps(static_cast<std::size_t>(samples),
                                               std::vector<StepTangents>(contacts.size()));
  for (int j = 0; j < samples; ++j)
    for (std::size_t c = 0; c < contacts.size(); ++c) {
      std::string error;
      if (!contact_step_tangents(contacts[c], traces[c], j, steps[static_cast<std::size_t>(j)][c],
                                 &error)) {
        out.failure = "contact " + contacts[c].name + ": " + error;
        return out;
      }
    }

  // A law that switches regime inside a step makes the force's linearisation jump there (a
  // contact that starts to slip loses its stiffness at once), which a straight line between
  // the step's samples smears over the step: an error of the order of the step, not its
  // square. Such steps are split where the law switches: located by bisection on the regime at
  // a point (the tangent of a short step from it, the law's state followed along the motion
  // from the step's start), and crossed by a short step of its own.
  std::vector<ContactPath> paths;
  paths.reserve(contacts.size());
  for (const auto& contact : contacts) paths.emplace_back(layout, y, contact);
  const double phase_step = 2 * std::numbers::pi / samples;
  struct Motion {
    double u[3], rate[3];  // rate: du/ds over a sub-step of fraction `length`
  };
  auto motion_at = [&](std::size_t c, int jp, double s, double length) {
    Motion mo{};
    paths[c].at(phase_step * jp + phase_step * s, mo.u, mo.rate);
    for (double& r : mo.rate) r *= phase_step * length;
    return mo;
  };
  // The law's state at fraction s of step j (from sample jp), followed along the motion from
  // its state `state` at fraction `from` (value-only steps).
  auto follow = [&](std::size_t c, int jp, double from, double s, Eigen::VectorXd& state,
                    std::string* error) {
    Eigen::VectorXd next;
    for (int i = 0; i < kPathSteps; ++i) {
      const double a = from + (s - from) * i / kPathSteps,
                   b = from + (s - from) * (i + 1) / kPathSteps;
      const Motion m0 = motion_at(c, jp, a, b - a), m1 = motion_at(c, jp, b, b - a);
      if (!law_state_step(contacts[c], state, m0.u, m1.u, m0.rate, m1.rate, next, error))
        return false;
      state = next;
    }
    return true;
  };
  // The regime at fraction s, the law's state there `state`: d force / d u_now of a short step.
  auto regime_at = [&](std::size_t c, int jp, double s, const Eigen::VectorXd& state,
                       RowMajor& regime, std::string* error) {
    Eigen::VectorXd next;
    StepTangents t;
    const Motion m0 = motion_at(c, jp, s, kProbe), m1 = motion_at(c, jp, s + kProbe, kProbe);
    if (!law_step(contacts[c], state, m0.u, m1.u, m0.rate, m1.rate, t, next, error)) return false;
    regime = t.df_dun;
    return true;
  };
  // Each contact's largest tangent over the period: the scale of a switch.
  std::vector<double> tangent_scale(contacts.size(), 0.0);
  for (const auto& step_tangents : steps)
    for (std::size_t c = 0; c < contacts.size(); ++c)
      tangent_scale[c] = std::max(tangent_scale[c], step_tangents[c].df_dun.cwiseAbs().maxCoeff());
  // Where contact c switches inside step j, or -1.
  auto locate_switch = [&](std::size_t c, int j, double& where, std::string* error) {
    where = -1.0;
    const int jp = (j + samples - 1) % samples;
    const double scale = tangent_scale[c];
    const auto& now = steps[static_cast<std::size_t>(j)][c].df_dun;
    const auto& before = steps[static_cast<std::size_t>(jp)][c].df_dun;
    const auto& after = steps[static_cast<std::size_t>((j + 1) % samples)][c].df_dun;
    if (relative_change(now, before, scale) <= kRegimeChange &&
        relative_change(now, after, scale) <= kRegimeChange)
      return true;
    const Eigen::VectorXd traced = traced_state(traces[c], jp);
    Eigen::VectorXd at_end = traced, at_lo = traced;
    RowMajor start, end, middle;
    if (!regime_at(c, jp, 0.0, traced, start, error) || !follow(c, jp, 0.0, 1.0, at_end, error) ||
        !regime_at(c, jp, 1.0, at_end, end, error))
      return false;
    if (relative_change(start, end, scale) <= kRegimeChange) return true;
    double lo = 0.0, hi = 1.0;
    for (int i = 0; i < kBisections; ++i) {
      const double mid = 0.5 * (lo + hi);
      Eigen::VectorXd at_mid = at_lo;
      if (!follow(c, jp, lo, mid, at_mid, error) || !regime_at(c, jp, mid, at_mid, middle, error))
        return false;
      if ((middle - start).cwiseAbs().maxCoeff() <= (middle - end).cwiseAbs().maxCoeff()) {
        lo = mid;
        at_lo = at_mid;
      } else {
        hi = mid;
      }
    }
    where = lo;
    return true;
  };

  std::vector<StepTangents> sub_tangents(contacts.size());
  std::vector<Eigen::VectorXd> sub_states(contacts.size());
  for (int step = 1; step <= samples; ++step) {
    const int j = step % samples, jp = step - 1;
    std::vector<double> cuts;
    for (std::size_t c = 0; c < contacts.size(); ++c) {
      std::string error;
      double where = -1.0;
      if (!locate_switch(c, j, where, &error)) {
        out.failure = "contact " + contacts[c].name + ": " + error;
        return out;
      }
      if (where < 0) continue;
      if (where > kSwitchStep) cuts.push_back(where);
      if (where + kSwitchStep < 1.0 - kSwitchStep) cuts.push_back(where + kSwitchStep);
    }
    if (cuts.empty()) {
      advance(1.0, steps[static_cast<std::size_t>(j)]);
      continue;
    }
    ++out.split_steps;
    std::sort(cuts.begin(), cuts.end());
    cuts.push_back(1.0);
    for (std::size_t c = 0; c < contacts.size(); ++c) sub_states[c] = traced_state(traces[c], jp);
    double a = 0.0;
    for (const double b : cuts) {
      if (b - a <= 0.0) continue;
      for (std::size_t c = 0; c < contacts.size(); ++c) {
        std::string error;
        const Motion from = motion_at(c, jp, a, b - a), to = motion_at(c, jp, b, b - a);
        Eigen::VectorXd next;
        if (!law_step(contacts[c], sub_states[c], from.u, to.u, from.rate, to.rate, sub_tangents[c],
                      next, &error)) {
          out.failure = "contact " + contacts[c].name + ": " + error;
          return out;
        }
        sub_states[c] = next;
      }
      advance(b - a, sub_tangents);
      a = b;
    }
  }
  if (!monodromy.allFinite()) {
    out.failure = "the monodromy matrix is not finite";
    return out;
  }
  int neutral = 0;
  for (const auto& mc : own) {
    if (mc.size() == 0) continue;
    const Eigen::VectorXcd mu = mc.eigenvalues();
    for (Eigen::Index k = 0; k < mu.size(); ++k)
      if (std::abs(mu(k) - 1.0) <= kNeutralTolerance) ++neutral;
  }
  classify(monodromy, m, neutral, out);
  return out;
}

}  // namespace frichb::core
