// The SDK's Eigen-based helpers, compiled as C++17 as a third-party plugin may be: the typed
// views of a step's tangents (frichb/plugin/tangents.hpp) and the modal-basis builder of
// structure providers (frichb/plugin/modal_basis.hpp), against the row-major layouts that
// abi.h defines, written out here as index arithmetic.
#include <gtest/gtest.h>

#include <complex>
#include <cstddef>
#include <stdexcept>
#include <vector>

#include "frichb/plugin/modal_basis.hpp"
#include "frichb/plugin/tangents.hpp"

static_assert(__cplusplus == 201703L, "the SDK headers are checked as C++17");

namespace {

using frichb::sdk::StepTangents;

// Row-major offset of entry (row, col) in a block with `cols` columns: abi.h's layout.
std::size_t offset(int row, int cols, int col) {
  return static_cast<std::size_t>(row) * static_cast<std::size_t>(cols) +
         static_cast<std::size_t>(col);
}

// The six blocks of one step, each followed by guard entries that no view may touch.
struct Blocks {
  static constexpr int kGuard = 4;
  static constexpr double kGuardValue = -12345.0;

  explicit Blocks(int s)
      : fu(9 + kGuard),
        fp(9 + kGuard),
        fs(3 * static_cast<std::size_t>(s) + kGuard),
        su(static_cast<std::size_t>(s) * 3 + kGuard),
        sp(static_cast<std::size_t>(s) * 3 + kGuard),
        ss(static_cast<std::size_t>(s) * static_cast<std::size_t>(s) + kGuard) {
    // Entry k of block b holds 1000 (b + 1) + k; the guards hold kGuardValue.
    int b = 0;
    for (auto* v : all()) {
      const std::size_t n = v->size() - kGuard;
      for (std::size_t k = 0; k < v->size(); ++k)
        (*v)[k] = k < n ? 1000.0 * (b + 1) + static_cast<double>(k) : kGuardValue;
      ++b;
    }
    abi = {fu.data(), fp.data(), fs.data(), su.data(), sp.data(), ss.data()};
  }
  std::vector<std::vector<double>*> all() { return {&fu, &fp, &fs, &su, &sp, &ss}; }
  bool guards_intact() {
    for (auto* v : all())
      for (std::size_t k = v->size() - kGuard; k < v->size(); ++k)
        if ((*v)[k] != kGuardValue) return false;
    return true;
  }

  std::vector<double> fu, fp, fs, su, sp, ss;
  frichb_step_tangents abi{};
};

class StepTangentsViews : public ::testing::TestWithParam<int> {};

TEST_P(StepTangentsViews, ShapesFollowTheStateSize) {
  const int s = GetParam();
  Blocks b(s);
  const StepTangents t(&b.abi, s);
  EXPECT_EQ(t.state_size(), s);
  EXPECT_EQ(t.dforce_du_now().rows(), 3);
  EXPECT_EQ(t.dforce_du_now().cols(), 3);
  EXPECT_EQ(t.dforce_du_prev().rows(), 3);
  EXPECT_EQ(t.dforce_du_prev().cols(), 3);
  EXPECT_EQ(t.dforce_dstate_prev().rows(), 3);
  EXPECT_EQ(t.dforce_dstate_prev().cols(), s);
  EXPECT_EQ(t.dstate_du_now().rows(), s);
  EXPECT_EQ(t.dstate_du_now().cols(), 3);
  EXPECT_EQ(t.dstate_du_prev().rows(), s);
  EXPECT_EQ(t.dstate_du_prev().cols(), 3);
  EXPECT_EQ(t.dstate_dstate_prev().rows(), s);
  EXPECT_EQ(t.dstate_dstate_prev().cols(), s);
}

TEST_P(StepTangentsViews, ReadTheRowMajorEntriesOfAbiH) {
  const int s = GetParam();
  Blocks b(s);
  const StepTangents t(&b.abi, s);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      EXPECT_EQ(t.dforce_du_now()(i, j), b.fu[offset(i, 3, j)]);
      EXPECT_EQ(t.dforce_du_prev()(i, j), b.fp[offset(i, 3, j)]);
    }
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < s; ++k) EXPECT_EQ(t.dforce_dstate_prev()(i, k), b.fs[offset(i, s, k)]);
  for (int k = 0; k < s; ++k)
    for (int j = 0; j < 3; ++j) {
      EXPECT_EQ(t.dstate_du_now()(k, j), b.su[offset(k, 3, j)]);
      EXPECT_EQ(t.dstate_du_prev()(k, j), b.sp[offset(k, 3, j)]);
    }
  for (int k = 0; k < s; ++k)
    for (int l = 0; l < s; ++l) EXPECT_EQ(t.dstate_dstate_prev()(k, l), b.ss[offset(k, s, l)]);
}

