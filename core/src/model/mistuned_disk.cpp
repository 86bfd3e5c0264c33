#include "frichb/core/model/mistuned_disk.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <string>

namespace frichb::core {

namespace {

using Complex = std::complex<double>;

// a_j^T K_b b_j summed over the blades with their deviations, for standing-wave parts of the
// complex modes u = phi_h e^{-i h j theta}, v = phi_h' e^{-i h' j theta}, from the sums
// P = sum_j delta_j u^H K_b v and Q = sum_j delta_j u^T K_b v:
//   Re u^T K Re v = Re(Q + P) / 2,   Im u^T K Im v = Re(P - Q) / 2,
//   Re u^T K Im v = Im(Q + P) / 2,   Im u^T K Re v = Im(Q - P) / 2.
double standing_wave_product(bool imaginary_a, bool imaginary_b, Complex p, Complex q) {
  if (!imaginary_a && !imaginary_b) return 0.5 * (q + p).real();
  if (imaginary_a && imaginary_b) return 0.5 * (p - q).real();
  if (!imaginary_a) return 0.5 * (q + p).imag();
  return 0.5 * (q - p).imag();
}

}  // namespace

MistunedDisk::MistunedDisk(std::unique_ptr<StructureInstance> sector,
                           const MistuningSpec& mistuning)
    : sector_(std::move(sector)), sectors_(mistuning.sectors) {
  if (static_cast<int>(sector_->sector_count()) != sectors_)
    throw std::invalid_argument("the mistuning pattern is for " + std::to_string(sectors_) +
                                " blades, the structure models one sector of " +
                                std::to_string(sector_->sector_count()));
  if (static_cast<int>(mistuning.deviations.size()) != sectors_)
    throw std::invalid_argument("the mistuning pattern has " +
                                std::to_string(mistuning.deviations.size()) + " deviations for " +
                                std::to_string(sectors_) + " blades");
  solve(mistuning);
}

std::size_t MistunedDisk::dof_count() const {
  return sector_->dof_count() * static_cast<std::size_t>(sectors_);
}

void MistunedDisk::solve(const MistuningSpec& mistuning) {
  const int nb = sectors_;
  const double scale_standing = std::sqrt(1.0 / nb), scale_pair = std::sqrt(2.0 / nb);
  std::vector<Eigen::Index> mode_counts;
  std::vector<double> frequencies, damping;
  const std::size_t probe = 0;
  for (int h = 0; 2 * h <= nb; ++h) {
    const frichb_modal_basis b = sector_->modal_basis(h, std::span<const std::size_t>(&probe, 1));
    if (b.residual_flexibility)
      throw std::invalid_argument(
          "the sector's modal basis of harmonic index " + std::to_string(h) +
          " has a residual flexibility (truncated modes): a mistuned disk needs every mode of "
          "the sector (their mistuning would be lost)");
    const bool real_index = h == 0 || 2 * h == nb;
    const auto m = static_cast<Eigen::Index>(b.n_modes);
    mode_counts.push_back(m);
    for (Eigen::Index r = 0; r < m; ++r) {
      for (Eigen::Index c = 0; c < m; ++c)
        if (c != r && b.modal_damping && b.modal_damping[r * m + c] != 0.0)
          throw std::invalid_argument(
              "the sector's modal damping of harmonic index " + std::to_string(h) +
              " is not diagonal: a mistuned disk takes modal damping ratios");
      const double w = b.natural_frequencies[r];
      const double c = b.modal_damping ? b.modal_damping[r * m + r] : 0.0;
      for (int part = 0; part < (real_index ? 1 : 2); ++part) {
        tuned_.push_back({h, r, part == 1, real_index ? scale_standing : scale_pair});
        frequencies.push_back(w);
        damping.push_back(c);
      }
    }
  }
  const auto n = static_cast<Eigen::Index>(tuned_.size());
  tuned_frequencies_ = Eigen::Map<const Eigen::VectorXd>(frequencies.data(), n);
  const Eigen::VectorXd tuned_damping = Eigen::Map<const Eigen::VectorXd>(damping.data(), n);

  // The first tuned mode of each harmonic index.
  std::vector<Eigen::Index> first(mode_counts.size(), 0);
  for (std::size_t a = 0; a < tuned_.size(); ++a) {
    const auto h = static_cast<std::size_t>(tuned_[a].h);
    if (a > 0 && tuned_[a - 1].h == tuned_[a].h) continue;
    first[h] = static_cast<Eigen::Index>(a);
  }
  Eigen::MatrixXd stiffness = tuned_frequencies_.cwiseAbs2().asDiagonal();
  const double theta = 2.0 * std::numbers::pi / nb;
  const int hmax = static_cast<int>(mode_counts.size()) - 1;
  for (int h = 0; h <= hmax; ++h)
    for (int g = h; g <= hmax; ++g) {
      // sum_j delta_j e^{i (h - g) j theta} and sum_j delta_j e^{-i (h + g) j theta}.
      Complex phase_p = 0, phase_q = 0;
      for (int j = 0; j < nb; ++j) {
        const double d = mistuning.deviations[static_cast<std::size_t>(j)];
        phase_p += d * std::polar(1.0, (h - g) * j * theta);
        phase_q += d * std::polar(1.0, -(h + g) * j * theta);
      }
      if (std::abs(phase_p) == 0.0 && std::abs(phase_q) == 0.0) continue;
      const auto mh = static_cast<std::size_t>(mode_counts[static_cast<std::size_t>(h)]);
      const auto mg = static_cast<std::size_t>(mode_counts[static_cast<std::size_t>(g)]);
      const auto sh = sector_->blade_stiffness(h, g, true, mh, mg);
      const auto st = sector_->blade_stiffness(h, g, false, mh, mg);
      const auto parts_h = (h == 0 || 2 * h == nb) ? 1 : 2,
                 parts_g = (g == 0 || 2 * g == nb) ? 1 : 2;
      for (std::size_t r = 0; r < mh; ++r)
        for (std::size_t s = 0; s < mg; ++s) {
          const Complex p = phase_p * sh[r * mg + s], q = phase_q * st[r * mg + s];
          for (int pa = 0; pa < parts_h; ++pa)
            for (int pb = 0; pb < parts_g; ++pb) {
              const Eigen::Index a =
                  first[static_cast<std::size_t>(h)] + static_cast<Eigen::Index>(r) * parts_h + pa;
              const Eigen::Index b =
                  first[static_cast<std::size_t>(g)] + static_cast<Eigen::Index>(s) * parts_g + pb;
              const double value = tuned_[static_cast<std::size_t>(a)].scale *
                                   tuned_[static_cast<std::size_t>(b)].scale *
                                   standing_wave_product(pa == 1, pb == 1, p, q);
              if (h == g) {
                stiffness(a, b) += value;
              } else {
                stiffness(a, b) += value;
                stiffness(b, a) += value;
              }
            }
        }
    }
  // Symmetric up to rounding within a harmonic index's block.
  const Eigen::MatrixXd symmetric = 0.5 * (stiffness + stiffness.transpose());
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(symmetric);
  if (eig.info() != Eigen::Success)
    throw std::runtime_error("the mistuned disk's eigen-solve failed");
  const Eigen::VectorXd& lambda = eig.eigenvalues();
  const double top = std::max(1.0, lambda.cwiseAbs().maxCoeff());
  frequencies_.resize(n);
  damping_.resize(n);
  vectors_ = eig.eigenvectors();
  for (Eigen::Index k = 0; k < n; ++k) {
    if (lambda(k) < -1e-10 * top)
      throw std::invalid_argument("the mistuned disk's stiffness is not positive (eigenvalue " +
                                  std::to_string(lambda(k)) + " 1/s^2)");
    frequencies_(k) = std::sqrt(std::max(0.0, lambda(k)));
    double ratio = 0;
    for (Eigen::Index a = 0; a < n; ++a)
      if (tuned_frequencies_(a) > 0)
        ratio += vectors_(a, k) * vectors_(a, k) * tuned_damping(a) / (2.0 * tuned_frequencies_(a));
    damping_(k) = 2.0 * ratio * frequencies_(k);
  }
  std::sort(tuned_frequencies_.data(), tuned_frequencies_.data() + n);
}

frichb_modal_basis MistunedDisk::modal_basis(int harmonic_index,
                                             std::span<const std::size_t> kept_dofs) {
  if (harmonic_index != 0)
    throw std::invalid_argument("a mistuned disk is a plain structure: harmonic index " +
                                std::to_string(harmonic_index) + " does not exist");
  const auto nb = static_cast<std::size_t>(sectors_);
  const std::size_t total = dof_count();
  // The sector DOFs the kept DOFs sit on, and where each kept DOF finds its row.
  std::vector<std::size_t> sector_dofs;
  std::vector<std::size_t> row_of(kept_dofs.size());
  for (std::size_t i = 0; i < kept_dofs.size(); ++i) {
    if (kept_dofs[i] >= total)
      throw std::out_of_range("DOF " + std::to_string(kept_dofs[i]) +
                              " does not exist (the mistuned disk has " + std::to_string(total) +
                              " DOFs)");
    const std::size_t d = kept_dofs[i] / nb;
    auto it = std::find(sector_dofs.begin(), sector_dofs.end(), d);
    row_of[i] = static_cast<std::size_t>(it - sector_dofs.begin());
    if (it == sector_dofs.end()) sector_dofs.push_back(d);
  }
  const auto n = static_cast<Eigen::Index>(tuned_.size());
  const auto kept = static_cast<Eigen::Index>(kept_dofs.size());
  Eigen::MatrixXd tuned_rows(kept, n);
  const double theta = 2.0 * std::numbers::pi / sectors_;
  Eigen::Index a = 0;
  while (a < n) {
    const int h = tuned_[static_cast<std::size_t>(a)].h;
    const frichb_modal_basis b = sector_->modal_basis(h, sector_dofs);
    const auto m = static_cast<Eigen::Index>(b.n_modes);
    for (; a < n && tuned_[static_cast<std::size_t>(a)].h == h; ++a) {
      const TunedMode& t = tuned_[static_cast<std::size_t>(a)];
      for (Eigen::Index i = 0; i < kept; ++i) {
        const auto j = static_cast<double>(kept_dofs[static_cast<std::size_t>(i)] % nb);
        const auto row = static_cast<Eigen::Index>(row_of[static_cast<std::size_t>(i)]);
        const Complex phi(b.mode_rows_real[row * m + t.r],
                          b.mode_rows_imag ? b.mode_rows_imag[row * m + t.r] : 0.0);
        // A standing index's modes are real: its one standing wave is the real part.
        if ((h == 0 || 2 * h == sectors_) && std::abs(phi.imag()) > 1e-9 * std::abs(phi))
          throw std::invalid_argument("the sector's modes of harmonic index " + std::to_string(h) +
                                      " are complex: a mistuned disk needs them real");
        const Complex u = phi * std::polar(1.0, -h * j * theta);
        tuned_rows(i, a) = t.scale * (t.imaginary ? u.imag() : u.real());
      }
    }
  }
  rows_ = tuned_rows * vectors_;
  // Row-major arrays, as the ABI reads them.
  rows_.transposeInPlace();
  damping_matrix_ = Eigen::MatrixXd(damping_.asDiagonal());
  frichb_modal_basis out{};
  out.struct_size = sizeof(out);
  out.n_modes = static_cast<std::size_t>(n);
  out.natural_frequencies = frequencies_.data();
  out.modal_damping = damping_matrix_.data();
  out.mode_rows_real = rows_.data();
  return out;
}

std::unique_ptr<StructureModel> instantiate_structure(const Scene& scene) {
  auto instance =
      std::make_unique<StructureInstance>(scene.structure.plugin, scene.structure.values);
  if (!scene.mistuning) return instance;
  YAML::Node root = scene.root;  // a handle: its operator[] on a const node would throw
  const YamlContext ctx{scene.file.string()};
  try {
    return std::make_unique<MistunedDisk>(std::move(instance), *scene.mistuning);
  } catch (const PluginError& e) {
    ctx.fail(root["mistuning"], "mistuning", e.what());
  } catch (const std::invalid_argument& e) {
    ctx.fail(root["mistuning"], "mistuning", e.what());
  }
}

}  // namespace frichb::core
