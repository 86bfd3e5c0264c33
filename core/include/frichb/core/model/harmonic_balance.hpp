// The harmonic-balance equations in receptance form, reduced to the contacts' relative
// displacements (thesis eq. 4.2 premultiplied by the contact gather matrix G):
//
//   e(U, w) = U - U0(w) + Rc(w) F(U) = 0,   U0 = G R Fext,   Rc = G R G^T,
//
// for every kept temporal harmonic n (receptance at n w). U holds, contact after contact,
// the harmonic coefficients of each used local component (t1, t2, n) of the relative
// displacement u = frame . (x_B - x_A); F the matching contact-force coefficients from AFT.
// Unknowns are y = [U; w] (w in rad/s, last). The model is a CurveProblem for the
// continuation module; evaluate() is not thread-safe (it reuses AFT work buffers). Inside one
// evaluation the contacts may be traced on several threads (set_contact_threads): each
// contact has its own tracer, law instance and trace, so the result does not depend on it.
#pragma once

#include <Eigen/Dense>
#include <Eigen/SparseCore>
#include <array>
#include <complex>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "frichb/core/model/reduced_structure.hpp"
#include "frichb/core/plugin_host/periodic_trace.hpp"
#include "frichb/core/scene/scene.hpp"
#include "frichb/core/solver/continuation.hpp"

namespace frichb::core {

struct ContactModel {
  std::string name;
  std::unique_ptr<ContactLawInstance> law;
  std::unique_ptr<PeriodicTracer> tracer;
  int offset = 0;  // first row of this contact's components in the stacked components
};

struct EvaluationStats {
  long residual_evaluations = 0;
  long jacobian_evaluations = 0;
  long contacts_with_fd_jacobian = 0;  // contact traces that fell back to finite differences
  long non_periodic_traces = 0;
  std::string last_trace_diagnostic;
  // Contact traces run, the passes over the period they took in total, and of those the
  // passes followed by a Newton step on the periodic state (TraceOptions).
  long traces = 0;
  long trace_passes = 0;
  long trace_newton_steps = 0;
  // Wall time spent in evaluate(), by part (seconds, summed over calls): the contact traces
  // (AFT, with the contacts' Jacobian blocks when asked), the receptances at the contacts with
  // the residual's receptance products, and the assembly of I + Rc dF/dU.
  double contact_seconds = 0.0;
  double receptance_seconds = 0.0;
  double assembly_seconds = 0.0;
};

// The gather matrix G of one kept harmonic: contact components x kept DOFs, at most six
// non-zeros per row (a frame direction at each side's node).
using SparseGather = Eigen::SparseMatrix<std::complex<double>, Eigen::RowMajor>;

// G F G^H for a Hermitian F (kept x kept): the flexibility F seen between the contact
// components, Hermitian, in about 12 (components x kept + components^2) flops.
Eigen::MatrixXcd gather_hermitian(const SparseGather& g, const Eigen::MatrixXcd& f);

struct HarmonicReceptance;  // model/harmonic_jacobian.hpp

class HarmonicBalanceModel final : public CurveProblem {
 public:
  // Builds the reduced model of a bound scene (plugins loaded, params validated) on an
  // instance of its structure, which must outlive the model. The scene must have passed
  // check_scene_against_plugins (scene/plugin_checks.hpp), which locates its errors in the
  // scene file; here a DOF out of range, a sector count that differs from cyclic.sectors or a
  // missing frame direction throws std::invalid_argument, a law refusing its params PluginError,
  // and a structure failing to give its modal basis PluginError.
  HarmonicBalanceModel(const Scene& scene, StructureModel& structure);
  ~HarmonicBalanceModel() override;

