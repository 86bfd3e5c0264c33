// Step-level checks shared by the suites of 2D-tangential laws with a 2-double state
// (coupled_3d, uncoupled_2d): one step through the real loader, and every tangent block of
// that step against central differences of the step itself.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <string>

#include "frichb/core/plugin_host/registry.hpp"

namespace frichb::test {

using core::ContactLawInstance;

// One step through the real loader: force (3) and state (2) from (state_prev, u_now).
struct StepResult {
  Eigen::Vector3d force;
  Eigen::Vector2d state;
  // The six ABI blocks, row-major as abi.h defines them.
  Eigen::Matrix<double, 3, 3, Eigen::RowMajor> df_du, df_dup;
  Eigen::Matrix<double, 3, 2, Eigen::RowMajor> df_ds;
  Eigen::Matrix<double, 2, 3, Eigen::RowMajor> ds_du, ds_dup;
  Eigen::Matrix<double, 2, 2, Eigen::RowMajor> ds_ds;
};
StepResult step_law(const ContactLawInstance& law, const Eigen::Vector2d& state_prev,
                    const Eigen::Vector3d& u_now) {
  StepResult r;
  r.df_du.setConstant(7);  // the law must overwrite every entry of every block
  r.df_dup.setConstant(7);
  r.df_ds.setConstant(7);
  r.ds_du.setConstant(7);
  r.ds_dup.setConstant(7);
  r.ds_ds.setConstant(7);
  frichb_step_tangents tangents{r.df_du.data(), r.df_dup.data(), r.df_ds.data(),
                                r.ds_du.data(), r.ds_dup.data(), r.ds_ds.data()};
  const double u_prev[3] = {0, 0, 0};
  std::string error;
  EXPECT_TRUE(law.step(state_prev.data(), u_prev, u_now.data(), r.force.data(), r.state.data(),
                       &tangents, &error))
      << error;
  return r;
}

// Every tangent block of one step against central differences of the step itself.
void expect_step_tangents_match_differences(const ContactLawInstance& law, const Eigen::Vector2d& w,
                                            const Eigen::Vector3d& u) {
  const StepResult r = step_law(law, w, u);
  const double h = 1e-9;
  for (int j = 0; j < 3; ++j) {
    Eigen::Vector3d up = u, um = u;
    up(j) += h;
    um(j) -= h;
    const StepResult p = step_law(law, w, up), m = step_law(law, w, um);
    const Eigen::Vector3d df = (p.force - m.force) / (2 * h);
    const Eigen::Vector2d ds = (p.state - m.state) / (2 * h);
    EXPECT_LT((r.df_du.col(j) - df).cwiseAbs().maxCoeff(), 1e-6 * (1 + df.cwiseAbs().maxCoeff()))
        << "d force / d u_" << j;
    EXPECT_LT((r.ds_du.col(j) - ds).cwiseAbs().maxCoeff(), 1e-6) << "d state / d u_" << j;
  }
  for (int k = 0; k < 2; ++k) {
    Eigen::Vector2d wp = w, wm = w;
    wp(k) += h;
    wm(k) -= h;
    const StepResult p = step_law(law, wp, u), m = step_law(law, wm, u);
    const Eigen::Vector3d df = (p.force - m.force) / (2 * h);
    const Eigen::Vector2d ds = (p.state - m.state) / (2 * h);
    EXPECT_LT((r.df_ds.col(k) - df).cwiseAbs().maxCoeff(), 1e-6 * (1 + df.cwiseAbs().maxCoeff()))
        << "d force / d w_" << k;
    EXPECT_LT((r.ds_ds.col(k) - ds).cwiseAbs().maxCoeff(), 1e-6) << "d state / d w_" << k;
  }
  EXPECT_EQ(r.df_dup.cwiseAbs().maxCoeff(), 0.0);  // the law does not use u_prev
  EXPECT_EQ(r.ds_dup.cwiseAbs().maxCoeff(), 0.0);
}

}  // namespace frichb::test
