// fe_sector: one sector of a tuned bladed disk given by its finite-element mass and stiffness
// matrices (Matrix Market files exported from an FE code), with cyclic symmetry over `sectors`
// sectors. The sector's left boundary DOFs are the right boundary DOFs of the previous sector,
// paired in order: right DOF j of sector s is left DOF j of sector s+1. With FricHB's
// convention (sector s+1 moves like sector s times e^{-i h phi}, phi = 2 pi / sectors) the
// left boundary of sector s follows its right boundary as
//   x_left(s) = x_right(s-1) = e^{+i h phi} x_right(s),
// so x = T_h q with q the independent DOFs (all but the left ones) and
//   K_h = T_h^H K T_h,  M_h = T_h^H M T_h  (Hermitian; real for h = 0 and h = sectors/2),
// which is K0 + e^{-i h phi} K1 + e^{i h phi} K1^T of the ABI on the independent DOFs. The
// lowest `modes` eigenpairs of (K_h, M_h) come from a dense solve for small sectors, or from
// Spectra's shift-invert Lanczos on the real symmetric embedding [[Re, -Im], [Im, Re]] of the
// Hermitian pair followed by a Rayleigh-Ritz step that recovers complex modes. Modes are
// mass-normalised (Phi^H M_h Phi = I) and expanded to every sector DOF with T_h. Optional:
// the static residual flexibility of the truncated modes (complex for 0 < h < nb/2, through the
// ABI 1.1 imaginary part), and a disk cache of each harmonic index's solution keyed by an FNV-1a
// hash of the matrix files' contents and the solver inputs (see README.md).
#include <Spectra/MatOp/SparseSymMatProd.h>
#include <Spectra/SymGEigsShiftSolver.h>
#include <Eigen/CholmodSupport>
#include <Eigen/Dense>
#include <Eigen/Sparse>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <complex>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "frichb/plugin/matrix_market.hpp"
#include "frichb/plugin/modal_basis.hpp"
#include "frichb/plugin/sdk.hpp"