TEST_P(StepTangentsViews, WritesLandOnTheirOwnEntries) {
  const int s = GetParam();
  Blocks b(s);
  const StepTangents t(&b.abi, s);
  // Each write through a view changes exactly the entry that abi.h assigns to (row, column).
  auto check = [&](std::vector<double>& array, std::size_t index, auto&& write) {
    const std::vector<double> before = array;
    write(-1.5);
    for (std::size_t k = 0; k < array.size(); ++k)
      EXPECT_EQ(array[k], k == index ? -1.5 : before[k]) << "entry " << k;
    array = before;
  };
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const auto at = offset(i, 3, j);
      check(b.fu, at, [&](double v) { t.dforce_du_now()(i, j) = v; });
      check(b.fp, at, [&](double v) { t.dforce_du_prev()(i, j) = v; });
    }
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < s; ++k)
      check(b.fs, offset(i, s, k), [&](double v) { t.dforce_dstate_prev()(i, k) = v; });
  for (int k = 0; k < s; ++k)
    for (int j = 0; j < 3; ++j) {
      const auto at = offset(k, 3, j);
      check(b.su, at, [&](double v) { t.dstate_du_now()(k, j) = v; });
      check(b.sp, at, [&](double v) { t.dstate_du_prev()(k, j) = v; });
    }
  for (int k = 0; k < s; ++k)
    for (int l = 0; l < s; ++l)
      check(b.ss, offset(k, s, l), [&](double v) { t.dstate_dstate_prev()(k, l) = v; });
}

TEST_P(StepTangentsViews, ZeroClearsExactlyTheSixBlocks) {
  const int s = GetParam();
  Blocks b(s);
  const StepTangents t(&b.abi, s);
  ASSERT_TRUE(t.wanted());
  t.zero();
  for (auto* v : b.all())
    for (std::size_t k = 0; k + Blocks::kGuard < v->size(); ++k) EXPECT_EQ((*v)[k], 0.0);
  EXPECT_TRUE(b.guards_intact());
}

INSTANTIATE_TEST_SUITE_P(StateSizes, StepTangentsViews, ::testing::Values(0, 1, 2, 3, 5));

TEST(StepTangents, BlockAssignmentsUseTheRowMajorLayout) {
  // A 2-state law's writes as the built-in laws make them.
  Blocks b(2);
  const StepTangents t(&b.abi, 2);
  t.zero();
  Eigen::Matrix2d a;
  a << 1, 2, 3, 4;
  auto fu = t.dforce_du_now();
  fu.topLeftCorner<2, 2>() = a;
  fu.topRightCorner<2, 1>() = Eigen::Vector2d(5, 6);
  t.dforce_dstate_prev().topRows<2>() = -a;
  t.dstate_du_now().col(2) = Eigen::Vector2d(7, 8);
  t.dstate_dstate_prev().diagonal() = Eigen::Vector2d(9, 10);
  const std::vector<double> fu_expected = {1, 2, 5, 3, 4, 6, 0, 0, 0};
  const std::vector<double> fs_expected = {-1, -2, -3, -4, 0, 0};
  const std::vector<double> su_expected = {0, 0, 7, 0, 0, 8};
  const std::vector<double> ss_expected = {9, 0, 0, 10};
  for (std::size_t k = 0; k < 9; ++k) EXPECT_EQ(b.fu[k], fu_expected[k]) << k;
  for (std::size_t k = 0; k < 6; ++k) EXPECT_EQ(b.fs[k], fs_expected[k]) << k;
  for (std::size_t k = 0; k < 6; ++k) EXPECT_EQ(b.su[k], su_expected[k]) << k;
  for (std::size_t k = 0; k < 4; ++k) EXPECT_EQ(b.ss[k], ss_expected[k]) << k;
  EXPECT_TRUE(b.guards_intact());
}

TEST(StepTangents, ValueOnlyCallsAreNotWantedAndZeroTouchesNothing) {
  EXPECT_FALSE(StepTangents(nullptr, 2).wanted());
  StepTangents(nullptr, 2).zero();  // no block to clear, no access

  // A struct without dforce_du_now is a value-only call too: no block is written.
  Blocks b(2);
  const std::vector<double> fp = b.fp, ss = b.ss;
  frichb_step_tangents partial = b.abi;
  partial.dforce_du_now = nullptr;
  const StepTangents t(&partial, 2);
  EXPECT_FALSE(t.wanted());
  t.zero();
  EXPECT_EQ(b.fp, fp);
  EXPECT_EQ(b.ss, ss);

  EXPECT_TRUE(StepTangents(&b.abi, 2).wanted());
}

