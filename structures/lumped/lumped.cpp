// lumped: spring-mass(-damper) models written in the scene. Each DOF is a scalar
// coordinate with a mass; springs and viscous dampers join two DOFs or a DOF and the ground.
// The modal basis comes from the generalised eigenproblem K phi = w^2 M phi with
// mass-normalised modes; viscous dampers are projected on the modes (the full modal damping
// matrix, so non-proportional damping stays exact when all modes are kept) and modal
// damping ratios add 2 z_r w_r on its diagonal.
#include <Eigen/Dense>
#include <cmath>
#include <stdexcept>
#include <string>

#include "frichb/plugin/modal_basis.hpp"
#include "frichb/plugin/sdk.hpp"

namespace {

using frichb::sdk::Param;

const frichb_param_spec kSpringFields[] = {
    Param::text_list("between", "two ends: DOF indices (0-based) or 'ground'").count(2, 2),
    Param::real("k", "N/m", "stiffness").at_least(0),
};
const frichb_param_spec kDamperFields[] = {
    Param::text_list("between", "two ends: DOF indices (0-based) or 'ground'").count(2, 2),
    Param::real("c", "N s/m", "viscous damping coefficient").at_least(0),
};

std::vector<frichb_param_spec> lumped_schema() {
  return {
      Param::real_list("masses", "kg", "mass of each DOF; their number sets the DOF count")
          .greater_than(0)
          .count(1, 0),
      Param::records("springs", "linear springs between DOFs or to the ground", kSpringFields, 2)
          .optional(),
      Param::records("dampers", "viscous dampers between DOFs or to the ground", kDamperFields, 2)
          .optional(),
      Param::real_list("modal_damping", "",
                       "modal damping ratio: one value for every mode, or one per mode")
          .at_least(0)
          .optional(),
  };
}

class Lumped final : public frichb::sdk::StructureProvider {
 public:
  explicit Lumped(const frichb::sdk::Params& p) {
    const auto masses = p.reals("masses");
    const auto n = static_cast<Eigen::Index>(masses.size());
    // Dense n x n matrices and a dense eigen-solve (n^3): beyond a few thousand DOFs that is
    // minutes and gigabytes, which a sparse FE provider does in seconds.
    constexpr Eigen::Index kMaxDofs = 5000;
    if (n > kMaxDofs)
      throw std::invalid_argument(
          "masses has " + std::to_string(n) + " entries: the lumped provider forms dense " +
          std::to_string(n) + " x " + std::to_string(n) + " matrices (at most " +
          std::to_string(kMaxDofs) + " DOFs); give a large model as sparse matrices to fe_sector");
    mass_ = Eigen::MatrixXd::Zero(n, n);
    for (Eigen::Index i = 0; i < n; ++i) mass_(i, i) = masses[static_cast<std::size_t>(i)];
    stiffness_ = Eigen::MatrixXd::Zero(n, n);
    damping_ = Eigen::MatrixXd::Zero(n, n);
    assemble(p, "springs", "k", stiffness_);
    assemble(p, "dampers", "c", damping_);

    Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> eig(stiffness_, mass_);
    if (eig.info() != Eigen::Success) throw std::runtime_error("eigen-solve failed");
    const Eigen::VectorXd& lambda = eig.eigenvalues();
    const double scale = std::max(1.0, lambda.cwiseAbs().maxCoeff());
    Eigen::VectorXd frequencies(n);
    for (Eigen::Index r = 0; r < n; ++r) {
      if (lambda(r) < -1e-10 * scale)
        throw std::runtime_error("negative eigenvalue: the stiffness matrix is not positive");
      frequencies(r) = std::sqrt(std::max(0.0, lambda(r)));
    }
    modes_ = eig.eigenvectors();  // mass-normalised: modes^T M modes = I
    const auto ratios = p.reals("modal_damping");
    if (!ratios.empty() && ratios.size() != 1 && ratios.size() != masses.size())
      throw std::invalid_argument("modal_damping has " + std::to_string(ratios.size()) +
                                  " values; give 1 or one per mode (" +
                                  std::to_string(masses.size()) + ")");
    // The same for every call: only the mode rows depend on the kept DOFs.
    basis_.set_frequencies(frequencies);
    const Eigen::MatrixXd projected_damping = modes_.transpose() * damping_ * modes_;
    basis_.set_damping_matrix(projected_damping);
    basis_.add_damping_ratios(ratios);
  }

  size_t dof_count() const override { return static_cast<size_t>(mass_.rows()); }

  frichb_modal_basis modal_basis(int harmonic_index, const size_t* kept, size_t n_kept) override {
    if (harmonic_index != 0)
      throw std::invalid_argument("the lumped provider has no cyclic symmetry (harmonic index " +
                                  std::to_string(harmonic_index) + " requested)");
    for (size_t i = 0; i < n_kept; ++i)
      if (kept[i] >= dof_count())
        throw std::out_of_range("DOF " + std::to_string(kept[i]) +
                                " does not exist (the model has " + std::to_string(dof_count()) +
                                " DOFs)");
    // Real modes; all modes kept, so no residual flexibility: nothing is truncated.
    basis_.gather_mode_rows(modes_, kept, n_kept);
    return basis_.basis();
  }

 private:
  long end_index(const std::string& end, Eigen::Index n) const {
    if (end == "ground") return -1;
    std::size_t used = 0;
    long i = -1;
    try {
      i = std::stol(end, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != end.size() || i < 0 || i >= n)
      throw std::invalid_argument("end '" + end + "' is neither 'ground' nor a DOF index in [0, " +
                                  std::to_string(n - 1) + "]");
    return i;
  }

  void assemble(const frichb::sdk::Params& p, const char* list, const char* value,
                Eigen::MatrixXd& matrix) const {
    const Eigen::Index n = matrix.rows();
    for (size_t r = 0; r < p.record_count(list); ++r) {
      const auto rec = p.record(list, r);
      const auto ends = rec.texts("between");
      const double k = rec.real(value);
      const long a = end_index(ends[0], n), b = end_index(ends[1], n);
      if (a == b)
        throw std::invalid_argument(std::string(list) + "[" + std::to_string(r) +
                                    "] joins an end to itself");
      if (a >= 0) matrix(a, a) += k;
      if (b >= 0) matrix(b, b) += k;
      if (a >= 0 && b >= 0) {
        matrix(a, b) -= k;
        matrix(b, a) -= k;
      }
    }
  }

  Eigen::MatrixXd mass_, stiffness_, damping_, modes_;
  frichb::sdk::ModalBasisBuilder basis_;
};

}  // namespace

FRICHB_STRUCTURE_PLUGIN(Lumped, lumped, "1.0.0",
                        "spring-mass-damper model written in the scene (masses, springs, "
                        "dampers, modal damping)",
                        lumped_schema)