namespace {

using frichb::sdk::Param;
using cd = std::complex<double>;
using Eigen::Index;
template <class S>
using SpMat = Eigen::SparseMatrix<S>;
template <class S>
using Mat = Eigen::Matrix<S, Eigen::Dynamic, Eigen::Dynamic>;

// Independent DOFs up to which `solver: auto` solves densely.
constexpr Index kDenseLimit = 200;

// K_h counts as singular (a rigid-body mode: no static residual flexibility) when its lowest
// eigenvalue w_1^2 is at most kSingularRatio times the highest retained one, or within
// kRoundOff rounding errors of zero on the scale max_i K_ii / M_ii of the sector's eigenvalues
// (a rigid-body mode's computed w_1^2 is noise of that size). G_h = K_h^-1 - (the retained
// modes' part) cancels the 1 / w_1^2 term of both, which leaves an error of about
// eps w_kept^2 / w_1^2 relative to G_h: 2e-7 at the ratio. (The scale alone is no measure of
// a low mode: the small elements of a fine contact mesh raise it by orders of magnitude, past
// the first mode of the blade itself.)
constexpr double kSingularRatio = 1e-9;
constexpr double kRoundOff = 1e3;

// Disk cache format: bump when the file layout or the solution it holds changes.
constexpr std::uint64_t kCacheFormat = 1;
constexpr char kCacheMagic[8] = {'F', 'R', 'I', 'C', 'H', 'B', 'F', 'S'};

std::vector<frichb_param_spec> fe_sector_schema() {
  return {
      Param::path("mass",
                  "Matrix Market file of the sector mass matrix (real symmetric, every DOF of "
                  "the sector including both boundaries); relative to the scene file's folder"),
      Param::path("stiffness", "Matrix Market file of the sector stiffness matrix, same DOFs"),
      Param::integer("sectors",
                     "number of identical sectors nb of the full disk (1: no cyclic "
                     "symmetry); harmonic indices run from 0 to nb - 1")
          .at_least(1)
          .at_most(1.0e6)
          .defaults_to(1),
      Param::real_list("left_dofs", "",
                       "DOF indices (0-based matrix rows) of the left cyclic boundary; left DOF j "
                       "of sector s+1 is right DOF j of sector s")
          .at_least(0)
          .optional(),
      Param::real_list("right_dofs", "",
                       "DOF indices (0-based) of the right cyclic boundary, paired in order with "
                       "left_dofs")
          .at_least(0)
          .optional(),
      Param::path("cyclic_pairs",
                  "text file of the cyclic boundary, one pair 'left right' of 0-based DOF "
                  "indices per line ('#' starts a comment), instead of left_dofs/right_dofs; "
                  "relative to the scene file's folder")
          .defaults_to_text(""),
      Param::integer("modes", "number of lowest modes kept per harmonic index").at_least(1),
      Param::real_list("modal_damping", "",
                       "modal damping ratio: one value for every mode, or one per kept mode (the "
                       "same for every harmonic index; default: undamped)")
          .at_least(0)
          .optional(),
      Param::text("solver",
                  "eigen-solver: dense, sparse (Spectra shift-invert Lanczos) or auto (dense up "
                  "to 200 independent DOFs)")
          .choices("auto|dense|sparse")
          .defaults_to_text("auto"),
      Param::boolean("residual_flexibility",
                     "add the static residual flexibility of the truncated modes at the kept "
                     "DOFs (every harmonic index: real for 0 and sectors/2, Hermitian otherwise; "
                     "none when K_h is singular or every mode is kept)")
          .defaults_to(1.0),
      Param::path("cache_dir",
                  "folder of a disk cache of the modal solution of each harmonic index, keyed "
                  "by a hash of the matrix files' contents and the solver inputs (empty: no "
                  "cache)")
          .defaults_to_text(""),
  };
}

// ---------------------------------------------------------------------------------------
// Matrix Market

bool blank(const std::string& line) {
  return std::all_of(line.begin(), line.end(),
                     [](unsigned char c) { return std::isspace(c) != 0; });
}

// A real Matrix Market matrix (frichb/plugin/matrix_market.hpp: coordinate or array; real or
// integer; general or symmetric), with symmetric storage expanded to both triangles and
// repeated coordinates summed.
SpMat<double> read_market(const std::string& file, const std::string& what) {
  namespace fs = std::filesystem;
  std::error_code ec;
  // Checked before opening: opening a FIFO blocks until a writer comes.
  const bool regular = fs::is_regular_file(fs::path(file), ec);
  std::ifstream in;
  if (regular) in.open(file, std::ios::binary);
  if (!regular || !in) {
    std::string where;
    if (fs::path(file).is_relative()) {
      const fs::path cwd = fs::current_path(ec);
      where = " (a relative path is relative to the current working directory" +
              (ec ? std::string() : ", here '" + cwd.string() + "'") + ")";
    }
    throw std::invalid_argument("cannot open the " + what + " matrix file '" + file + "'" + where +
                                " (or it is not a regular file)");
  }
  std::vector<Eigen::Triplet<double>> triplets;
  Index rows = 0, columns = 0;
  bool symmetric = false, array = false;
  try {
    frichb::sdk::read_matrix_market(
        in,
        [&](const frichb::sdk::MatrixMarketHeader& h) {
          rows = static_cast<Index>(h.rows);
          columns = static_cast<Index>(h.columns);
          symmetric = h.symmetric;
          array = !h.coordinate;
          // The reader has checked that the file can hold the entries (arrays skip zeros).
          if (h.coordinate)
            triplets.reserve(static_cast<std::size_t>(symmetric ? 2 * h.entries : h.entries));
        },
        [&](long long i, long long j, double v, long /*line*/) {
          if (array && v == 0.0) return;
          const auto r = static_cast<Index>(i - 1), c = static_cast<Index>(j - 1);
          triplets.emplace_back(r, c, v);
          if (symmetric && r != c) triplets.emplace_back(c, r, v);
        });
  } catch (const frichb::sdk::MatrixMarketError& e) {
    throw std::invalid_argument(what + " matrix " + file + ":" + std::to_string(e.line()) + ": " +
                                e.what());
  }
  SpMat<double> a(rows, columns);
  a.setFromTriplets(triplets.begin(), triplets.end());
  a.makeCompressed();
  return a;
}

// Refuses a non-square or unsymmetric matrix; returns the exactly symmetric (A + A^T) / 2.
SpMat<double> checked_symmetric(const SpMat<double>& a, const std::string& what,
                                const std::string& file) {
  if (a.rows() != a.cols())
    throw std::invalid_argument("the " + what + " matrix '" + file + "' is " +
                                std::to_string(a.rows()) + " x " + std::to_string(a.cols()) +
                                ", not square");
  const SpMat<double> at = a.transpose();
  const SpMat<double> d = a - at;
  double largest = 0.0;
  for (Index k = 0; k < a.outerSize(); ++k)
    for (SpMat<double>::InnerIterator it(a, k); it; ++it)
      largest = std::max(largest, std::abs(it.value()));
  double worst = 0.0;
  Index wr = 0, wc = 0;
  for (Index k = 0; k < d.outerSize(); ++k)
    for (SpMat<double>::InnerIterator it(d, k); it; ++it)
      if (std::abs(it.value()) > worst) {
        worst = std::abs(it.value());
        wr = it.row();
        wc = it.col();
      }
  if (worst > 1e-8 * largest) {
    std::ostringstream m;
    m.precision(6);
    m << "the " << what << " matrix '" << file << "' is not symmetric: entries (" << wr + 1 << ", "
      << wc + 1 << ") = " << a.coeff(wr, wc) << " and (" << wc + 1 << ", " << wr + 1
      << ") = " << a.coeff(wc, wr) << " (1-based) differ by more than 1e-8 times its largest "
      << "entry " << largest;
    throw std::invalid_argument(m.str());
  }
  SpMat<double> s = 0.5 * (a + at);
  s.makeCompressed();
  return s;
}

// Refuses a mass matrix that is not positive definite (an indefinite one gives modes of
// negative kinetic energy and a wrong response, not an error): a zero or negative pivot of
// its LDL^T factorisation.
void check_positive_definite(const SpMat<double>& mass, const std::string& file) {
  const Eigen::SimplicialLDLT<SpMat<double>> ldlt(mass);
  const Eigen::VectorXd d =
      ldlt.info() == Eigen::Success ? Eigen::VectorXd(ldlt.vectorD()) : Eigen::VectorXd();
  const double largest = d.size() ? d.cwiseAbs().maxCoeff() : 0.0;
  Index worst = -1;
  for (Index i = 0; i < d.size(); ++i)
    if (!(d(i) > 1e-14 * largest) && (worst < 0 || d(i) < d(worst))) worst = i;
  if (ldlt.info() == Eigen::Success && largest > 0.0 && worst < 0) return;
  std::ostringstream m;
  m.precision(6);
  m << "the mass matrix '" << file << "' is not positive definite";
  if (worst >= 0)
    m << ": its LDL^T factorisation has the pivot " << d(worst) << " (largest " << largest
      << "); every DOF needs a positive mass and the matrix no negative direction (a sign "
         "or unit error in the export?)";
  throw std::invalid_argument(m.str());
}

// ---------------------------------------------------------------------------------------
// Disk cache

// 64-bit FNV-1a, fed with length-prefixed fields (so that field boundaries count).
class Fnv1a {
 public:
  void bytes(const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) {
      h_ ^= p[i];
      h_ *= 1099511628211ULL;
    }
  }
  void u64(std::uint64_t v) { bytes(&v, sizeof v); }
  void text(const std::string& s) {
    u64(s.size());
    bytes(s.data(), s.size());
  }
  void indices(const std::vector<Index>& v) {
    u64(v.size());
    for (const Index i : v) u64(static_cast<std::uint64_t>(i));
  }
  // The contents of a file, read in chunks.
  void file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::invalid_argument("cannot read '" + path + "' to key the disk cache");
    std::vector<char> chunk(1 << 16);
    std::uint64_t total = 0;
    while (in) {
      in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
      const auto got = static_cast<std::size_t>(in.gcount());
      bytes(chunk.data(), got);
      total += got;
    }
    if (!in.eof()) throw std::invalid_argument("cannot read '" + path + "' to key the disk cache");
    u64(total);
  }
  std::uint64_t value() const { return h_; }

 private:
  std::uint64_t h_ = 14695981039346656037ULL;
};

