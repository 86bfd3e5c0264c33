// lumped_cyclic: one sector of a tuned bladed disk written in the scene as a spring-mass
// model, with cyclic symmetry. Each DOF is a scalar coordinate with a mass; springs join two
// DOFs of the sector or a DOF and the ground; coupling springs join DOF i of sector s to DOF
// j of sector s+1 (shroud or disk coupling). The block-circulant full disk is represented by
//   K0 = within-sector springs + k at (i, i) and (j, j) of every coupling spring,
//   K1(i, j) = -k for every coupling spring,  M0 = diag(masses),  M1 = 0,
// and harmonic index h by the Hermitian K_h = K0 + e^{-i h phi} K1 + e^{i h phi} K1^T,
// phi = 2 pi / sectors (thesis eq. 2.24). The modal basis of h is the Hermitian generalised
// eigen-solution K_h phi = w^2 M0 phi with mass-normalised complex modes (real for h = 0
// and h = sectors/2); modal damping ratios put 2 z_r w_r on the modal damping diagonal.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "frichb/plugin/modal_basis.hpp"
#include "frichb/plugin/sdk.hpp"

namespace {

using frichb::sdk::Param;

const frichb_param_spec kSpringFields[] = {
    Param::text_list("between", "two ends: DOF indices (0-based) or 'ground'").count(2, 2),
    Param::real("k", "N/m", "stiffness").at_least(0),
};
const frichb_param_spec kCouplingFields[] = {
    Param::text_list("between", "[i, j]: DOF i (0-based) of sector s and DOF j of sector s+1")
        .count(2, 2),
    Param::real("k", "N/m", "stiffness").at_least(0),
};

std::vector<frichb_param_spec> lumped_cyclic_schema() {
  return {
      Param::integer("sectors", "number of identical sectors nb of the full disk").at_least(2),
      Param::real_list("masses", "kg",
                       "mass of each DOF of one sector; their number sets the DOF count")
          .greater_than(0)
          .count(1, 0),
      Param::records("springs", "linear springs within the sector, between DOFs or to the ground",
                     kSpringFields, 2)
          .optional(),
      Param::records("coupling", "linear springs between DOF i of sector s and DOF j of sector s+1",
                     kCouplingFields, 2)
          .optional(),
      Param::real_list("modal_damping", "",
                       "modal damping ratio: one value for every mode, or one per mode (the "
                       "same for every harmonic index)")
          .at_least(0)
          .optional(),
      Param::text_list("blade_dofs",
                       "the DOFs (0-based) of the sector's blade: a mistuning factor scales "
                       "every spring with an end on one of them (springs, not coupling)")
          .optional(),
  };
}

class LumpedCyclic final : public frichb::sdk::StructureProvider {
 public:
  explicit LumpedCyclic(const frichb::sdk::Params& p) : sectors_(p.integer("sectors")) {
    const auto masses = p.reals("masses");
    const auto n = static_cast<Eigen::Index>(masses.size());
    mass_ = Eigen::VectorXd::Map(masses.data(), n);
    k0_ = Eigen::MatrixXd::Zero(n, n);
    k1_ = Eigen::MatrixXd::Zero(n, n);
    blade_ = Eigen::MatrixXd::Zero(n, n);
    for (const auto& d : p.texts("blade_dofs")) {
      try {
        blade_dofs_.push_back(end_index(d, n, false));
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(std::string("blade_dofs: ") + e.what());
      }
    }
    assemble_springs(p);
    assemble_coupling(p);

    const auto ratios = p.reals("modal_damping");
    if (!ratios.empty() && ratios.size() != 1 && ratios.size() != masses.size())
      throw std::invalid_argument("modal_damping has " + std::to_string(ratios.size()) +
                                  " values; give 1 or one per mode (" +
                                  std::to_string(masses.size()) + ")");
    ratios_ = ratios;

    // Every harmonic index is solved now, so that a non-positive stiffness is refused with the
    // parameters rather than at the first modal_basis() call.
    bases_.reserve(static_cast<std::size_t>(sectors_));
    for (long long h = 0; h < sectors_; ++h) bases_.push_back(solve(h));
  }

  size_t dof_count() const override { return static_cast<size_t>(mass_.size()); }
  size_t sector_count() const override { return static_cast<size_t>(sectors_); }

