// The SDK's Eigen-based helpers, compiled as C++17 as a third-party plugin may be: the typed
// views of a step's tangents (frichb/plugin/tangents.hpp) against the row-major layout that
// abi.h defines, written out here as index arithmetic.
#include <gtest/gtest.h>

#include <cstddef>
#include <vector>

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

}  // namespace
