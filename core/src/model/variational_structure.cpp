// The linear part of the variational equations, plain or the whole cyclic disk, and the turning
// of a disk's state by whole sectors (model/variational_structure.hpp).
#include "model/variational_structure.hpp"

#include <cmath>
#include <complex>
#include <numbers>

namespace frichb::core {

namespace {

// The rows of a disk's modal coordinates (modes x columns) as the disk turned by `by` sectors
// sees them: (Q x)_s = x_(s + by). Sector s of mode pair v = Phi_h e^{-i h phi s} / sqrt(nb)
// turns into e^{-i h phi by} v, so the coordinates (a, b) of its real and imaginary parts turn
// by theta = h phi by: a' = a cos theta - b sin theta, b' = a sin theta + b cos theta; a mode
// of h = nb/2 changes sign with an odd `by`, one of h = 0 is unchanged.
void turn_modes(Eigen::Ref<Eigen::MatrixXd> rows, const VariationalStructure& vs, int nb, int by) {
  const double phi = 2 * std::numbers::pi / nb;
  for (Eigen::Index r = 0; r < rows.rows(); ++r) {
    const auto i = static_cast<std::size_t>(r);
    const int h = vs.nodal_diameter[i];
    if (vs.pair_role[i] == 0) {
      if (2 * h == nb && by % 2 != 0) rows.row(r) *= -1.0;
      continue;
    }
    if (vs.pair_role[i] != 1) continue;
    const double theta = h * phi * by, c = std::cos(theta), s = std::sin(theta);
    const Eigen::RowVectorXd a = rows.row(r), b = rows.row(r + 1);
    rows.row(r) = c * a - s * b;
    rows.row(r + 1) = s * a + c * b;
  }
}

// Rows held sector after sector (the same count each) as the disk turned by `by` sectors sees
// them: sector s takes sector s + by's.
void turn_sectors(Eigen::Ref<Eigen::MatrixXd> rows, int nb, int by) {
  if (rows.size() == 0) return;
  const Eigen::Index per = rows.rows() / nb;
  const Eigen::MatrixXd old = rows;
  for (int s = 0; s < nb; ++s)
    rows.middleRows(s * per, per) = old.middleRows(((s + by) % nb) * per, per);
}

// a^k for k >= 1, by squaring.
Eigen::MatrixXd matrix_power(const Eigen::MatrixXd& a, int k) {
  Eigen::MatrixXd result, base = a;
  bool first = true;
  for (; k > 0; k /= 2) {
    if (k % 2 != 0) {
      result = first ? base : Eigen::MatrixXd(base * result);
      first = false;
    }
    if (k > 1) base = base * base;
  }
  return result;
}

// A model built from a scene without output.stability reduces F as it fetches it and keeps
// none of it between the contacts of every harmonic index.
constexpr const char* kFlexibilityNotKept =
    "the structure has a residual flexibility, and the model was built without the stability "
    "analysis, which keeps it between the contacts (output.stability)";

}  // namespace

// A plain structure: its modes as the model holds them, each contact once.
bool plain_structure(const HarmonicBalanceModel& model, VariationalStructure& vs,
                     std::vector<ContactCopy>& copies, std::string& failure) {
  const auto& basis = model.structure().basis(0);
  if (basis.rows.size() > 0 && basis.rows.imag().cwiseAbs().maxCoeff() > 0) {
    failure = "stability needs real modes";
    return false;
  }
  vs.frequencies = basis.frequencies;
  vs.damping = basis.damping;
  vs.diagonal = basis.diagonal_damping;
  vs.p = Eigen::MatrixXd(Eigen::MatrixXcd(model.gather(0)).real()) * basis.rows.real();
  if (basis.has_residual_flexibility()) {
    const Eigen::MatrixXcd* f = model.index_flexibility(0);
    if (f == nullptr) {
      failure = kFlexibilityNotKept;
      return false;
    }
    if (f->size() > 0 &&
        f->imag().cwiseAbs().maxCoeff() > 1e-12 * f->real().cwiseAbs().maxCoeff()) {
      failure = "stability needs a real residual flexibility";
      return false;
    }
    vs.flexibility = f->real();
  }
  Eigen::Index states = 0;
  for (std::size_t c = 0; c < model.contacts().size(); ++c) {
    copies.push_back({c, 0, model.contacts()[c].offset, states});
    states += model.contacts()[c].law->traits().state_size;
  }
  return true;
}

// A cyclic structure: the whole disk. Its real modes are built from the sector's modes of every
// nodal diameter h <= nb/2: sector s of the complex mode v = Phi_h e^{-i h phi s} / sqrt(nb)
// (the sign of the model's cyclic gather), mass-normalised over the disk when Phi_h is over
// the sector; for 0 < h < nb/2 its real and imaginary parts times sqrt(2) (the standing pair
// of h and nb - h), for h = 0 and nb/2 the mode itself, real up to a phase. Each contact is
// copied into every sector, delayed by s m / nb of the period: a whole number of samples.
bool cyclic_structure(const HarmonicBalanceModel& model, int samples, VariationalStructure& vs,
                      std::vector<ContactCopy>& copies, std::string& failure) {
  const CyclicSpec& cyclic = model.cyclic();
  const int nb = cyclic.sectors;
  const long long delay = static_cast<long long>(samples) * cyclic.engine_order;
  if (delay % nb != 0) {
    failure = "the cyclic stability needs the samples of a period (" + std::to_string(samples) +
              ") times the engine order to be a multiple of the sector count (" +
              std::to_string(nb) + ")";
    return false;
  }
  const auto kept = static_cast<Eigen::Index>(model.structure().kept_dofs().size());
  const double phi = 2 * std::numbers::pi / nb;
  std::vector<Eigen::VectorXd> columns;
  std::vector<double> frequencies, damping;
  for (int h = 0; 2 * h <= nb; ++h) {
    const auto& basis = model.structure().basis(h);
    if (!basis.diagonal_damping) {
      failure = "the cyclic stability needs diagonal modal damping (nodal diameter " +
                std::to_string(h) + ")";
      return false;
    }
    if (basis.has_residual_flexibility() && model.index_flexibility(h) == nullptr) {
      failure = kFlexibilityNotKept;
      return false;
    }
    for (Eigen::Index r = 0; r < basis.rows.cols(); ++r) {
      Eigen::VectorXcd v(nb * kept);
      for (int s = 0; s < nb; ++s)
        v.segment(s * kept, kept) =
            basis.rows.col(r) * std::polar(1.0 / std::sqrt(double(nb)), -h * phi * s);
      auto add = [&](const Eigen::VectorXd& column, int role) {
        columns.push_back(column);
        frequencies.push_back(basis.frequencies(r));
        damping.push_back(basis.damping(r, r));
        vs.nodal_diameter.push_back(h);
        vs.pair_role.push_back(role);
      };
      if (h == 0 || 2 * h == nb) {
        Eigen::Index i = 0;
        basis.rows.col(r).cwiseAbs().maxCoeff(&i);
        const std::complex<double> a = basis.rows(i, r);
        add((v * (std::abs(a) > 0 ? std::conj(a) / std::abs(a) : 1.0)).real(), 0);
      } else {
        add(std::sqrt(2.0) * v.real(), 1);
        add(std::sqrt(2.0) * v.imag(), 2);
      }
    }
  }
  const auto modes = static_cast<Eigen::Index>(columns.size());
  Eigen::MatrixXd shapes(nb * kept, modes);
  for (Eigen::Index r = 0; r < modes; ++r) shapes.col(r) = columns[static_cast<std::size_t>(r)];
  vs.frequencies = Eigen::Map<const Eigen::VectorXd>(frequencies.data(), modes);
  vs.damping = Eigen::Map<const Eigen::VectorXd>(damping.data(), modes).asDiagonal();
  vs.diagonal = true;
  const Eigen::Index m = model.component_count();
  vs.p = Eigen::MatrixXd::Zero(nb * m, modes);
  for (int offset = -1; offset <= 1; ++offset)
    for (int s = 0; s < nb; ++s)
      vs.p.middleRows(s * m, m) +=
          model.side_gather(offset) * shapes.middleRows(((s + offset + nb) % nb) * kept, kept);
  // The residual flexibility between the contacts of sectors s and s': the sum over every
  // nodal diameter h < nb of e^{-i h phi (s - s')} C_h / nb, C_h = G_h F_h G_h^H and
  // C_(nb - h) its conjugate; it depends on s - s' alone and is real.
  bool flexible = false;
  for (int h = 0; 2 * h <= nb; ++h) flexible = flexible || model.index_flexibility(h) != nullptr;
  if (flexible) {
    std::vector<Eigen::MatrixXd> by_distance(static_cast<std::size_t>(nb),
                                             Eigen::MatrixXd::Zero(m, m));
    for (int h = 0; h < nb; ++h) {
      const Eigen::MatrixXcd* c = model.index_flexibility(2 * h <= nb ? h : nb - h);
      if (c == nullptr) continue;
      const Eigen::MatrixXcd ch = 2 * h <= nb ? *c : Eigen::MatrixXcd(c->conjugate());
      for (int d = 0; d < nb; ++d)
        by_distance[static_cast<std::size_t>(d)] +=
            (ch * std::polar(1.0 / nb, -h * phi * d)).real();
    }
    vs.flexibility.resize(nb * m, nb * m);
    for (int s = 0; s < nb; ++s)
      for (int t = 0; t < nb; ++t)
        vs.flexibility.block(s * m, t * m, m, m) =
            by_distance[static_cast<std::size_t>((s - t + nb) % nb)];
  }
  Eigen::Index states = 0;
  for (int s = 0; s < nb; ++s)
    for (std::size_t c = 0; c < model.contacts().size(); ++c) {
      copies.push_back({c, static_cast<int>((s * delay / nb) % samples),
                        s * m + model.contacts()[c].offset, states});
      states += model.contacts()[c].law->traits().state_size;
    }
  return true;
}

void complete_by_turning(Eigen::MatrixXd& monodromy, std::vector<Eigen::MatrixXd>& own,
                         const VariationalStructure& vs, const std::vector<ContactCopy>& copies,
                         int nb, int repeats, int turn) {
  const Eigen::Index modes = vs.frequencies.size(), n2 = 2 * modes, m = vs.p.rows();
  const Eigen::Index states = monodromy.rows() - n2 - m;
  const int back = (nb - (turn * repeats) % nb) % nb;
  auto turn_state = [&](Eigen::MatrixXd& rows, int by) {
    turn_modes(rows.topRows(modes), vs, nb, by);
    turn_modes(rows.middleRows(modes, modes), vs, nb, by);
    turn_sectors(rows.middleRows(n2, m), nb, by);
    turn_sectors(rows.bottomRows(states), nb, by);
  };
  turn_state(monodromy, turn);
  monodromy = matrix_power(monodromy, repeats);
  turn_state(monodromy, back);
  Eigen::MatrixXd own_all = Eigen::MatrixXd::Zero(states, states);
  if (states > 0) {
    for (std::size_t k = 0; k < copies.size(); ++k)
      if (own[k].size() > 0)
        own_all.block(copies[k].state, copies[k].state, own[k].rows(), own[k].cols()) = own[k];
    turn_sectors(own_all, nb, turn);
    own_all = matrix_power(own_all, repeats);
    turn_sectors(own_all, nb, back);
  }
  own = {own_all};
}

}  // namespace frichb::core