void put_u64(std::string& out, std::uint64_t v) {
  char b[sizeof v];
  std::memcpy(b, &v, sizeof v);
  out.append(b, sizeof v);
}

std::uint64_t get_u64(const std::string& in, std::size_t& at) {
  std::uint64_t v = 0;
  std::memcpy(&v, in.data() + at, sizeof v);
  at += sizeof v;
  return v;
}

// ---------------------------------------------------------------------------------------
// Eigen-solvers

// (A - sigma B)^{-1} x by a sparse LDL^T factorisation (A - sigma B is positive definite for
// a positive semi-definite A, positive definite B and sigma < 0).
class ShiftInvertLdlt {
 public:
  using Scalar = double;
  ShiftInvertLdlt(const SpMat<double>& a, const SpMat<double>& b) : a_(a), b_(b) {}
  Index rows() const { return a_.rows(); }
  Index cols() const { return a_.cols(); }
  void set_shift(double sigma) {
    const SpMat<double> shifted = a_ - sigma * b_;
    ldlt_.compute(shifted);
    if (ldlt_.info() != Eigen::Success)
      throw std::runtime_error("the sparse factorisation of K_h - sigma M_h failed");
  }
  void perform_op(const double* x_in, double* y_out) const {
    Eigen::Map<const Eigen::VectorXd> x(x_in, a_.rows());
    Eigen::Map<Eigen::VectorXd> y(y_out, a_.rows());
    y = ldlt_.solve(x);
  }

 private:
  const SpMat<double>& a_;
  const SpMat<double>& b_;
  Eigen::SimplicialLDLT<SpMat<double>> ldlt_;
};

// Real symmetric embedding [[Re, -Im], [Im, Re]] of a Hermitian matrix: (a; b) is an
// eigenvector of the embedded pair iff a + i b is one of the Hermitian pair.
SpMat<double> embed(const SpMat<cd>& a) {
  const Index m = a.rows();
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(static_cast<std::size_t>(4 * a.nonZeros()));
  for (Index k = 0; k < a.outerSize(); ++k)
    for (SpMat<cd>::InnerIterator it(a, k); it; ++it) {
      const Index r = it.row(), c = it.col();
      const double re = it.value().real(), im = it.value().imag();
      t.emplace_back(r, c, re);
      t.emplace_back(r + m, c + m, re);
      if (im != 0.0) {
        t.emplace_back(r, c + m, -im);
        t.emplace_back(r + m, c, im);
      }
    }
  SpMat<double> e(2 * m, 2 * m);
  e.setFromTriplets(t.begin(), t.end());
  e.makeCompressed();
  return e;
}

// The `nev` lowest eigenpairs of the real symmetric pair (a, b) by shift-invert Lanczos.
Mat<double> spectra_lowest(const SpMat<double>& a, const SpMat<double>& b, Index nev, int h) {
  // A small negative shift keeps A - sigma B positive definite even with rigid-body modes.
  double ratio = 0.0;
  for (Index i = 0; i < a.rows(); ++i)
    if (b.coeff(i, i) > 0.0) ratio = std::max(ratio, a.coeff(i, i) / b.coeff(i, i));
  const double sigma = -1e-10 * std::max(ratio, 1e-300);
  ShiftInvertLdlt op(a, b);
  Spectra::SparseSymMatProd<double> bop(b);
  const Index ncv = std::min(a.rows(), std::max(2 * nev + 1, nev + 20));
  Spectra::SymGEigsShiftSolver<ShiftInvertLdlt, Spectra::SparseSymMatProd<double>,
                               Spectra::GEigsMode::ShiftInvert>
      solver(op, bop, nev, ncv, sigma);
  solver.init();
  const Index converged =
      solver.compute(Spectra::SortRule::LargestMagn, 1000, 1e-12, Spectra::SortRule::SmallestAlge);
  if (solver.info() != Spectra::CompInfo::Successful)
    throw std::runtime_error(
        "the sparse eigen-solver (Spectra) did not converge for harmonic "
        "index " +
        std::to_string(h) + ": " + std::to_string(converged) + " of " + std::to_string(nev) +
        " eigenpairs converged");
  return solver.eigenvectors();
}