  // The model of `scene`, which differs from this model's scene at most in its contacts' law
  // parameters (the same contacts, in the same order, with the same laws, sides and frames, and
  // the same structure, excitation, harmonics and output): it shares this model's reduced
  // structure, so that no modal basis is fetched again, and instantiates the contacts' laws
  // anew. The new model does not refer to this one. Throws PluginError where a law refuses
  // its params and std::invalid_argument where a contact uses other components than here.
  std::unique_ptr<HarmonicBalanceModel> with_contact_params(const Scene& scene) const;
  // A model of the same scene with the excitation at temporal harmonic `harmonic` (>= 1) times
  // `scale` (the static load and the other harmonics' excitation as they are): it shares this
  // model's reduced structure and instantiates the contacts anew from `scene` (this model's).
  // Throws as with_contact_params, and std::invalid_argument for a harmonic below 1 or a scale
  // that is not finite.
  std::unique_ptr<HarmonicBalanceModel> with_excitation_scaled(const Scene& scene, int harmonic,
                                                               double scale) const;

  Eigen::Index equation_count() const override { return unknown_count_; }
  bool evaluate(const Eigen::VectorXd& y, Eigen::VectorXd& residual, Eigen::MatrixXd* jacobian,
                std::string* message) const override;
  // The Jacobian as an operator (model/harmonic_jacobian: I + Rc dF/dU applied, never formed,
  // with a harmonic-decoupled preconditioner). The operator shares the model's projected
  // modes and residual flexibilities: the model must outlive it.
  bool has_jacobian_operator() const override { return true; }
  bool evaluate_operator(const Eigen::VectorXd& y, Eigen::VectorXd& residual,
                         std::shared_ptr<const JacobianOperator>* jacobian,
                         std::string* message) const override;