// ---------------------------------------------------------------------------------------
// ModalBasisBuilder

using frichb::sdk::ModalBasisBuilder;

// True when [p, p + n) lies inside the storage of `m` (the struct points at owned data).
bool inside(const double* p, std::size_t n, const ModalBasisBuilder::RowMajorMatrix& m) {
  return p == m.data() && n == static_cast<std::size_t>(m.size());
}

TEST(ModalBasisBuilder, RealBasisPointsAtItsOwnCopiesInAbiLayout) {
  ModalBasisBuilder builder;
  Eigen::VectorXd w(3);
  w << 10.0, 20.0, 35.0;
  Eigen::MatrixXd rows(2, 3);  // column-major on purpose: the struct must be row-major
  rows << 1, 2, 3, 4, 5, 6;
  builder.set_frequencies(w);
  builder.add_damping_ratios({0.01, 0.02, 0.5});
  builder.set_mode_rows(rows);
  const frichb_modal_basis b = builder.basis();

  EXPECT_EQ(b.struct_size, sizeof(frichb_modal_basis));
  ASSERT_EQ(b.n_modes, 3U);
  EXPECT_EQ(b.natural_frequencies, builder.frequencies().data());
  EXPECT_TRUE(inside(b.modal_damping, 9, builder.damping()));
  EXPECT_TRUE(inside(b.mode_rows_real, 6, builder.mode_rows_real()));
  EXPECT_EQ(b.mode_rows_imag, nullptr);
  EXPECT_EQ(b.residual_flexibility, nullptr);
  EXPECT_EQ(b.residual_flexibility_imag, nullptr);

  // The inputs are copied: changing them afterwards changes nothing the struct points at.
  w.setZero();
  rows.setZero();
  const double w_expected[3] = {10.0, 20.0, 35.0};
  const double z[3] = {0.01, 0.02, 0.5};
  for (std::size_t r = 0; r < 3; ++r) {
    EXPECT_EQ(b.natural_frequencies[r], w_expected[r]);
    for (std::size_t c = 0; c < 3; ++c)
      EXPECT_EQ(b.modal_damping[r * 3 + c], r == c ? 2.0 * z[r] * w_expected[r] : 0.0);
  }
  const double rows_expected[2][3] = {{1, 2, 3}, {4, 5, 6}};
  for (std::size_t i = 0; i < 2; ++i)
    for (std::size_t r = 0; r < 3; ++r) EXPECT_EQ(b.mode_rows_real[i * 3 + r], rows_expected[i][r]);
}

TEST(ModalBasisBuilder, DampingMatrixPlusOneRatioForEveryMode) {
  ModalBasisBuilder builder;
  builder.set_frequencies(Eigen::Vector2d(3.0, 7.0));
  Eigen::Matrix2d c;
  c << 0.5, 0.25, -0.125, 1.0;
  builder.set_damping_matrix(c);
  builder.add_damping_ratios({0.1});
  builder.set_mode_rows(Eigen::MatrixXd::Identity(2, 2));
  const frichb_modal_basis b = builder.basis();
  const double expected[4] = {0.5 + 2.0 * 0.1 * 3.0, 0.25, -0.125, 1.0 + 2.0 * 0.1 * 7.0};
  for (std::size_t k = 0; k < 4; ++k) EXPECT_EQ(b.modal_damping[k], expected[k]) << k;

  // New frequencies start undamped again.
  builder.set_frequencies(Eigen::Vector2d(3.0, 7.0));
  builder.set_mode_rows(Eigen::MatrixXd::Identity(2, 2));
  EXPECT_EQ(builder.damping(), ModalBasisBuilder::RowMajorMatrix::Zero(2, 2));
  builder.add_damping_ratios({});
  EXPECT_EQ(builder.damping(), ModalBasisBuilder::RowMajorMatrix::Zero(2, 2));
}

TEST(ModalBasisBuilder, ComplexRowsGiveBothPartsAndRealPartsGiveNoImaginaryPart) {
  using cd = std::complex<double>;
  ModalBasisBuilder builder;
  builder.set_frequencies(Eigen::Vector2d(1.0, 2.0));
  Eigen::MatrixXcd rows(3, 2);
  rows << cd(1, -1), cd(2, 0.5), cd(3, 0), cd(4, -4), cd(-5, 2), cd(6, 6);
  builder.set_mode_rows(rows);
  frichb_modal_basis b = builder.basis();
  ASSERT_NE(b.mode_rows_imag, nullptr);
  EXPECT_TRUE(inside(b.mode_rows_imag, 6, builder.mode_rows_imag()));
  for (int i = 0; i < 3; ++i)
    for (int r = 0; r < 2; ++r) {
      EXPECT_EQ(b.mode_rows_real[offset(i, 2, r)], rows(i, r).real());
      EXPECT_EQ(b.mode_rows_imag[offset(i, 2, r)], rows(i, r).imag());
    }
  builder.set_mode_rows(rows.real());
  b = builder.basis();
  EXPECT_EQ(b.mode_rows_imag, nullptr);
  EXPECT_EQ(b.mode_rows_real[offset(2, 2, 0)], -5.0);
}