  frichb_modal_basis modal_basis(int harmonic_index, const size_t* kept, size_t n_kept) override {
    if (harmonic_index < 0 || harmonic_index >= sectors_)
      throw std::invalid_argument("harmonic index " + std::to_string(harmonic_index) +
                                  " is outside [0, " + std::to_string(sectors_) +
                                  "): the lumped_cyclic model has " + std::to_string(sectors_) +
                                  " sectors");
    for (size_t i = 0; i < n_kept; ++i)
      if (kept[i] >= dof_count())
        throw std::out_of_range("DOF " + std::to_string(kept[i]) +
                                " does not exist (the model has " + std::to_string(dof_count()) +
                                " DOFs)");
    const Basis& basis = bases_[static_cast<std::size_t>(harmonic_index)];
    basis_.set_frequencies(basis.frequencies);
    basis_.add_damping_ratios(ratios_);
    // All modes kept, so no residual flexibility: nothing is truncated.
    if (basis.real)
      basis_.gather_mode_rows(basis.modes.real(), kept, n_kept);
    else
      basis_.gather_mode_rows(basis.modes, kept, n_kept);
    return basis_.basis();
  }

  // S = Phi_h1^H K_b Phi_h2 (or Phi_h1^T K_b Phi_h2) with K_b the springs on blade_dofs.
  void blade_stiffness(int h1, int h2, bool conjugate_first, size_t rows, size_t cols, double* real,
                       double* imag) override {
    if (blade_dofs_.empty())
      throw std::invalid_argument(
          "lumped_cyclic has no blade_dofs: name the blade's DOFs to mistune it");
    for (int h : {h1, h2})
      if (h < 0 || h >= sectors_)
        throw std::invalid_argument("harmonic index " + std::to_string(h) + " is outside [0, " +
                                    std::to_string(sectors_) + ")");
    const Eigen::MatrixXcd& a = bases_[static_cast<std::size_t>(h1)].modes;
    const Eigen::MatrixXcd& b = bases_[static_cast<std::size_t>(h2)].modes;
    const Eigen::MatrixXcd kb = blade_.cast<std::complex<double>>() * b;
    if (rows != static_cast<size_t>(a.cols()) || cols != static_cast<size_t>(b.cols()))
      throw std::invalid_argument("blade_stiffness asked for " + std::to_string(rows) + " x " +
                                  std::to_string(cols) + " values; the harmonic indices have " +
                                  std::to_string(a.cols()) + " and " + std::to_string(b.cols()) +
                                  " modes");
    const Eigen::MatrixXcd out =
        conjugate_first ? Eigen::MatrixXcd(a.adjoint() * kb) : Eigen::MatrixXcd(a.transpose() * kb);
    for (Eigen::Index i = 0; i < out.rows(); ++i)
      for (Eigen::Index j = 0; j < out.cols(); ++j) {
        real[i * out.cols() + j] = out(i, j).real();
        imag[i * out.cols() + j] = out(i, j).imag();
      }
  }

 private:
  struct Basis {
    Eigen::VectorXd frequencies;
    Eigen::MatrixXcd modes;  // n x n, mass-normalised: modes^H M0 modes = I
    bool real = false;       // h = 0 or h = sectors/2: K_h is real, so are the modes
  };

  // e^{-i h phi}, exact (+-1) where K_h is real.
  std::complex<double> phase(long long h) const {
    if (h == 0) return {1.0, 0.0};
    if (2 * h == sectors_) return {-1.0, 0.0};
    return std::polar(
        1.0, -2.0 * std::numbers::pi * static_cast<double>(h) / static_cast<double>(sectors_));
  }