  const HarmonicLayout& layout() const { return layout_; }
  const std::vector<ContactModel>& contacts() const { return contacts_; }
  const ReducedStructure& structure() const { return *structure_; }
  int component_count() const { return components_; }
  // Contact-free response of the contact unknowns at w (rad/s): U0.
  Eigen::VectorXd linear_response(double w) const;
  // The contact forces' coefficients of the last evaluation when it was at y (bit for bit),
  // else empty: what a continuation point keeps so that kept_response need not trace the
  // contacts again.
  Eigen::VectorXd point_record(const Eigen::VectorXd& y) const override;
  // Complex amplitude X_n (kept DOFs) of each kept harmonic for the solution y. `forces`: the
  // contact forces' coefficients at y (point_record), or empty to trace the contacts for them.
  // For a harmonic whose residual flexibility was reduced at construction (diagonal modal
  // damping and a residual flexibility), only the DOFs of the excitation's and the responses'
  // nodes are computed: the entries of the other kept DOFs are NaN.
  std::vector<Eigen::VectorXcd> kept_response(const Eigen::VectorXd& y,
                                              const Eigen::VectorXd& forces = {}) const;
  // The derivatives of kept_response at the kept DOFs `dofs` (kept indices) in y = [U; w]: per
  // kept harmonic k, a dofs x (n + 1) complex matrix D_k with dX_k = D_k dy. Analytic: the
  // contacts' force blocks dF/dU of the last evaluation, the receptances from the contacts to
  // the DOFs (one structure response per contact component and harmonic) and dR/dW (the
  // forces do not depend on w). The last contact trace must have been the one of an evaluation
  // with the Jacobian (evaluate or evaluate_operator) at y: throws std::logic_error otherwise.
  // Entries are NaN where kept_response's are (a DOF outside a reduced flexibility's rows).
  std::vector<Eigen::MatrixXcd> kept_response_jacobian(const Eigen::VectorXd& y,
                                                       const std::vector<Eigen::Index>& dofs) const;
  // The extended periodic motion concept (EPMC; Krack, Computers & Structures 154, 2015): the
  // same equations at y = [U; w] without the dynamic excitation (the harmonics n >= 1 of the
  // external force; harmonic 0's static load stays) and with every retained mode's damping
  // lowered by `xi` (rad/s): a damping -xi M in physical coordinates, so that the damped
  // motion is periodic. Mode r's impedance at W = n w is w_r^2 - W^2 + i W (c_rr - xi). The
  // residual flexibility, massless, is unchanged. `jacobian` (n x (n + 2)): d/dU, d/dw and
  // d/dxi. Needs diagonal modal damping at every kept harmonic n >= 1: false with `message`
  // otherwise, and where the evaluation fails as evaluate's does. Not thread-safe.
  bool evaluate_autonomous(const Eigen::VectorXd& y, double xi, Eigen::VectorXd& residual,
                           Eigen::MatrixXd* jacobian, std::string* message) const;
  // The modal coordinate q of retained mode `mode` (the structure's basis of kept harmonic k,
  // ascending frequency, mass-normalised) in harmonic k >= 1 of the autonomous motion at
  // y = [U; w] and xi: the complex amplitude with q(t) = Re(q e^{i n w t}),
  // q = -(Phi^H G^H F_n)_mode / z_mode(n w, xi). `gradient`, when given: dq/d[U; w; xi]
  // (n + 2 entries; from the contacts' force blocks dF/dU of the last evaluation, which must
  // have been one with the Jacobian at y: throws std::logic_error otherwise).
  // Throws std::invalid_argument for a harmonic 0, a mode out of range or a harmonic whose
  // receptance is formed (non-diagonal damping).
  std::complex<double> modal_coordinate(const Eigen::VectorXd& y, double xi, std::size_t k,
                                        Eigen::Index mode,
                                        Eigen::VectorXcd* gradient = nullptr) const;
  // The contact forces' complex amplitudes at kept harmonic k and y = [U; w], F_c - i F_s per
  // contact component (N): those of the last evaluation when it was at y, else traced. Throws
  // std::runtime_error where a trace fails.
  Eigen::VectorXcd contact_force_amplitudes(const Eigen::VectorXd& y, std::size_t k) const;
  // G F f_k: the contacts' static relative motion under kept harmonic k's excitation through
  // the residual flexibility (components, m); zero without one.
  Eigen::VectorXcd excitation_flexible_motion(std::size_t k) const {
    const Eigen::VectorXcd& motion = contact_receptance_[k].flexible_motion;
    return motion.size() ? motion : Eigen::VectorXcd::Zero(components_);
  }
  // P = G_n Phi of kept harmonic k: the structure's retained modes at the contact components
  // (components x modes), where harmonic k's modal damping is diagonal; else empty.
  const Eigen::MatrixXcd& contact_modes(std::size_t k) const {
    return contact_receptance_[k].projected;
  }
  // Index of a structure DOF among the kept DOFs.
  Eigen::Index kept_index(std::size_t dof) const;
  // Traces contact c at the solution y (for friction loops).
  bool trace_contact(std::size_t c, const Eigen::VectorXd& y, ContactTrace& out,
                     std::string* error) const;
  const EvaluationStats& stats() const { return stats_; }
  // How the receptance at the contacts is represented for one kept harmonic: by the structure's
  // retained modes (`modes` of them) with or without its static residual flexibility, or
  // formed from the structure's receptance (non-diagonal modal damping: `modal` false).
  struct ReceptanceForm {
    int harmonic = 0;
    int harmonic_index = 0;  // the structure's (nodal diameter for a cyclic sector)
    bool modal = false;
    Eigen::Index modes = 0;
    bool residual_flexibility = false;
  };
  std::vector<ReceptanceForm> receptance_forms() const;
  // u_n = G_n x_n of kept harmonic k (components x kept DOFs; real without cyclic symmetry),
  // sparse: a row holds the frame direction's entries at the DOFs of the contact's two sides.
  const SparseGather& gather(std::size_t k) const { return gather_[k]; }
  // The cyclic symmetry of the scene (sectors 1 without it).
  const CyclicSpec& cyclic() const { return cyclic_; }
  // The gather of the contact sides in the sector at `offset` (-1, 0, +1) from the reference
  // one: u = sum over offsets of W_offset x_(s + offset), real (components x kept DOFs). G_n of
  // harmonic n is their sum with the phase factors e^{-i n m phi offset}.
  const Eigen::SparseMatrix<double, Eigen::RowMajor>& side_gather(int offset) const {
    const int slot = offset + 1;
    return side_gather_.at(static_cast<std::size_t>(slot));
  }
  // G F G^H of kept harmonic k (components x components, Hermitian) where its modal damping is
  // diagonal and the structure has a residual flexibility F, else empty (F itself is reduced
  // to it at construction: ReducedStructure::FlexibilityUse).
  const Eigen::MatrixXcd& contact_flexibility(std::size_t k) const {
    return contact_receptance_[k].flexibility;
  }
  // G_h F_h G_h^H of harmonic index h (nodal diameter h of a cyclic sector, 0 without cyclic
  // symmetry; components x components, Hermitian; G_h the gather with the phase factors
  // e^{-i h phi offset}) for every index the model fetched, where the scene asks for stability
  // and the structure has a residual flexibility F_h; else null. The variational equations of
  // the stability analysis see the contacts' flexibility of every nodal diameter through it.
  const Eigen::MatrixXcd* index_flexibility(int h) const {
    const auto it = index_flexibility_.find(h);
    return it == index_flexibility_.end() ? nullptr : &it->second;
  }
  // Complex amplitude of the external force of kept harmonic k at the kept DOFs.
  const Eigen::VectorXcd& excitation(std::size_t k) const { return excitation_[k]; }
  JacobianMode jacobian_mode() const { return mode_; }
  // Threads that trace the contacts in an evaluation with the Jacobian, or in any evaluation
  // of 64 contacts or more (default 1; n <= 0: one per core). Contiguous ranges of contacts go
  // to each; at most one thread per contact. Residual-only evaluations of fewer contacts trace
  // on the calling thread (too little work per contact). From 600 contact components on, the
  // Jacobian operator's products and preconditioner solves use as many threads (one harmonic
  // per thread at a time).
  void set_contact_threads(int n);

