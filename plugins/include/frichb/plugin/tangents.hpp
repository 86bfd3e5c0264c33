// FricHB plugin SDK: typed views of the consistent tangents of one contact-law step.
//
// frichb_step_tangents (abi.h) hands a law six raw row-major blocks; StepTangents maps each
// one as an Eigen matrix of its shape, so that a law writes `fu(0, 2) = dT1/du_n` or assigns
// whole blocks instead of computing `i * 3 + j` offsets. S is the law's state_size:
//
//   block                 shape   entry (i, j)
//   dforce_du_now()       3 x 3   d force_now_i / d u_now_j          (N/m)
//   dforce_du_prev()      3 x 3   d force_now_i / d u_prev_j         (N/m)
//   dforce_dstate_prev()  3 x S   d force_now_i / d state_prev_j     (N per state unit)
//   dstate_du_now()       S x 3   d state_now_i / d u_now_j          (state unit per m)
//   dstate_du_prev()      S x 3   d state_now_i / d u_prev_j         (state unit per m)
//   dstate_dstate_prev()  S x S   d state_now_i / d state_prev_j     (1 for a state in m)
//
// Rows and columns of forces and displacements run over the local frame (t1, t2, n); forces
// in N, displacements in m, the state in the law's own units.
//
// Contract:
//  - Ownership: the view owns nothing. It wraps the host's arrays, which stay valid for the
//    step() call that received them; never keep a view (or a block) beyond that call.
//  - wanted(): the host asks for tangents with a non-null pointer whose dforce_du_now is
//    non-null, and then passes all six blocks. Otherwise no block may be touched through this
//    view: step() computes the force and state and returns. (step_along, ABI 1.3, may also be
//    given only dstate_dstate_prev, with the other five null: a law writes that S x S block
//    directly; see abi.h.)
//  - Every entry of every block must be written: the host zeroes the blocks before each
//    call, but callers such as test harnesses may not. zero() clears all six blocks; a law
//    calls it once and then writes its nonzero entries.
//  - Threading: step() runs concurrently on several threads, each with its own arrays; a
//    view is a local of one call and shares nothing.
//  - Failure: nothing here throws or allocates. No block may be used when wanted() is
//    false: it may map a null pointer (undefined behaviour).
//
// Header-only and C++17; it needs Eigen 3.3 or later (the FricHB::sdk target brings it).
// sdk.hpp does not include this header, so a plugin that does not use it needs no Eigen.
#pragma once

#include <Eigen/Core>

#include "frichb/plugin/abi.h"

namespace frichb::sdk {

class StepTangents {
 public:
  template <int Rows, int Cols>
  using Block = Eigen::Map<Eigen::Matrix<double, Rows, Cols, Eigen::RowMajor>>;
  using ForceByDisplacement = Block<3, 3>;                     // 3 x 3
  using ForceByState = Block<3, Eigen::Dynamic>;               // 3 x S
  using StateByDisplacement = Block<Eigen::Dynamic, 3>;        // S x 3
  using StateByState = Block<Eigen::Dynamic, Eigen::Dynamic>;  // S x S

  // `tangents` as step() received it (may be null); `state_size` is the law's
  // traits().state_size (>= 0).
  StepTangents(const frichb_step_tangents* tangents, int state_size) noexcept
      : t_(tangents), s_(state_size) {}

  // True when the host asks for tangents in this call.
  bool wanted() const noexcept { return t_ != nullptr && t_->dforce_du_now != nullptr; }
  int state_size() const noexcept { return s_; }

  ForceByDisplacement dforce_du_now() const noexcept {
    return ForceByDisplacement(data(&frichb_step_tangents::dforce_du_now));
  }
  ForceByDisplacement dforce_du_prev() const noexcept {
    return ForceByDisplacement(data(&frichb_step_tangents::dforce_du_prev));
  }
  ForceByState dforce_dstate_prev() const noexcept {
    return ForceByState(data(&frichb_step_tangents::dforce_dstate_prev), 3, s_);
  }
  StateByDisplacement dstate_du_now() const noexcept {
    return StateByDisplacement(data(&frichb_step_tangents::dstate_du_now), s_, 3);
  }
  StateByDisplacement dstate_du_prev() const noexcept {
    return StateByDisplacement(data(&frichb_step_tangents::dstate_du_prev), s_, 3);
  }
  StateByState dstate_dstate_prev() const noexcept {
    return StateByState(data(&frichb_step_tangents::dstate_dstate_prev), s_, s_);
  }

  // Sets every entry of the six blocks to 0. Does nothing when !wanted().
  void zero() const noexcept {
    if (!wanted()) return;
    dforce_du_now().setZero();
    dforce_du_prev().setZero();
    dforce_dstate_prev().setZero();
    dstate_du_now().setZero();
    dstate_du_prev().setZero();
    dstate_dstate_prev().setZero();
  }

 private:
  double* data(double* frichb_step_tangents::*block) const noexcept {
    return t_ != nullptr ? t_->*block : nullptr;
  }

  const frichb_step_tangents* t_;
  int s_;
};

}  // namespace frichb::sdk