  Basis solve(long long h) const {
    const Eigen::Index n = mass_.size();
    const std::complex<double> e = phase(h);
    const Eigen::MatrixXcd k = k0_.cast<std::complex<double>>() +
                               e * k1_.cast<std::complex<double>>() +
                               std::conj(e) * k1_.transpose().cast<std::complex<double>>();
    // M0 is diagonal: A = M0^{-1/2} K_h M0^{-1/2} is Hermitian with the same eigenvalues.
    const Eigen::VectorXd inv_sqrt_m = mass_.cwiseSqrt().cwiseInverse();
    Basis b;
    b.real = e.imag() == 0.0;
    Eigen::VectorXd lambda;
    if (b.real) {
      const Eigen::MatrixXd a = inv_sqrt_m.asDiagonal() * k.real() * inv_sqrt_m.asDiagonal();
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(a);
      if (eig.info() != Eigen::Success)
        throw std::runtime_error("eigen-solve failed for harmonic index " + std::to_string(h));
      lambda = eig.eigenvalues();
      b.modes = (inv_sqrt_m.asDiagonal() * eig.eigenvectors()).cast<std::complex<double>>();
    } else {
      const Eigen::MatrixXcd a = inv_sqrt_m.asDiagonal() * k * inv_sqrt_m.asDiagonal();
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXcd> eig(a);
      if (eig.info() != Eigen::Success)
        throw std::runtime_error("eigen-solve failed for harmonic index " + std::to_string(h));
      lambda = eig.eigenvalues();
      b.modes = inv_sqrt_m.asDiagonal() * eig.eigenvectors();
    }
    const double scale = std::max(1.0, lambda.cwiseAbs().maxCoeff());
    b.frequencies.resize(n);
    for (Eigen::Index r = 0; r < n; ++r) {
      if (lambda(r) < -1e-10 * scale)
        throw std::runtime_error("negative eigenvalue at harmonic index " + std::to_string(h) +
                                 ": the stiffness matrix is not positive");
      b.frequencies(r) = std::sqrt(std::max(0.0, lambda(r)));
    }
    return b;
  }

  // A DOF index in [0, n), or -1 for 'ground' when `ground_allowed`.
  static long end_index(const std::string& end, Eigen::Index n, bool ground_allowed) {
    if (ground_allowed && end == "ground") return -1;
    std::size_t used = 0;
    long i = -1;
    try {
      i = std::stol(end, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != end.size() || i < 0 || i >= n)
      throw std::invalid_argument("end '" + end + "' is " +
                                  (ground_allowed ? "neither 'ground' nor " : "not ") +
                                  "a DOF index in [0, " + std::to_string(n - 1) + "]");
    return i;
  }

  void assemble_springs(const frichb::sdk::Params& p) {
    const Eigen::Index n = k0_.rows();
    for (size_t r = 0; r < p.record_count("springs"); ++r) {
      const auto rec = p.record("springs", r);
      const auto ends = rec.texts("between");
      const double k = rec.real("k");
      const long a = end_index(ends[0], n, true), b = end_index(ends[1], n, true);
      if (a == b)
        throw std::invalid_argument("springs[" + std::to_string(r) + "] joins an end to itself");
      add_spring(k0_, a, b, k);
      if (on_blade(a) || on_blade(b)) add_spring(blade_, a, b, k);
    }
  }

  bool on_blade(long dof) const {
    return dof >= 0 && std::find(blade_dofs_.begin(), blade_dofs_.end(), dof) != blade_dofs_.end();
  }

  // k (e_a - e_b)(e_a - e_b)^T, e_ground = 0.
  static void add_spring(Eigen::MatrixXd& stiffness, long a, long b, double k) {
    if (a >= 0) stiffness(a, a) += k;
    if (b >= 0) stiffness(b, b) += k;
    if (a >= 0 && b >= 0) {
      stiffness(a, b) -= k;
      stiffness(b, a) -= k;
    }
  }

  void assemble_coupling(const frichb::sdk::Params& p) {
    const Eigen::Index n = k0_.rows();
    for (size_t r = 0; r < p.record_count("coupling"); ++r) {
      const auto rec = p.record("coupling", r);
      const auto ends = rec.texts("between");
      const double k = rec.real("k");
      long i = -1, j = -1;
      try {
        i = end_index(ends[0], n, false);
        j = end_index(ends[1], n, false);
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument("coupling[" + std::to_string(r) + "]: " + e.what() +
                                    " (a coupling spring joins DOF i of sector s to DOF j of "
                                    "sector s+1, never the ground)");
      }
      // Sector s, DOF i <-> sector s+1, DOF j: i == j is a genuine spring between sectors.
      k0_(i, i) += k;
      k0_(j, j) += k;
      k1_(i, j) -= k;
    }
  }

  long long sectors_;
  Eigen::VectorXd mass_;
  Eigen::MatrixXd k0_, k1_;
  Eigen::MatrixXd blade_;  // K_b: the springs with an end on a blade DOF
  std::vector<long> blade_dofs_;
  std::vector<double> ratios_;
  std::vector<Basis> bases_;
  frichb::sdk::ModalBasisBuilder basis_;
};

}  // namespace

FRICHB_STRUCTURE_PLUGIN(LumpedCyclic, lumped_cyclic, "1.0.0",
                        "one sector of a cyclic spring-mass model (sectors, masses, springs, "
                        "coupling to the next sector, modal damping)",
                        lumped_cyclic_schema)