 private:
  // with_contact_params: `base`'s structure, gathers, receptances and excitation, the contacts
  // of `scene`.
  HarmonicBalanceModel(const HarmonicBalanceModel& base, const Scene& scene);
  // The law and tracer of each of the scene's contacts, in order.
  static std::vector<ContactModel> instantiate_contacts(const Scene& scene,
                                                        const HarmonicLayout& trace_layout);

  // Traces every contact at y: their force coefficients into `forces`; with_jacobian: each
  // contact's block dF/dU into traces_[i].jacobian.
  void gather_forces(const Eigen::VectorXd& y, Eigen::VectorXd& forces, bool with_jacobian,
                     std::string* message, bool& ok) const;

  // evaluate and evaluate_operator: the Jacobian formed into `jacobian`, or as an operator
  // into `op` (at most one of them not null).
  // The autonomous (EPMC) form of an evaluation: the damping shift xi and, with the Jacobian,
  // the residual's derivative in xi (n entries) written into xi_column.
  struct Autonomy {
    double xi = 0.0;
    Eigen::VectorXd xi_column;
  };
  bool evaluate_into(const Eigen::VectorXd& y, Eigen::VectorXd& residual, Eigen::MatrixXd* jacobian,
                     std::shared_ptr<const JacobianOperator>* op, std::string* message,
                     Autonomy* autonomy = nullptr) const;
  // evaluate_into's Jacobian at frequency w from the contacts' blocks (traces_): as an operator
  // into `op` over the harmonics' `receptances` and `parameter_column`, or formed into
  // `jacobian` (neither: nothing). False, with `message`, where it is not finite.
  bool finish_jacobian(double w, Eigen::MatrixXd* jacobian,
                       std::shared_ptr<const JacobianOperator>* op,
                       std::vector<HarmonicReceptance>&& receptances,
                       Eigen::VectorXd&& parameter_column, std::string* message) const;

  // G_h F_h G_h^H of harmonic index `index` (the gather with its cyclic phase factors) into
  // index_flexibility_.
  void keep_index_flexibility(int index, const Eigen::MatrixXcd& f);