TEST(ModalBasisBuilder, GatherTakesTheRowsOfTheKeptDofsInTheirOrder) {
  using cd = std::complex<double>;
  Eigen::MatrixXcd shapes(4, 2);  // 4 DOFs, 2 modes; entry (d, r) = (10 d + r, -d)
  for (int d = 0; d < 4; ++d)
    for (int r = 0; r < 2; ++r) shapes(d, r) = cd(10.0 * d + r, -d);
  const std::size_t kept[3] = {3, 0, 3};
  ModalBasisBuilder builder;
  builder.set_frequencies(Eigen::Vector2d(1.0, 2.0));
  builder.gather_mode_rows(shapes, kept, 3);
  frichb_modal_basis b = builder.basis();
  ASSERT_NE(b.mode_rows_imag, nullptr);
  for (int i = 0; i < 3; ++i)
    for (int r = 0; r < 2; ++r) {
      const auto d = static_cast<double>(kept[i]);
      EXPECT_EQ(b.mode_rows_real[offset(i, 2, r)], 10.0 * d + r);
      EXPECT_EQ(b.mode_rows_imag[offset(i, 2, r)], -d);
    }
  builder.gather_mode_rows(shapes.real(), kept, 2);
  b = builder.basis();
  EXPECT_EQ(builder.kept_count(), 2);
  EXPECT_EQ(b.mode_rows_imag, nullptr);
  EXPECT_EQ(b.mode_rows_real[offset(1, 2, 1)], 1.0);

  const std::size_t beyond[1] = {4};
  EXPECT_THROW(builder.gather_mode_rows(shapes, beyond, 1), std::out_of_range);
}

TEST(ModalBasisBuilder, ResidualFlexibilityBelongsToTheKeptDofsOfTheRows) {
  using cd = std::complex<double>;
  ModalBasisBuilder builder;
  builder.set_frequencies(Eigen::VectorXd::Constant(1, 5.0));
  builder.set_mode_rows(Eigen::MatrixXd::Constant(2, 1, 0.5));
  Eigen::Matrix2cd g;
  g << cd(1, 0), cd(2, 3), cd(2, -3), cd(4, 0);
  builder.set_residual_flexibility(g);
  frichb_modal_basis b = builder.basis();
  ASSERT_NE(b.residual_flexibility, nullptr);
  ASSERT_NE(b.residual_flexibility_imag, nullptr);
  EXPECT_TRUE(inside(b.residual_flexibility, 4, builder.residual_flexibility_real()));
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      EXPECT_EQ(b.residual_flexibility[offset(i, 2, j)], g(i, j).real());
      EXPECT_EQ(b.residual_flexibility_imag[offset(i, 2, j)], g(i, j).imag());
    }
  builder.set_residual_flexibility(g.real());
  b = builder.basis();
  EXPECT_NE(b.residual_flexibility, nullptr);
  EXPECT_EQ(b.residual_flexibility_imag, nullptr);

  // New mode rows are new kept DOFs: the residual flexibility of the old ones is dropped.
  builder.set_mode_rows(Eigen::MatrixXd::Constant(2, 1, 0.5));
  b = builder.basis();
  EXPECT_EQ(b.residual_flexibility, nullptr);
  EXPECT_EQ(b.residual_flexibility_imag, nullptr);
}

TEST(ModalBasisBuilder, RefusesSizesThatDoNotMatch) {
  ModalBasisBuilder builder;
  builder.set_frequencies(Eigen::Vector3d(1.0, 2.0, 3.0));
  EXPECT_THROW(builder.set_damping_matrix(Eigen::Matrix2d::Zero()), std::invalid_argument);
  EXPECT_THROW(builder.add_damping_ratios({0.1, 0.2}), std::invalid_argument);
  EXPECT_THROW(builder.set_mode_rows(Eigen::MatrixXd::Zero(2, 2)), std::invalid_argument);
  builder.set_mode_rows(Eigen::MatrixXd::Zero(2, 3));
  EXPECT_THROW(builder.set_residual_flexibility(Eigen::Matrix3d::Zero()), std::invalid_argument);
  // Frequencies changed after the rows: basis() refuses rows of another mode count.
  builder.set_frequencies(Eigen::Vector2d(1.0, 2.0));
  EXPECT_THROW(builder.basis(), std::invalid_argument);
}

}  // namespace
