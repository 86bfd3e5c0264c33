// A small FE-like cyclic sector written by the tests themselves: a 2D lattice of scalar DOFs
// (a disk ring segment with consistent bar masses, grounded at the hub row) and a blade chain,
// its M and K as Matrix Market text for the fe_sector provider, and the full disk assembled
// from it (boundary DOFs merged) for the oracles.
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <complex>
#include <numbers>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace frichb::test {

using cd = std::complex<double>;

// A 2D lattice of scalar DOFs: `rows` radial rows x (cols + 1) columns; column 0 is the left
// cyclic boundary (owned by the previous sector: no mass, no vertical springs of its own),
// column `cols` the right one. Springs: horizontal, vertical and one diagonal direction (so
// the sector has no mirror symmetry and h differs from nb - h), hub row grounded, a blade
// chain on the top row. Horizontal bars carry consistent masses (off-diagonal M entries).
struct Sector {
  int n = 0;
  Eigen::MatrixXd k, m;
  std::vector<int> left, right;
  std::vector<int> independent;  // local DOF -> index among the non-left DOFs, -1 for left
  int m_count = 0;

  Sector(int rows, int cols, int blade, bool grounded, unsigned seed) {
    auto node = [cols](int r, int c) { return r * (cols + 1) + c; };
    n = rows * (cols + 1) + blade;
    k = Eigen::MatrixXd::Zero(n, n);
    m = Eigen::MatrixXd::Zero(n, n);
    std::mt19937 gen(seed);
    std::uniform_real_distribution<double> u(0.5, 1.5);
    auto spring = [&](int a, int b, double value) {
      k(a, a) += value;
      if (b >= 0) {
        k(b, b) += value;
        k(a, b) -= value;
        k(b, a) -= value;
      }
    };
    auto bar_mass = [&](int a, int b, double value) {
      m(a, a) += value / 3.0;
      m(b, b) += value / 3.0;
      m(a, b) += value / 6.0;
      m(b, a) += value / 6.0;
    };
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c <= cols; ++c) {
        const int a = node(r, c);
        if (c > 0) m(a, a) += 0.01 * u(gen);
        if (c < cols) {
          spring(a, node(r, c + 1), 1.0e6 * u(gen));
          bar_mass(a, node(r, c + 1), 0.004 * u(gen));
        }
        if (r + 1 < rows && c > 0) spring(a, node(r + 1, c), 8.0e5 * u(gen));
        if (r + 1 < rows && c < cols) spring(a, node(r + 1, c + 1), 3.0e5 * u(gen));
        if (r == 0 && c > 0 && grounded) spring(a, -1, 2.0e6 * u(gen));
      }
    for (int b = 0; b < blade; ++b) {
      const int a = rows * (cols + 1) + b;
      m(a, a) += 0.005 * u(gen);
      spring(a, b == 0 ? node(rows - 1, cols / 2) : a - 1, 4.0e5 * u(gen));
    }
    for (int r = 0; r < rows; ++r) {
      left.push_back(node(r, 0));
      right.push_back(node(r, cols));
    }
    independent.assign(static_cast<std::size_t>(n), -1);
    for (int d = 0; d < n; ++d)
      if (std::find(left.begin(), left.end(), d) == left.end())
        independent[static_cast<std::size_t>(d)] = m_count++;
  }

  // Global DOF of local DOF d of sector s in a disk of nb sectors (nb * m_count DOFs).
  int global(int s, int d, int nb) const {
    const auto it = std::find(left.begin(), left.end(), d);
    if (it == left.end()) return s * m_count + independent[static_cast<std::size_t>(d)];
    const int partner = right[static_cast<std::size_t>(it - left.begin())];
    return ((s - 1 + nb) % nb) * m_count + independent[static_cast<std::size_t>(partner)];
  }

  void assemble(int nb, Eigen::MatrixXd& kf, Eigen::MatrixXd& mf) const {
    kf = Eigen::MatrixXd::Zero(nb * m_count, nb * m_count);
    mf = kf;
    for (int s = 0; s < nb; ++s)
      for (int a = 0; a < n; ++a)
        for (int b = 0; b < n; ++b) {
          kf(global(s, a, nb), global(s, b, nb)) += k(a, b);
          mf(global(s, a, nb), global(s, b, nb)) += m(a, b);
        }
  }

  // The ABI's harmonic matrices on the independent DOFs from the full disk's blocks:
  // A0 = block(s, s), A1 = block(s, s+1) (three sectors make them distinct).
  void harmonic(int h, int nb, Eigen::MatrixXcd& kh, Eigen::MatrixXcd& mh) const {
    Eigen::MatrixXd kf, mf;
    assemble(3, kf, mf);
    const cd e = std::polar(1.0, -2.0 * std::numbers::pi * h / nb);
    auto form = [&](const Eigen::MatrixXd& f) -> Eigen::MatrixXcd {
      const Eigen::MatrixXd a0 = f.block(0, 0, m_count, m_count);
      const Eigen::MatrixXd a1 = f.block(0, m_count, m_count, m_count);
      return a0.cast<cd>() + e * a1.cast<cd>() + std::conj(e) * a1.transpose().cast<cd>();
    };
    kh = form(kf);
    mh = form(mf);
  }

  std::vector<std::size_t> independent_dofs() const {
    std::vector<std::size_t> out;
    for (int d = 0; d < n; ++d)
      if (independent[static_cast<std::size_t>(d)] >= 0) out.push_back(static_cast<std::size_t>(d));
    return out;
  }
  std::vector<std::size_t> all_dofs() const {
    std::vector<std::size_t> out(static_cast<std::size_t>(n));
    std::iota(out.begin(), out.end(), std::size_t{0});
    return out;
  }
};

// Matrix Market text: K as symmetric (lower triangle), M as general, as exporters do.
inline std::string market(const Eigen::MatrixXd& a, bool symmetric) {
  std::ostringstream out;
  out.precision(17);
  std::vector<std::string> lines;
  for (Eigen::Index c = 0; c < a.cols(); ++c)
    for (Eigen::Index r = symmetric ? c : 0; r < a.rows(); ++r)
      if (a(r, c) != 0.0) {
        std::ostringstream l;
        l.precision(17);
        l << r + 1 << " " << c + 1 << " " << a(r, c) << "\n";
        lines.push_back(l.str());
      }
  out << "%%MatrixMarket matrix coordinate real " << (symmetric ? "symmetric" : "general")
      << "\n% written by test_fe_sector\n"
      << a.rows() << " " << a.cols() << " " << lines.size() << "\n";
  for (const auto& l : lines) out << l;
  return out.str();
}

template <class T>
std::string list(const std::vector<T>& v) {
  std::ostringstream out;
  out << "[";
  for (std::size_t i = 0; i < v.size(); ++i) out << (i ? ", " : "") << v[i];
  out << "]";
  return out.str();
}

}  // namespace frichb::test