  struct ContactReceptance;
  struct Workspace;
  // ws.inv_z = 1 / z_r and ws.dinv_z = d(1/z_r)/dw of harmonic hn's modes at w, with every
  // mode's damping lowered by xi (0: the forced equations); with xi_derivative, ws.xi_inv_z =
  // d(1/z_r)/dxi. Diagonal modal damping.
  static void modal_impedances(const ReducedStructure::Basis& b, int hn, double w, double xi,
                               bool xi_derivative, Workspace& ws);
  // Rc_n = P diag(1/z) P^H from ws.inv_z into rc (components x components).
  void form_modal_receptance(const ContactReceptance& cr, Workspace& ws,
                             Eigen::Ref<Eigen::MatrixXcd> rc) const;
  // The first n columns of J = I + Rc dF/dU from the contacts' blocks (traces_) and the
  // contact receptances of every harmonic (work_.contact_receptance).
  void assemble_jacobian(Eigen::MatrixXd& jacobian) const;

  HarmonicLayout layout_;
  HarmonicLayout trace_layout_;  // the contacts' tracing grid (oversampled layout_)
  JacobianMode mode_;
  std::shared_ptr<const ReducedStructure> structure_;  // shared by with_contact_params
  std::vector<std::size_t> kept_dofs_;
  std::vector<ContactModel> contacts_;
  // Per kept harmonic: u_n = G_n x_n (components x kept DOFs), with the cyclic phase factors of
  // sides in neighbouring sectors; real and equal for all n without them.
  std::vector<SparseGather> gather_;
  std::vector<int> harmonic_index_;  // per kept harmonic
  CyclicSpec cyclic_;
  std::array<Eigen::SparseMatrix<double, Eigen::RowMajor>, 3> side_gather_;
  std::map<int, Eigen::MatrixXcd> index_flexibility_;  // index_flexibility()
  // Per kept harmonic, the receptance seen by the contacts, precomputed where the modal
  // damping is diagonal: G R(W) G^H = P diag(1 / z(W)) P^H + G F G^H with P = G Phi (contact
  // components x modes), and the contact-free response G R(W) f = P (q / z(W)) + G F f with
  // q = Phi^H f. An evaluation then costs components^2 x modes per harmonic, with no product
  // over the kept DOFs.
  struct ContactReceptance {
    bool modal = false;          // false: non-diagonal modal damping, R(W) is formed and gathered
    Eigen::MatrixXcd projected;  // P = G Phi
    Eigen::MatrixXd projected_real;  // P when it is real (no cyclic phase, real modes), else empty
    Eigen::VectorXcd modal_force;    // q = Phi^H f
    Eigen::MatrixXcd flexibility;    // G F G^H, or empty
    Eigen::VectorXcd flexible_motion;  // G F f, or empty
  };
  std::vector<ContactReceptance> contact_receptance_;
  std::vector<Eigen::VectorXcd> excitation_;  // per kept harmonic, over kept DOFs
  int components_ = 0;
  int contact_threads_ = 1;
  Eigen::Index unknown_count_ = 0;
  mutable EvaluationStats stats_;
  mutable std::vector<ContactTrace> traces_;
  // Work buffers of evaluate(), kept between calls so that the hot loop does not allocate.
  struct Workspace {
    Eigen::VectorXd forces;
    Eigen::VectorXd forces_at;  // the y of `forces` (empty when they failed or were never traced)
    // The y of the contacts' last trace when it carried their force blocks (traces_), else empty.
    Eigen::VectorXd jacobian_at;
    Eigen::MatrixXcd contact_receptance, receptance, receptance_derivative, product;
    Eigen::MatrixXcd force_block, scaled;
    Eigen::MatrixXd scaled_real, stacked_real;
    Eigen::VectorXcd inv_z, dinv_z, force, motion, motion_derivative, modal;
    // evaluate_autonomous: d(1/z)/dxi and the motion's derivative in xi of the harmonic
    // being assembled.
    Eigen::VectorXcd xi_inv_z, xi_motion;
  };
  mutable Workspace work_;
};

}  // namespace frichb::core
