// BM_HarmonicOperator/<what>/<pairs>: the matrix-free path's pieces at H = 5 (harmonics 0..5,
// 3 x 11 unknowns per pair) for a receptance of 10 retained modes plus a residual flexibility
// F (a dense Hermitian m x m block per harmonic, m = 3 x pairs, as a cyclic sector gives), with
// random contact tangents:
//   product         one product e_x x (what a GMRES iteration applies once);
//   precondition    one solve with the preconditioner (the other half of an iteration): the
//                   LU of I + F D0 per harmonic above 0 with the modes by Woodbury's identity;
//   precondition_formed  the same with the receptance formed (the LU of I + Rc D0 per
//                   harmonic, the modes inside it): the preconditioner of a model without a
//                   modal form;
//   build           making the preconditioner (the LUs, one harmonic per thread);
//   follow          bringing it to another frequency (a 10 x 10 LU per harmonic).
// The data are random: the figures are of the operations, not of a model.
#include <benchmark/benchmark.h>

#include <Eigen/Dense>
#include <complex>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "frichb/core/numerics/harmonics.hpp"
#include "model/harmonic_jacobian.hpp"

namespace {

using frichb::core::ContactTangent;
using frichb::core::HarmonicJacobian;
using frichb::core::HarmonicLayout;
using frichb::core::HarmonicReceptance;

constexpr int kModes = 10;
constexpr int kMaxHarmonic = 5;

struct OperatorCase {
  HarmonicLayout layout{{0, 1, 2, 3, 4, 5}, 16};
  int components = 0;
  std::vector<Eigen::MatrixXcd> projected, flexibility;
  std::vector<ContactTangent> tangents;
  Eigen::VectorXd column;

  explicit OperatorCase(int pairs) : components(3 * pairs) {
    std::mt19937 gen(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const int c = layout.coefficient_count();
    for (int k = 0; k <= kMaxHarmonic; ++k) {
      Eigen::MatrixXcd p(components, kModes);
      for (Eigen::Index j = 0; j < p.cols(); ++j)
        for (Eigen::Index i = 0; i < p.rows(); ++i) p(i, j) = {u(gen), u(gen)};
      projected.push_back(1e-2 * p);
      Eigen::MatrixXcd f(components, components);
      for (Eigen::Index j = 0; j < f.cols(); ++j)
        for (Eigen::Index i = 0; i < f.rows(); ++i) f(i, j) = {u(gen), u(gen)};
      const Eigen::MatrixXcd hermitian = 0.5 * (f + f.adjoint()) / components;
      flexibility.push_back(hermitian);
    }
    for (int i = 0; i < pairs; ++i) {
      ContactTangent t;
      t.first = static_cast<Eigen::Index>(3 * i) * c;
      t.block = Eigen::MatrixXd::Random(3 * c, 3 * c);
      t.block.diagonal().array() += 3.0 * c;
      tangents.push_back(std::move(t));
    }
    column = Eigen::VectorXd::Random(static_cast<Eigen::Index>(components) * c);
  }

  // The operator at frequency ratio `w` (modal compliances 1 / (w_r^2 - W^2 + i W c_r));
  // `formed`: the receptance as one m x m matrix per harmonic.
  std::shared_ptr<HarmonicJacobian> at(double w, bool formed) const {
    std::vector<HarmonicReceptance> receptances;
    for (std::size_t k = 0; k < layout.harmonics().size(); ++k) {
      HarmonicReceptance r;
      r.harmonic = layout.harmonics()[k];
      r.cos_index = layout.cos_index(k);
      r.sin_index = layout.sin_index(k);
      r.projected = &projected[k];
      r.flexibility = &flexibility[k];
      r.inv_z.resize(kModes);
      const double big_w = r.harmonic * w;
      for (int q = 0; q < kModes; ++q) {
        const double wr = 0.5 + 0.3 * q;
        r.inv_z(q) = 1.0 / std::complex<double>(wr * wr - big_w * big_w, 0.004 * big_w);
      }
      if (formed) {
        r.formed = r.matrix();
        r.projected = nullptr;
        r.flexibility = nullptr;
      }
      receptances.push_back(std::move(r));
    }
    const int threads = static_cast<int>(std::max(1U, std::thread::hardware_concurrency()));
    return std::make_shared<HarmonicJacobian>(layout.coefficient_count(), components, receptances,
                                              tangents, column, threads);
  }
};

const OperatorCase& case_of(int pairs) {
  static std::map<int, std::unique_ptr<OperatorCase>> cases;
  auto& slot = cases[pairs];
  if (!slot) slot = std::make_unique<OperatorCase>(pairs);
  return *slot;
}

void BM_HarmonicOperator(benchmark::State& state, const std::string& what) {
  const int pairs = static_cast<int>(state.range(0));
  const OperatorCase& oc = case_of(pairs);
  const bool formed = what == "precondition_formed";
  const auto op = oc.at(1.0, formed);
  const Eigen::Index n = op->rows();
  const Eigen::MatrixXd x = Eigen::MatrixXd::Random(n, 1);
  Eigen::MatrixXd y(n, 1);
  Eigen::VectorXd s(n);
  std::unique_ptr<frichb::core::JacobianPreconditioner> m;
  if (what != "build" && what != "product") m = op->make_preconditioner();
  const auto later = oc.at(1.01, formed);
  for (auto _ : state) {
    if (what == "product") {
      op->apply(x, y);
      benchmark::DoNotOptimize(y.data());
    } else if (what == "build") {
      auto made = op->make_preconditioner();
      benchmark::DoNotOptimize(made.get());
    } else if (what == "follow") {
      auto followed = m->follow(*later);
      benchmark::DoNotOptimize(followed.get());
    } else {
      m->solve(x.col(0), s);
      benchmark::DoNotOptimize(s.data());
    }
  }
  state.counters["unknowns"] = static_cast<double>(n);
}

// Registered at start-up.
const bool registered = [] {
  for (const std::string what :
       {"product", "precondition", "precondition_formed", "build", "follow"}) {
    benchmark::RegisterBenchmark(("BM_HarmonicOperator/" + what).c_str(),
                                 [what](benchmark::State& s) { BM_HarmonicOperator(s, what); })
        ->Arg(100)
        ->Arg(300)
        ->Arg(1000)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  }
  return true;
}();

}  // namespace