// Lowest k eigenpairs of the Hermitian pair (kh, mh) in the span of v (an invariant subspace
// spanned by eigenvectors, possibly with complex-dependent columns): an M-orthonormal basis
// of span(v) followed by a Rayleigh-Ritz step.
template <class S>
void rayleigh_ritz(const SpMat<S>& kh, const SpMat<S>& mh, const Mat<S>& v, Index k, int h,
                   Eigen::VectorXd& lambda, Mat<S>& modes) {
  Mat<S> g = v.adjoint() * (mh * v);
  g = (0.5 * (g + g.adjoint())).eval();
  const Eigen::SelfAdjointEigenSolver<Mat<S>> ge(g);
  const Eigen::VectorXd& gv = ge.eigenvalues();
  const double top = gv.maxCoeff();
  std::vector<Index> keep;
  for (Index i = 0; i < gv.size(); ++i)
    if (gv(i) > 1e-9 * top) keep.push_back(i);
  if (static_cast<Index>(keep.size()) < k)
    throw std::runtime_error("harmonic index " + std::to_string(h) + ": the sparse solver found " +
                             std::to_string(keep.size()) + " independent modes of the " +
                             std::to_string(k) + " requested (use solver: dense)");
  Mat<S> basis(v.cols(), static_cast<Index>(keep.size()));
  for (std::size_t c = 0; c < keep.size(); ++c)
    basis.col(static_cast<Index>(c)) = ge.eigenvectors().col(keep[c]) / std::sqrt(gv(keep[c]));
  const Mat<S> u = v * basis;
  Mat<S> hk = u.adjoint() * (kh * u);
  hk = (0.5 * (hk + hk.adjoint())).eval();
  const Eigen::SelfAdjointEigenSolver<Mat<S>> he(hk);
  lambda = he.eigenvalues().head(k);
  modes = u * he.eigenvectors().leftCols(k);
}

// ---------------------------------------------------------------------------------------

class FeSector final : public frichb::sdk::StructureProvider {
 public:
  explicit FeSector(const frichb::sdk::Params& p)
      : sectors_(static_cast<int>(p.integer("sectors"))),
        modes_(static_cast<Index>(p.integer("modes"))),
        solver_(p.text("solver")),
        ratios_(p.reals("modal_damping")),
        residual_(p.boolean("residual_flexibility")),
        cache_dir_(p.text("cache_dir")) {
    const std::string mass_file = p.text("mass"), stiffness_file = p.text("stiffness");
    mass_ = checked_symmetric(read_market(mass_file, "mass"), "mass", mass_file);
    check_positive_definite(mass_, mass_file);
    stiffness_ =
        checked_symmetric(read_market(stiffness_file, "stiffness"), "stiffness", stiffness_file);
    if (mass_.rows() != stiffness_.rows())
      throw std::invalid_argument("the mass matrix has " + std::to_string(mass_.rows()) +
                                  " DOFs but the stiffness matrix " +
                                  std::to_string(stiffness_.rows()) +
                                  ": both must cover the same sector DOFs");
    const std::string pairs_file = p.text("cyclic_pairs");
    if (pairs_file.empty()) {
      read_boundary(p.reals("left_dofs"), p.reals("right_dofs"));
    } else {
      if (!p.reals("left_dofs").empty() || !p.reals("right_dofs").empty())
        throw std::invalid_argument(
            "give the cyclic boundary either as cyclic_pairs or as left_dofs/right_dofs, not "
            "both");
      const auto [left, right] = read_pairs(pairs_file);
      read_boundary(left, right);
    }
    const Index n = mass_.rows(), m = independent_count();
    if (modes_ > m)
      throw std::invalid_argument("modes = " + std::to_string(modes_) + " exceeds the " +
                                  std::to_string(m) + " independent DOFs of a sector (" +
                                  std::to_string(n) + " DOFs less " + std::to_string(left_.size()) +
                                  " on the left boundary)");
    if (ratios_.size() > 1 && static_cast<Index>(ratios_.size()) != modes_)
      throw std::invalid_argument(
          "modal_damping has " + std::to_string(ratios_.size()) +
          " values; give 1 or one per kept mode (modes = " + std::to_string(modes_) + ")");
    for (Index i = 0; i < stiffness_.rows(); ++i)
      if (mass_.coeff(i, i) > 0.0)
        scale_ = std::max(scale_, stiffness_.coeff(i, i) / mass_.coeff(i, i));
    if (!cache_dir_.empty()) open_cache(mass_file, stiffness_file);
  }

  size_t dof_count() const override { return static_cast<size_t>(mass_.rows()); }
  size_t sector_count() const override { return static_cast<size_t>(sectors_); }

