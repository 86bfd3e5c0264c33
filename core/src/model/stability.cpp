#include "frichb/core/model/stability.hpp"

#include "model/variational_structure.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>

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

// Balances `a` in place by a diagonal similarity a <- D^-1 a D (powers of 2, so exact), with
// D returned in `scale`: the rows and columns of each index brought to comparable norms
// (Parlett and Reinsch). The monodromy mixes modal displacements, velocities, forces and slider
// offsets whose scales differ by many orders; unbalanced, the rounding of its Schur form
// splits a double multiplier (a cyclic disk's standing pair) by 1e-6.
void balance(Eigen::MatrixXd& a, Eigen::VectorXd& scale) {
  constexpr double radix = 2.0;
  const Eigen::Index n = a.rows();
  scale = Eigen::VectorXd::Ones(n);
  for (bool done = false; !done;) {
    done = true;
    for (Eigen::Index i = 0; i < n; ++i) {
      double c = a.col(i).cwiseAbs().sum() - std::abs(a(i, i));
      double r = a.row(i).cwiseAbs().sum() - std::abs(a(i, i));
      if (c == 0.0 || r == 0.0) continue;
      const double total = c + r;
      double f = 1.0;
      while (c < r / radix) {
        f *= radix;
        c *= radix * radix;
      }
      while (c > r * radix) {
        f /= radix;
        c /= radix * radix;
      }
      if ((c + r) / f < 0.95 * total) {
        done = false;
        scale(i) *= f;
        a.row(i) /= f;
        a.col(i) *= f;
      }
    }
  }
}

// Multipliers of `w` split as the header says: the `dropped` smallest (force samples), the
// `neutral` nearest 1, the rest largest first. With `nodal_diameter` (per mode, cyclic), each
// multiplier's nodal diameter: the one holding most of its Floquet mode's modal energy
// (w^2 |dq|^2 + |dq'|^2 over the modes of that diameter; the first 2 x modes rows of w).
void classify(const Eigen::MatrixXd& w, Eigen::Index dropped, int neutral,
              const VariationalStructure& vs, FloquetMultipliers& out) {
  const bool cyclic = !vs.nodal_diameter.empty();
  Eigen::MatrixXd balanced = w;
  Eigen::VectorXd scale;
  balance(balanced, scale);
  Eigen::EigenSolver<Eigen::MatrixXd> solver(balanced, cyclic);
  struct Multiplier {
    std::complex<double> value;
    int nodal_diameter = -1;
  };
  std::vector<Multiplier> all;
  const Eigen::Index modes = vs.frequencies.size();
  const int diameters =
      cyclic ? *std::max_element(vs.nodal_diameter.begin(), vs.nodal_diameter.end()) + 1 : 0;
  // The eigenvectors once (each call of EigenSolver::eigenvectors() forms all of them).
  const Eigen::MatrixXcd vectors =
      cyclic ? Eigen::MatrixXcd(solver.eigenvectors()) : Eigen::MatrixXcd();
  for (Eigen::Index k = 0; k < w.rows(); ++k) {
    Multiplier mu{solver.eigenvalues()(k), -1};
    if (cyclic) {
      const Eigen::VectorXcd v = scale.asDiagonal() * vectors.col(k);
      std::vector<double> energy(static_cast<std::size_t>(diameters), 0.0);
      for (Eigen::Index r = 0; r < modes; ++r)
        energy[static_cast<std::size_t>(vs.nodal_diameter[static_cast<std::size_t>(r)])] +=
            std::norm(vs.frequencies(r) * v(r)) + std::norm(v(modes + r));
      mu.nodal_diameter =
          static_cast<int>(std::max_element(energy.begin(), energy.end()) - energy.begin());
    }
    all.push_back(mu);
  }
  auto by_modulus = [](const Multiplier& a, const Multiplier& b) {
    return std::abs(a.value) < std::abs(b.value);
  };
  std::sort(all.begin(), all.end(), by_modulus);
  all.erase(all.begin(), all.begin() + std::min<std::ptrdiff_t>(dropped, std::ssize(all)));
  for (int k = 0; k < neutral && !all.empty(); ++k) {
    const auto nearest = std::min_element(all.begin(), all.end(), [](const auto& a, const auto& b) {
      return std::abs(a.value - 1.0) < std::abs(b.value - 1.0);
    });
    out.neutral.push_back(nearest->value);
    all.erase(nearest);
  }
  std::sort(all.rbegin(), all.rend(), by_modulus);
  for (const auto& mu : all) {
    out.multipliers.push_back(mu.value);
    if (cyclic) out.nodal_diameters.push_back(mu.nodal_diameter);
  }
  out.largest_modulus = out.multipliers.empty() ? 0.0 : std::abs(out.multipliers.front());
  for (const auto& mu : all)
    if (std::abs(mu.value) > 1.0) {
      ++out.unstable_count;
      out.nearest_unstable = mu.value;  // largest first: the last one outside is the nearest
      out.nearest_unstable_nodal_diameter = mu.nodal_diameter;
    }
}

