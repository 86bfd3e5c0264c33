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

bool contact_step_tangents(const ContactModel& contact, const ContactTrace& trace, int j,
                           StepTangents& t, std::string* error) {
  const ContactLawInstance& law = *contact.law;
  const auto& components = contact.tracer->components();
  const auto d = static_cast<Eigen::Index>(components.size());
  const int s = law.traits().state_size, n = static_cast<int>(trace.displacement.rows());
  const int jp = (j + n - 1) % n;
  const int sd = std::max(s, 1);
  RowMajor fun = RowMajor::Zero(3, 3), fup = RowMajor::Zero(3, 3), fz = RowMajor::Zero(3, sd),
           zun = RowMajor::Zero(sd, 3), zup = RowMajor::Zero(sd, 3), zz = RowMajor::Zero(sd, sd),
           frp = RowMajor::Zero(3, 3), frn = RowMajor::Zero(3, 3), zrp = RowMajor::Zero(sd, 3),
           zrn = RowMajor::Zero(sd, 3);
  frichb_step_tangents tangents{fun.data(), fup.data(), fz.data(),
                                zun.data(), zup.data(), zz.data()};
  frichb_motion_tangents motion_tangents{frp.data(), frn.data(), zrp.data(), zrn.data()};
  double u_now[3] = {0, 0, 0}, u_prev[3] = {0, 0, 0}, r_now[3] = {0, 0, 0}, r_prev[3] = {0, 0, 0};
  const bool along = contact.tracer->along_motion();
  for (Eigen::Index a = 0; a < d; ++a) {
    const int c = components[static_cast<std::size_t>(a)];
    u_now[c] = trace.displacement(j, a);
    u_prev[c] = trace.displacement(jp, a);
    if (along) {
      r_now[c] = trace.rate(j, a);
      r_prev[c] = trace.rate(jp, a);
    }
  }
  Eigen::VectorXd state_prev = trace.state.row(jp).transpose(), state_now(s);
  double force[3];
  const bool ok =
      along ? law.step_along(state_prev.data(), u_prev, u_now,
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

  const StepPropagator prop =
      propagate_modes(basis.frequencies, basis.damping, basis.diagonal_damping, h);
  const Eigen::MatrixXd gamma0 = -prop.g0 * p.transpose(), gamma1 = -prop.g1 * p.transpose();
  const Eigen::Index dim = n2 + m + states;
  Eigen::MatrixXd monodromy = Eigen::MatrixXd::Identity(dim, dim);
  std::vector<Eigen::MatrixXd> own(contacts.size());  // each contact's state monodromy
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const int s = contacts[c].law->traits().state_size;
    own[c] = Eigen::MatrixXd::Identity(s, s);
  }
  Eigen::MatrixXd k1(m, n2), k0(m, n2), kz(m, states), z1(states, n2), z0(states, n2),
      zz(states, states);
  StepTangents t;
  for (int step = 1; step <= samples; ++step) {
    const int j = step % samples;
    k1.setZero();
    k0.setZero();
    kz.setZero();
    z1.setZero();
    z0.setZero();
    zz.setZero();
    for (std::size_t c = 0; c < contacts.size(); ++c) {
      std::string error;
      if (!contact_step_tangents(contacts[c], traces[c], j, t, &error)) {
        out.failure = "contact " + contacts[c].name + ": " + error;
        return out;
      }
      const Eigen::Index r = contacts[c].offset, d = t.df_dun.rows(), zo = state_offset[c],
                         s = t.dz_dz.rows();
      const auto pc = p.middleRows(r, d);
      // u = P q and the rates du/ds = h P q' at the step's ends.
      k1.block(r, 0, d, modes) = t.df_dun * pc;
      k1.block(r, modes, d, modes) = h * t.df_drn * pc;
      k0.block(r, 0, d, modes) = t.df_dup * pc;
      k0.block(r, modes, d, modes) = h * t.df_drp * pc;
      kz.block(r, zo, d, s) = t.df_dz;
      z1.block(zo, 0, s, modes) = t.dz_dun * pc;
      z1.block(zo, modes, s, modes) = h * t.dz_drn * pc;
      z0.block(zo, 0, s, modes) = t.dz_dup * pc;
      z0.block(zo, modes, s, modes) = h * t.dz_drp * pc;
      zz.block(zo, zo, s, s) = t.dz_dz;
      own[c] = t.dz_dz * own[c];
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