  frichb_modal_basis modal_basis(int harmonic_index, const size_t* kept, size_t n_kept) override {
    if (harmonic_index < 0 || harmonic_index >= sectors_)
      throw std::invalid_argument(
          "harmonic index " + std::to_string(harmonic_index) + " is outside [0, " +
          std::to_string(sectors_) +
          "): the fe_sector model has sectors = " + std::to_string(sectors_));
    for (size_t i = 0; i < n_kept; ++i)
      if (kept[i] >= dof_count())
        throw std::out_of_range("DOF " + std::to_string(kept[i]) +
                                " does not exist (the sector matrices have " +
                                std::to_string(dof_count()) + " DOFs)");
    if (harmonic_index != solved_h_) {
      solved_h_ = -1;
      if (cache_dir_.empty() || !load_cache(harmonic_index)) {
        solve(harmonic_index);
        if (!cache_dir_.empty()) store_cache(harmonic_index);
      }
      finish(harmonic_index);
      solved_h_ = harmonic_index;
    }
    const cd e = left_phase(harmonic_index);
    const auto rows = static_cast<Index>(n_kept);
    Mat<cd> phi(rows, modes_);
    for (Index i = 0; i < rows; ++i) {
      const size_t dof = kept[static_cast<size_t>(i)];
      const Index q = column_[dof];
      const cd factor = is_left_[dof] ? e : cd(1.0, 0.0);
      for (Index r = 0; r < modes_; ++r) phi(i, r) = factor * modes_q_(q, r);
    }
    if (real_) {
      phi = phi.real().cast<cd>().eval();
      basis_.set_mode_rows(phi.real());
    } else {
      basis_.set_mode_rows(phi);
    }
    const Mat<cd> g = residual_flexibility(harmonic_index, kept, n_kept, phi);
    if (g.size() > 0) {
      if (real_)
        basis_.set_residual_flexibility(g.real());
      else
        basis_.set_residual_flexibility(g);
    }
    return basis_.basis();
  }

 private:
  Index independent_count() const { return mass_.rows() - static_cast<Index>(left_.size()); }

  static std::vector<Index> dof_list(const std::vector<double>& values, const char* name, Index n) {
    std::vector<Index> out;
    out.reserve(values.size());
    for (std::size_t i = 0; i < values.size(); ++i) {
      const double v = values[i];
      const std::string at = std::string(name) + "[" + std::to_string(i) + "]";
      if (v != std::floor(v))
        throw std::invalid_argument(at + " = " + std::to_string(v) +
                                    " is not an integer DOF index");
      if (v >= static_cast<double>(n))
        throw std::invalid_argument(at + " = DOF " + std::to_string(static_cast<long long>(v)) +
                                    " is outside [0, " + std::to_string(n) +
                                    ") (the sector matrices have " + std::to_string(n) +
                                    " DOFs; indices are 0-based)");
      out.push_back(static_cast<Index>(v));
    }
    return out;
  }