// The relative displacement of the model's contacts along the period from their harmonic
// coefficients, on the tracing grid's phases: at fraction s of the step from sample jp, and
// its rate du/ds over a sub-step of fraction `length`.
class ContactMotions {
 public:
  struct Motion {
    double u[3], rate[3];
  };
  ContactMotions(const HarmonicBalanceModel& model, const Eigen::VectorXd& y, int samples)
      : phase_step_(2 * std::numbers::pi / samples) {
    paths_.reserve(model.contacts().size());
    for (const auto& contact : model.contacts()) paths_.emplace_back(model.layout(), y, contact);
  }
  Motion at(std::size_t c, int jp, double s, double length) const {
    Motion mo{};
    paths_[c].at(phase_step_ * jp + phase_step_ * s, mo.u, mo.rate);
    for (double& r : mo.rate) r *= phase_step_ * length;
    return mo;
  }

 private:
  std::vector<ContactPath> paths_;
  double phase_step_;
};

// A law that switches regime inside a step makes the force's linearisation jump there (a
// contact that starts to slip loses its stiffness at once), which a straight line between
// the step's samples smears over the step: an error of the order of the step, not its
// square. Where each model contact switches inside each step (switches[c][j], the fraction of
// step j from sample j - 1, or -1): located by bisection on the regime at a point (the tangent
// of a short step from it, the law's state followed along the motion from the step's start).
bool locate_switches(const std::vector<ContactModel>& contacts,
                     const std::vector<ContactTrace>& traces,
                     const std::vector<std::vector<StepTangents>>& steps,
                     const ContactMotions& motions, std::vector<std::vector<double>>& switches,
                     std::string& failure) {
  const int samples = static_cast<int>(steps.size());
  using Motion = ContactMotions::Motion;
  // The law's state at fraction s of step j (from sample jp), followed along the motion from
  // its state `state` at fraction `from` (value-only steps).
  auto follow = [&](std::size_t c, int jp, double from, double s, Eigen::VectorXd& state,
                    std::string* error) {
    Eigen::VectorXd next;
    for (int i = 0; i < kPathSteps; ++i) {
      const double a = from + (s - from) * i / kPathSteps,
                   b = from + (s - from) * (i + 1) / kPathSteps;
      const Motion m0 = motions.at(c, jp, a, b - a), m1 = motions.at(c, jp, b, b - a);
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
    const Motion m0 = motions.at(c, jp, s, kProbe), m1 = motions.at(c, jp, s + kProbe, kProbe);
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
  switches.assign(contacts.size(), std::vector<double>(static_cast<std::size_t>(samples)));
  for (std::size_t c = 0; c < contacts.size(); ++c)
    for (int j = 0; j < samples; ++j) {
      std::string error;
      if (!locate_switch(c, j, switches[c][static_cast<std::size_t>(j)], &error)) {
        failure = "contact " + contacts[c].name + ": " + error;
        return false;
      }
    }
  return true;
}

// The product of the variational step maps: the monodromy of the state (dq, dq', df, dz) and
// each contact copy's own state monodromy (d state / d state_prev, the motion held).
class VariationalMap {
 public:
  VariationalMap(const VariationalStructure& vs, const std::vector<ContactCopy>& copies,
                 const std::vector<int>& state_sizes, Eigen::Index states, double h)
      : vs_(vs),
        copies_(copies),
        h_(h),
        modes_(vs.frequencies.size()),
        m_(vs.p.rows()),
        states_(states),
        full_step_(propagate_modes(vs.frequencies, vs.damping, vs.diagonal, h)),
        k1_(m_, 2 * modes_),
        k0_(m_, 2 * modes_),
        kz_(m_, states),
        z1_(states, 2 * modes_),
        z0_(states, 2 * modes_),
        zz_(states, states),
        an_(vs.flexibility.size() ? m_ : 0, m_),
        ap_(vs.flexibility.size() ? m_ : 0, m_),
        bn_(vs.flexibility.size() ? states : 0, m_),
        bp_(vs.flexibility.size() ? states : 0, m_) {
    const Eigen::Index dim = 2 * modes_ + m_ + states;
    monodromy = Eigen::MatrixXd::Identity(dim, dim);
    for (const int s : state_sizes) own.push_back(Eigen::MatrixXd::Identity(s, s));
  }

  // The map over a fraction `length` of a step, each copy's tangents `t`: the new force sample
  // solves (I - K1 G1) df_j = K1 (E x + G0 df_{j-1}) + K0 x + Kz dz. With a residual
  // flexibility F the contacts move by du = P dq - F df, and by du/ds = hl P dq' - F (df_j -
  // df_{j-1}) (the force linear over the step, as the modal propagator takes it): the tangents'
  // columns times F move to the left, (I - K1 G1 + An) df_j = ... - Ap df_{j-1}, An = (Dun + Drn
  // + Drp) F, Ap = (Dup - Drn - Drp) F with D the force's tangents; the states' likewise.
  void advance(double length, const std::vector<const StepTangents*>& t) {
    const StepPropagator sub =
        length == 1.0 ? StepPropagator{}
                      : propagate_modes(vs_.frequencies, vs_.damping, vs_.diagonal, length * h_);
    const StepPropagator& prop = length == 1.0 ? full_step_ : sub;
    const Eigen::MatrixXd& p = vs_.p;
    const Eigen::MatrixXd gamma0 = modal_product(prop.g0, p.transpose(), -1.0),
                          gamma1 = modal_product(prop.g1, p.transpose(), -1.0);
    const double hl = length * h_;
    const Eigen::Index modes = modes_, n2 = 2 * modes_;
    k1_.setZero();
    k0_.setZero();
    kz_.setZero();
    z1_.setZero();
    z0_.setZero();
    zz_.setZero();
    const bool flexible = vs_.flexibility.size() > 0;
    if (flexible) {
      an_.setZero();
      ap_.setZero();
      bn_.setZero();
      bp_.setZero();
    }
    for (std::size_t k = 0; k < copies_.size(); ++k) {
      const StepTangents& tc = *t[k];
      const Eigen::Index r = copies_[k].row, d = tc.df_dun.rows(), zo = copies_[k].state,
                         s = tc.dz_dz.rows();
      const auto pc = p.middleRows(r, d);
      if (flexible) {
        const auto fc = vs_.flexibility.middleRows(r, d);
        an_.middleRows(r, d) = (tc.df_dun + tc.df_drn + tc.df_drp) * fc;
        ap_.middleRows(r, d) = (tc.df_dup - tc.df_drn - tc.df_drp) * fc;
        if (s > 0) {
          bn_.middleRows(zo, s) = (tc.dz_dun + tc.dz_drn + tc.dz_drp) * fc;
          bp_.middleRows(zo, s) = (tc.dz_dup - tc.dz_drn - tc.dz_drp) * fc;
        }
      }
      // u = P q and the rates du/ds = hl P q' at the step's ends.
      k1_.block(r, 0, d, modes) = tc.df_dun * pc;
      k1_.block(r, modes, d, modes) = hl * tc.df_drn * pc;
      k0_.block(r, 0, d, modes) = tc.df_dup * pc;
      k0_.block(r, modes, d, modes) = hl * tc.df_drp * pc;
      if (s == 0) continue;  // a law without state: no blocks (and no offsets into empty ones)
      kz_.block(r, zo, d, s) = tc.df_dz;
      z1_.block(zo, 0, s, modes) = tc.dz_dun * pc;
      z1_.block(zo, modes, s, modes) = hl * tc.dz_drn * pc;
      z0_.block(zo, 0, s, modes) = tc.dz_dup * pc;
      z0_.block(zo, modes, s, modes) = hl * tc.dz_drp * pc;
      zz_.block(zo, zo, s, s) = tc.dz_dz;
      own[k] = tc.dz_dz * own[k];
    }
    const auto x = monodromy.topRows(n2);
    const auto f = monodromy.middleRows(n2, m_);
    const auto z = monodromy.bottomRows(states_);
    Eigen::MatrixXd predicted = modal_product(prop.e, x, 1.0);
    predicted.noalias() += gamma0 * f;
    Eigen::MatrixXd rhs = k1_ * predicted + k0_ * x + kz_ * z;
    Eigen::MatrixXd system = Eigen::MatrixXd::Identity(m_, m_) - k1_ * gamma1;
    if (flexible) {
      rhs -= ap_ * f;
      system += an_;
    }
    const Eigen::MatrixXd f_next = system.partialPivLu().solve(rhs);
    const Eigen::MatrixXd x_next = predicted + gamma1 * f_next;
    Eigen::MatrixXd z_next = z1_ * x_next + z0_ * x + zz_ * z;
    if (flexible && states_ > 0) z_next -= bn_ * f_next + bp_ * f;
    monodromy << x_next, f_next, z_next;
  }

  Eigen::MatrixXd monodromy;
  std::vector<Eigen::MatrixXd> own;  // per copy

 private:
  // scale * a * b for a propagator block `a` (2 modes x modes, or 2 modes x 2 modes) whose
  // modes do not couple when the damping is diagonal: each of its modes x modes blocks is then
  // diagonal, and the product is a scaling of b's rows (2 modes x columns of work, against
  // 2 modes x modes x columns dense).
  Eigen::MatrixXd modal_product(const Eigen::MatrixXd& a,
                                const Eigen::Ref<const Eigen::MatrixXd>& b, double scale) const {
    if (!vs_.diagonal || modes_ == 0) return scale * (a * b);
    const Eigen::Index n = modes_;
    Eigen::MatrixXd out = Eigen::MatrixXd::Zero(a.rows(), b.cols());
    for (Eigen::Index half = 0; half < a.rows() / n; ++half)
      for (Eigen::Index block = 0; block < a.cols() / n; ++block)
        out.middleRows(half * n, n) +=
            (scale * a.block(half * n, block * n, n, n).diagonal()).asDiagonal() *
            b.middleRows(block * n, n);
    return out;
  }

  const VariationalStructure& vs_;
  const std::vector<ContactCopy>& copies_;
  double h_;
  Eigen::Index modes_, m_, states_;
  StepPropagator full_step_;
  Eigen::MatrixXd k1_, k0_, kz_, z1_, z0_, zz_;
  Eigen::MatrixXd an_, ap_, bn_, bp_;  // the residual flexibility's terms (advance), or empty
};

// The multipliers of the contacts' own state monodromies within kNeutralTolerance of 1.
int neutral_count(const std::vector<Eigen::MatrixXd>& own) {
  int neutral = 0;
  for (const auto& mc : own) {
    if (mc.size() == 0) continue;
    const Eigen::VectorXcd mu = mc.eigenvalues();
    for (Eigen::Index k = 0; k < mu.size(); ++k)
      if (std::abs(mu(k) - 1.0) <= kNeutralTolerance) ++neutral;
  }
  return neutral;
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
  const double w = y(y.size() - 1);

  // The contacts' traces at y and the tracing grid.
  const auto& contacts = model.contacts();
  std::vector<ContactTrace> traces(contacts.size());
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
    samples = static_cast<int>(traces[c].displacement.rows());
  }
  if (samples == 0) samples = model.layout().samples();
  out.steps = samples;

  VariationalStructure vs;
  std::vector<ContactCopy> copies;
  if (!(model.cyclic().enabled() ? cyclic_structure(model, samples, vs, copies, out.failure)
                                 : plain_structure(model, vs, copies, out.failure)))
    return out;
  const Eigen::Index modes = vs.frequencies.size();
  const Eigen::Index m = vs.p.rows(), n2 = 2 * modes;
  Eigen::Index states = 0;
  std::vector<int> state_sizes;
  for (const auto& copy : copies) {
    state_sizes.push_back(contacts[copy.contact].law->traits().state_size);
    states += state_sizes.back();
  }
  const Eigen::Index dim = n2 + m + states;
  if (dim > kMaxStabilityDimension) {
    out.failure = "the variational system has " + std::to_string(dim) +
                  " unknowns (modes twice, contact components, contact states); the dense "
                  "monodromy is limited to " +
                  std::to_string(kMaxStabilityDimension);
    return out;
  }

  // The tangents of every step of each model contact at the traced states (a copy's step j is
  // its contact's step j - shift), and where each switches regime inside a step.
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
  const ContactMotions motions(model, y, samples);
  std::vector<std::vector<double>> switches;
  if (!locate_switches(contacts, traces, steps, motions, switches, out.failure)) return out;

  // A travelling wave repeats itself after tau = g T / nb turned by r0 sectors (g = gcd(m, nb),
  // r0 m = g mod nb): sector s moves over [tau, 2 tau] as sector s - r0 did over [0, tau].
  // Hence Phi(T) = Q^-k (Q A)^k with A = Phi(tau), k = nb / g and Q the turn by r0 sectors:
  // only the first g N / nb steps of the period are integrated.
  const CyclicSpec& cyclic = model.cyclic();
  const bool turned = !vs.nodal_diameter.empty();
  const int repeats = turned ? cyclic.sectors / std::gcd(cyclic.engine_order, cyclic.sectors) : 1;
  const int segment = samples / repeats;
  int turn = 0;
  if (turned)
    while ((turn * cyclic.engine_order - cyclic.sectors / repeats) % cyclic.sectors != 0) ++turn;

  // The steps, each split where a copy's law switches regime: up to the switch, across it (a
  // short step of its own) and after it, each sub-step with the laws' tangents of its own.
  VariationalMap map(vs, copies, state_sizes, states, 2 * std::numbers::pi / w / samples);
  std::vector<StepTangents> sub_tangents(copies.size());
  std::vector<const StepTangents*> tangents(copies.size());
  std::vector<Eigen::VectorXd> sub_states(copies.size());
  // Copy k's own step and sample index for the disk's step or sample j.
  auto own_index = [&](std::size_t k, int j) { return (j - copies[k].shift + samples) % samples; };
  for (int step = 1; step <= segment; ++step) {
    const int j = step % samples, jp = step - 1;
    std::vector<double> cuts;
    for (std::size_t k = 0; k < copies.size(); ++k) {
      const double where = switches[copies[k].contact][static_cast<std::size_t>(own_index(k, j))];
      if (where < 0) continue;
      if (where > kSwitchStep) cuts.push_back(where);
      if (where + kSwitchStep < 1.0 - kSwitchStep) cuts.push_back(where + kSwitchStep);
    }
    if (cuts.empty()) {
      for (std::size_t k = 0; k < copies.size(); ++k)
        tangents[k] = &steps[static_cast<std::size_t>(own_index(k, j))][copies[k].contact];
      map.advance(1.0, tangents);
      continue;
    }
    ++out.split_steps;
    std::sort(cuts.begin(), cuts.end());
    cuts.push_back(1.0);
    for (std::size_t k = 0; k < copies.size(); ++k)
      sub_states[k] = traced_state(traces[copies[k].contact], own_index(k, jp));
    double a = 0.0;
    for (const double b : cuts) {
      if (b - a <= 0.0) continue;
      for (std::size_t k = 0; k < copies.size(); ++k) {
        const std::size_t c = copies[k].contact;
        const int from_sample = own_index(k, jp);
        std::string error;
        const auto from = motions.at(c, from_sample, a, b - a),
                   to = motions.at(c, from_sample, b, b - a);
        Eigen::VectorXd next;
        if (!law_step(contacts[c], sub_states[k], from.u, to.u, from.rate, to.rate, sub_tangents[k],
                      next, &error)) {
          out.failure = "contact " + contacts[c].name + ": " + error;
          return out;
        }
        sub_states[k] = next;
        tangents[k] = &sub_tangents[k];
      }
      map.advance(b - a, tangents);
      a = b;
    }
  }
  if (repeats > 1) {
    complete_by_turning(map.monodromy, map.own, vs, copies, cyclic.sectors, repeats, turn);
    out.split_steps *= repeats;
  }
  if (!map.monodromy.allFinite()) {
    out.failure = "the monodromy matrix is not finite";
    return out;
  }
  classify(map.monodromy, m, neutral_count(map.own), vs, out);
  return out;
}

}  // namespace frichb::core