  // The 'left right' pairs of a cyclic_pairs file, as the two lists left_dofs/right_dofs.
  static std::pair<std::vector<double>, std::vector<double>> read_pairs(const std::string& file) {
    std::ifstream in(file);
    if (!in) throw std::invalid_argument("cyclic_pairs: cannot open '" + file + "'");
    std::vector<double> left, right;
    std::string line;
    for (int number = 1; std::getline(in, line); ++number) {
      if (const auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
      if (blank(line)) continue;
      std::istringstream fields(line);
      double l = -1, r = -1;
      std::string extra;
      if (!(fields >> l >> r) || (fields >> extra) || l < 0 || r < 0 || l != std::floor(l) ||
          r != std::floor(r)) {
        std::ostringstream message;
        message << file << ":" << number
                << ": expected two DOF indices (integers >= 0) 'left right', got '" << line << "'";
        throw std::invalid_argument(message.str());
      }
      left.push_back(l);
      right.push_back(r);
    }
    return {std::move(left), std::move(right)};
  }

  void read_boundary(const std::vector<double>& left, const std::vector<double>& right) {
    const Index n = mass_.rows();
    if (left.size() != right.size())
      throw std::invalid_argument("left_dofs has " + std::to_string(left.size()) +
                                  " entries but right_dofs has " + std::to_string(right.size()) +
                                  ": they are paired in order and must have the same length");
    left_ = dof_list(left, "left_dofs", n);
    right_ = dof_list(right, "right_dofs", n);
    // 0: interior, 1: left, 2: right.
    std::vector<int> role(static_cast<std::size_t>(n), 0);
    for (int side = 1; side <= 2; ++side) {
      const auto& list = side == 1 ? left_ : right_;
      const char* name = side == 1 ? "left_dofs" : "right_dofs";
      for (const Index d : list) {
        int& r = role[static_cast<std::size_t>(d)];
        if (r == side)
          throw std::invalid_argument("DOF " + std::to_string(d) + " appears twice in " + name);
        if (r != 0)
          throw std::invalid_argument("DOF " + std::to_string(d) +
                                      " is in both left_dofs and right_dofs");
        r = side;
      }
    }
    // Independent DOFs: every DOF but the left ones, in ascending order.
    column_.assign(static_cast<std::size_t>(n), 0);
    is_left_.assign(static_cast<std::size_t>(n), false);
    Index q = 0;
    for (Index d = 0; d < n; ++d)
      if (role[static_cast<std::size_t>(d)] != 1) column_[static_cast<std::size_t>(d)] = q++;
    for (std::size_t j = 0; j < left_.size(); ++j) {
      const auto d = static_cast<std::size_t>(left_[j]);
      column_[d] = column_[static_cast<std::size_t>(right_[j])];
      is_left_[d] = true;
    }
  }

  // e^{+i h phi}: x_left = e^{+i h phi} x_right; exactly +-1 where the problem is real.
  cd left_phase(int h) const {
    if (h == 0) return {1.0, 0.0};
    if (2 * h == sectors_) return {-1.0, 0.0};
    return std::polar(1.0, 2.0 * std::numbers::pi * h / sectors_);
  }

  template <class S>
  SpMat<S> constraint(S e) const {
    const Index n = mass_.rows();
    std::vector<Eigen::Triplet<S>> t;
    t.reserve(static_cast<std::size_t>(n));
    for (Index d = 0; d < n; ++d) {
      const auto k = static_cast<std::size_t>(d);
      t.emplace_back(d, column_[k], is_left_[k] ? e : S(1.0));
    }
    SpMat<S> tm(n, independent_count());
    tm.setFromTriplets(t.begin(), t.end());
    return tm;
  }

  template <class S>
  static SpMat<S> project(const SpMat<double>& a, const SpMat<S>& t) {
    const SpMat<S> at = a.template cast<S>() * t;
    const SpMat<S> th = t.adjoint();
    SpMat<S> p = th * at;
    const SpMat<S> ph = p.adjoint();
    SpMat<S> hermitian = 0.5 * (p + ph);
    hermitian.makeCompressed();
    return hermitian;
  }

  bool use_dense(Index size, Index nev) const {
    if (solver_ == "dense") return true;
    const bool feasible = nev + 1 < size;
    if (solver_ == "sparse") {
      if (!feasible)
        throw std::invalid_argument("solver: sparse cannot compute " + std::to_string(modes_) +
                                    " modes of a sector with " +
                                    std::to_string(independent_count()) +
                                    " independent DOFs; use solver: dense or fewer modes");
      return false;
    }
    return independent_count() <= kDenseLimit || !feasible;
  }

  template <class S>
  void solve_as(int h, S e, Eigen::VectorXd& lambda, Mat<S>& modes) const {
    const SpMat<S> t = constraint<S>(e);
    const SpMat<S> kh = project<S>(stiffness_, t), mh = project<S>(mass_, t);
    constexpr bool complex = std::is_same_v<S, cd>;
    const Index m = kh.rows();
    const Index nev = complex ? std::min(2 * modes_ + 2, 2 * m) : modes_;
    if (use_dense(complex ? 2 * m : m, nev)) {
      const Mat<S> kd(kh), md(mh);
      const Eigen::GeneralizedSelfAdjointEigenSolver<Mat<S>> eig(kd, md);
      if (eig.info() != Eigen::Success)
        throw std::runtime_error("harmonic index " + std::to_string(h) +
                                 ": the dense eigen-solve failed (is the mass matrix positive "
                                 "definite on the independent DOFs?)");
      lambda = eig.eigenvalues().head(modes_);
      modes = eig.eigenvectors().leftCols(modes_);
      return;
    }
    if constexpr (complex) {
      const SpMat<double> ke = embed(kh), me = embed(mh);
      const Mat<double> w = spectra_lowest(ke, me, nev, h);
      Mat<cd> v(m, w.cols());
      v.real() = w.topRows(m);
      v.imag() = w.bottomRows(m);
      rayleigh_ritz<cd>(kh, mh, v, modes_, h, lambda, modes);
    } else {
      const Mat<double> w = spectra_lowest(kh, mh, nev, h);
      rayleigh_ritz<double>(kh, mh, w, modes_, h, lambda, modes);
    }
  }

  void solve(int h) {
    const cd e = left_phase(h);
    real_ = e.imag() == 0.0;
    Eigen::VectorXd lambda;
    if (real_) {
      Mat<double> modes;
      solve_as<double>(h, e.real(), lambda, modes);
      modes_q_ = modes.cast<cd>();
    } else {
      solve_as<cd>(h, e, lambda, modes_q_);
    }
    // Deterministic phase: each mode's largest component is real and positive.
    for (Index r = 0; r < modes_q_.cols(); ++r) {
      Index top = 0;
      modes_q_.col(r).cwiseAbs().maxCoeff(&top);
      const cd pivot = modes_q_(top, r);
      if (std::abs(pivot) > 0.0) modes_q_.col(r) *= std::conj(pivot) / std::abs(pivot);
      if (real_) modes_q_.col(r) = modes_q_.col(r).real().cast<cd>();
    }
    // Eigenvalues: a small negative one is round-off of a rigid-body mode.
    frequencies_.resize(modes_);
    for (Index r = 0; r < modes_; ++r) {
      if (lambda(r) < -1e-8 * scale_)
        throw std::runtime_error("negative eigenvalue " + std::to_string(lambda(r)) +
                                 " at harmonic index " + std::to_string(h) +
                                 ": the stiffness matrix is not positive semi-definite");
      frequencies_(r) = std::sqrt(std::max(0.0, lambda(r)));
    }
  }

  // What follows the modal solution (solved or read from the cache): the frequencies and the
  // modal damping of the basis handed to the host.
  void finish(int h) {
    real_ = left_phase(h).imag() == 0.0;
    basis_.set_frequencies(frequencies_);
    basis_.add_damping_ratios(ratios_);
  }

  // [K_h^{-1}] at the kept DOFs, S K_h^{-1} S^H with S the kept rows of T_h (row i: factor_i
  // at column cols_i), by CHOLMOD's supernodal Cholesky factorisation of K_h (its solves with
  // a block of right-hand sides are matrix-matrix products: the kept DOFs of a meshed contact
  // face are thousands of columns); empty when K_h is not positive definite.
  template <class S>
  Mat<cd> static_compliance(S e, const std::vector<Index>& cols,
                            const std::vector<cd>& factors) const {
    const SpMat<S> t = constraint<S>(e);
    const SpMat<S> kh = project<S>(stiffness_, t);
    Eigen::CholmodSupernodalLLT<SpMat<S>, Eigen::Lower> llt;
    llt.compute(kh);
    if (llt.info() != Eigen::Success) return {};
    // Solved kSolveBlock columns at a time: the sector's DOFs x kept DOFs at once would
    // hold gigabytes for a meshed contact face of a thousand nodes.
    constexpr Index kSolveBlock = 256;
    const auto n_kept = static_cast<Index>(cols.size());
    Mat<cd> g(n_kept, n_kept);
    Mat<S> rhs, x;
    for (Index first = 0; first < n_kept; first += kSolveBlock) {
      const Index width = std::min(kSolveBlock, n_kept - first);
      rhs.setZero(kh.rows(), width);
      for (Index i = 0; i < width; ++i) {
        const auto k = static_cast<std::size_t>(first + i);
        if constexpr (std::is_same_v<S, cd>)
          rhs(cols[k], i) = std::conj(factors[k]);
        else
          rhs(cols[k], i) = factors[k].real();
      }
      x = llt.solve(rhs);
      for (Index i = 0; i < n_kept; ++i)
        g.row(i).segment(first, width) =
            factors[static_cast<std::size_t>(i)] *
            x.row(cols[static_cast<std::size_t>(i)]).template cast<cd>();
    }
    return g;
  }

  // G_h = [K_h^{-1}]_kept - sum_r phi_r phi_r^H / w_r^2 (Hermitian; real for a real K_h) with
  // phi the mode rows at the kept DOFs, or empty: parameter off, every mode kept, or K_h
  // singular (rigid-body mode).
  Mat<cd> residual_flexibility(int h, const size_t* kept, size_t n_kept, const Mat<cd>& phi) const {
    if (!residual_ || modes_ >= independent_count() || n_kept == 0) return {};
    const double highest = frequencies_(frequencies_.size() - 1);
    const double noise = kRoundOff * std::numeric_limits<double>::epsilon() * scale_;
    if (frequencies_(0) * frequencies_(0) <= std::max(kSingularRatio * highest * highest, noise))
      return {};
    const cd e = left_phase(h);
    std::vector<Index> cols(n_kept);
    std::vector<cd> factors(n_kept);
    for (size_t i = 0; i < n_kept; ++i) {
      cols[i] = column_[kept[i]];
      factors[i] = is_left_[kept[i]] ? e : cd(1.0, 0.0);
    }
    Mat<cd> g = real_ ? static_compliance<double>(e.real(), cols, factors)
                      : static_compliance<cd>(e, cols, factors);
    if (g.size() == 0) return g;
    // In place: at a thousand contact node pairs g is half a gigabyte, a temporary as much.
    const Eigen::VectorXd inv_w2 = frequencies_.array().square().inverse().matrix();
    const Mat<cd> scaled = phi * inv_w2.asDiagonal();
    g.noalias() -= scaled * phi.adjoint();
    const Index n = g.rows();
    for (Index j = 0; j < n; ++j) {
      g(j, j) = g(j, j).real();
      for (Index i = j + 1; i < n; ++i) {
        const cd mean = 0.5 * (g(i, j) + std::conj(g(j, i)));
        g(i, j) = mean;
        g(j, i) = std::conj(mean);
      }
    }
    return g;
  }

  // ---- disk cache

  // Creates the folder and keys everything but the harmonic index.
  void open_cache(const std::string& mass_file, const std::string& stiffness_file) {
    namespace fs = std::filesystem;
    std::error_code ec;
    fs::create_directories(fs::path(cache_dir_), ec);
    if (!fs::is_directory(fs::path(cache_dir_), ec))
      throw std::invalid_argument("cache_dir '" + cache_dir_ + "' is not a folder and cannot be " +
                                  "created" + (ec ? ": " + ec.message() : std::string()));
    key_.u64(kCacheFormat);
    key_.file(mass_file);
    key_.file(stiffness_file);
    key_.u64(static_cast<std::uint64_t>(sectors_));
    key_.indices(left_);
    key_.indices(right_);
    key_.u64(static_cast<std::uint64_t>(modes_));
    key_.text(solver_);
  }

  std::uint64_t cache_key(int h) const {
    Fnv1a k = key_;
    k.u64(static_cast<std::uint64_t>(h));
    return k.value();
  }

  std::filesystem::path cache_file(std::uint64_t key) const {
    static constexpr char kHex[] = "0123456789abcdef";
    std::string name = "fe_sector_";
    for (int shift = 60; shift >= 0; shift -= 4) name += kHex[(key >> shift) & 0xFU];
    return std::filesystem::path(cache_dir_) / (name + ".bin");
  }

  // Layout (native byte order): magic[8], format, key, h, independent DOFs m, modes, real flag
  // (u64 each), frequencies (modes doubles), modes_q_ (m x modes complex, column-major), and
  // the FNV-1a checksum (u64) of everything before it.
  static constexpr std::size_t kHeaderBytes = sizeof kCacheMagic + 6 * sizeof(std::uint64_t);
  std::size_t cache_bytes() const {
    const auto modes = static_cast<std::size_t>(modes_);
    const auto m = static_cast<std::size_t>(independent_count());
    return kHeaderBytes + modes * sizeof(double) + m * modes * sizeof(cd) + sizeof(std::uint64_t);
  }

  std::string cache_header(int h, std::uint64_t key) const {
    std::string out(kCacheMagic, sizeof kCacheMagic);
    put_u64(out, kCacheFormat);
    put_u64(out, key);
    put_u64(out, static_cast<std::uint64_t>(h));
    put_u64(out, static_cast<std::uint64_t>(independent_count()));
    put_u64(out, static_cast<std::uint64_t>(modes_));
    put_u64(out, left_phase(h).imag() == 0.0 ? 1U : 0U);
    return out;
  }

  // Reads harmonic index h's solution if a valid cache file holds it (a missing, truncated or
  // corrupt file, or one of other inputs, is ignored: the caller re-solves and rewrites it).
  bool load_cache(int h) {
    const std::uint64_t key = cache_key(h);
    const std::filesystem::path file = cache_file(key);
    std::error_code ec;
    const std::size_t size = cache_bytes();
    if (std::filesystem::file_size(file, ec) != size || ec) return false;
    std::string data(size, '\0');
    std::ifstream in(file, std::ios::binary);
    if (!in.read(data.data(), static_cast<std::streamsize>(size))) return false;
    const std::string header = cache_header(h, key);
    if (data.compare(0, header.size(), header) != 0) return false;
    Fnv1a sum;
    sum.bytes(data.data(), size - sizeof(std::uint64_t));
    std::size_t at = size - sizeof(std::uint64_t);
    if (get_u64(data, at) != sum.value()) return false;
    Eigen::VectorXd frequencies(modes_);
    Mat<cd> modes(independent_count(), modes_);
    at = header.size();
    std::memcpy(frequencies.data(), data.data() + at, sizeof(double) * modes_);
    at += sizeof(double) * static_cast<std::size_t>(modes_);
    std::memcpy(static_cast<void*>(modes.data()), data.data() + at,
                sizeof(cd) * static_cast<std::size_t>(modes.size()));
    if (!frequencies.allFinite() || !modes.allFinite() || frequencies.minCoeff() < 0.0)
      return false;
    frequencies_ = std::move(frequencies);
    modes_q_ = std::move(modes);
    return true;
  }

  // Writes harmonic index h's solution atomically (temporary file, then rename); a failure
  // leaves no file and is not an error (the cache only saves time).
  void store_cache(int h) const {
    namespace fs = std::filesystem;
    const std::uint64_t key = cache_key(h);
    std::string data = cache_header(h, key);
    data.reserve(cache_bytes());
    data.append(reinterpret_cast<const char*>(frequencies_.data()),
                sizeof(double) * static_cast<std::size_t>(modes_));
    data.append(reinterpret_cast<const char*>(modes_q_.data()),
                sizeof(cd) * static_cast<std::size_t>(modes_q_.size()));
    Fnv1a sum;
    sum.bytes(data.data(), data.size());
    put_u64(data, sum.value());
    const fs::path file = cache_file(key);
    std::random_device random;
    const fs::path temp =
        fs::path(file).concat(".tmp" + std::to_string(random()) + std::to_string(random()));
    std::error_code ec;
    bool ok = false;
    {
      std::ofstream out(temp, std::ios::binary | std::ios::trunc);
      ok = static_cast<bool>(out.write(data.data(), static_cast<std::streamsize>(data.size())));
      out.close();
      ok = ok && !out.fail();
    }
    if (ok) fs::rename(temp, file, ec);
    if (!ok || ec) fs::remove(temp, ec);
  }

  int sectors_;
  Index modes_;
  std::string solver_;
  std::vector<double> ratios_;
  bool residual_;
  std::string cache_dir_;
  Fnv1a key_;         // cache key of everything but the harmonic index
  double scale_ = 0;  // max_i K_ii / M_ii
  SpMat<double> mass_, stiffness_;
  std::vector<Index> left_, right_;
  std::vector<Index> column_;  // per sector DOF: its independent DOF (a left DOF: its partner's)
  std::vector<bool> is_left_;

  // The most recent harmonic index's solution (independent DOFs x modes).
  int solved_h_ = -1;
  bool real_ = true;
  Mat<cd> modes_q_;
  Eigen::VectorXd frequencies_;
  frichb::sdk::ModalBasisBuilder basis_;  // what modal_basis() hands to the host
};

}  // namespace

FRICHB_STRUCTURE_PLUGIN(FeSector, fe_sector, "1.0.0",
                        "one sector of a bladed disk from FE mass and stiffness matrices (Matrix "
                        "Market) with cyclic boundary DOFs; lowest modes per harmonic index",
                        fe_sector_schema)
