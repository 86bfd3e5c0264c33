#include "frichb/core/model/harmonic_balance.hpp"

#include "frichb/core/numerics/dense_products.hpp"
#include "frichb/core/support/threads.hpp"
#include "model/harmonic_jacobian.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <thread>

namespace frichb::core {

namespace {

// From this many contacts on, traces of the forces alone are spread over the contact threads
// too (64 contacts at tens of microseconds each: about a millisecond per evaluation).
constexpr std::size_t kThreadedForceTraces = 64;

std::vector<std::size_t> collect_kept_dofs(const Scene& scene) {
  std::vector<std::size_t> kept;
  auto add_node = [&](const std::string& name) {
    if (name == "ground") return;
    for (std::size_t d : scene.structure.find(name)->dofs)
      if (std::find(kept.begin(), kept.end(), d) == kept.end()) kept.push_back(d);
  };
  for (const auto& c : scene.contacts) {
    add_node(c.side_a);
    add_node(c.side_b);
  }
  for (const auto& e : scene.excitation) add_node(e.node);
  for (const auto& r : scene.output.response) add_node(r);
  return kept;
}

// Indices among the kept DOFs of the excitation's and the responses' nodes' DOFs: where the
// output reads the structure's response.
std::vector<Eigen::Index> observed_kept_rows(const Scene& scene,
                                             const std::vector<std::size_t>& kept) {
  std::vector<Eigen::Index> rows;
  auto add_node = [&](const std::string& name) {
    if (name == "ground") return;
    for (std::size_t d : scene.structure.find(name)->dofs) {
      const auto row =
          static_cast<Eigen::Index>(std::find(kept.begin(), kept.end(), d) - kept.begin());
      if (std::find(rows.begin(), rows.end(), row) == rows.end()) rows.push_back(row);
    }
  };
  for (const auto& e : scene.excitation) add_node(e.node);
  for (const auto& r : scene.output.response) add_node(r);
  return rows;
}

// evaluate() writes each row of the Jacobian through the cos and sin indices of the kept
// harmonics: they must cover every coefficient exactly once.
void check_coefficient_cover(const HarmonicLayout& layout) {
  std::vector<int> seen(static_cast<std::size_t>(layout.coefficient_count()), 0);
  for (std::size_t k = 0; k < layout.harmonics().size(); ++k) {
    ++seen[static_cast<std::size_t>(layout.cos_index(k))];
    if (layout.harmonics()[k] > 0) ++seen[static_cast<std::size_t>(layout.sin_index(k))];
  }
  if (std::any_of(seen.begin(), seen.end(), [](int v) { return v != 1; }))
    throw std::logic_error("HarmonicLayout: cos/sin indices do not cover the coefficients");
}

}  // namespace

HarmonicBalanceModel::HarmonicBalanceModel(const Scene& scene, StructureModel& structure)
    : layout_(scene.harmonic_balance.harmonics, scene.harmonic_balance.samples_per_period),
      trace_layout_(
          scene.harmonic_balance.harmonics,
          scene.harmonic_balance.samples_per_period * scene.harmonic_balance.trace_oversampling),
      mode_(scene.harmonic_balance.analytic_jacobian ? JacobianMode::kAnalytic
                                                     : JacobianMode::kFiniteDifference) {
  // The scene's checks against its plugins (check_scene_against_plugins) locate these errors
  // in the scene; here they are preconditions.
  const std::size_t n_dofs = structure.dof_count();
  for (const auto& node : scene.structure.nodes)
    for (std::size_t d : node.dofs)
      if (d >= n_dofs)
        throw std::invalid_argument("HarmonicBalanceModel: node '" + node.name + "' names DOF " +
                                    std::to_string(d) + " of a structure with " +
                                    std::to_string(n_dofs));
  if (static_cast<int>(structure.sector_count()) != scene.cyclic.sectors)
    throw std::invalid_argument(
        "HarmonicBalanceModel: the structure models " + std::to_string(structure.sector_count()) +
        " sectors, the scene's cyclic section " + std::to_string(scene.cyclic.sectors));
  kept_dofs_ = collect_kept_dofs(scene);
  cyclic_ = scene.cyclic;
  // Harmonic index of each kept temporal harmonic; only the indices they excite are built,
  // and for the stability of a cyclic scene every nodal diameter's (model/stability.hpp).
  std::vector<int> indices;
  for (int n : layout_.harmonics()) {
    harmonic_index_.push_back(scene.cyclic.harmonic_index(n));
    if (std::find(indices.begin(), indices.end(), harmonic_index_.back()) == indices.end())
      indices.push_back(harmonic_index_.back());
  }
  if (scene.cyclic.enabled() && scene.output.stability)
    for (int h = 0; 2 * h <= scene.cyclic.sectors; ++h)
      if (std::find(indices.begin(), indices.end(), h) == indices.end()) indices.push_back(h);
  const auto kept = static_cast<Eigen::Index>(kept_dofs_.size());
  // Gather weights of the sides in the reference sector (offset 0) and in its neighbours
  // (offsets -1, +1) as (row, kept DOF, weight), combined per harmonic with the cyclic phase
  // factors below.
  std::vector<std::vector<Eigen::Triplet<double>>> by_offset(3);

  contacts_ = instantiate_contacts(scene, trace_layout_);
  for (std::size_t i = 0; i < scene.contacts.size(); ++i) {
    const ContactSpec& spec = scene.contacts[i];
    ContactModel& c = contacts_[i];
    const auto& comps = c.tracer->components();
    for (std::size_t a = 0; a < comps.size(); ++a) {
      const std::vector<double>& dir =
          comps[a] == 0 ? spec.tangent1 : (comps[a] == 1 ? spec.tangent2 : spec.normal);
      if (dir.empty())
        throw std::invalid_argument("HarmonicBalanceModel: contact '" + spec.name +
                                    "' has no frame." + kContactAxisNames[comps[a]] +
                                    " direction and its law uses it");
      auto add_side = [&](const std::string& side, int sector, double sign) {
        if (side == "ground") return;
        const auto& dofs = scene.structure.find(side)->dofs;
        const int slot = sector + 1;  // offsets -1, 0, +1 -> slots 0, 1, 2
        auto& w = by_offset[static_cast<std::size_t>(slot)];
        for (std::size_t k = 0; k < dofs.size(); ++k)
          w.emplace_back(components_ + static_cast<Eigen::Index>(a), kept_index(dofs[k]),
                         sign * dir[k]);
      };
      add_side(spec.side_a, spec.sector_a, -1.0);
      add_side(spec.side_b, spec.sector_b, +1.0);
    }
    c.offset = components_;
    components_ += static_cast<int>(comps.size());
  }
  // Sector s + o moves like the reference sector delayed by o Delta t: harmonic n of its
  // displacement is the reference's times e^{-i n m phi o} (thesis eqs. 2.7, 2.16-2.17). The
  // force on a neighbour's node reaches the reference sector through the conjugate factor,
  // hence G^H for forces (Newton's third law with cyclic symmetry, thesis eq. 2.13).
  for (std::size_t slot = 0; slot < 3; ++slot) {
    side_gather_[slot].resize(components_, kept);
    side_gather_[slot].setFromTriplets(by_offset[slot].begin(), by_offset[slot].end());
  }
  const double phi = scene.cyclic.enabled() ? 2.0 * std::numbers::pi / scene.cyclic.sectors : 0.0;
  for (int n : layout_.harmonics()) {
    std::vector<Eigen::Triplet<std::complex<double>>> entries;
    for (int slot = 0; slot < 3; ++slot) {
      const int offset = slot - 1;
      const std::complex<double> factor =
          std::polar(1.0, -n * scene.cyclic.engine_order * phi * offset);
      for (const auto& t : by_offset[static_cast<std::size_t>(slot)])
        entries.emplace_back(t.row(), t.col(), factor * t.value());
    }
    SparseGather g(components_, kept);
    g.setFromTriplets(entries.begin(), entries.end());  // duplicates (one DOF twice) summed
    gather_.push_back(std::move(g));
  }
  unknown_count_ = static_cast<Eigen::Index>(components_) * layout_.coefficient_count();
  check_coefficient_cover(layout_);
  traces_.resize(contacts_.size());

  const auto& h = layout_.harmonics();
  excitation_.assign(h.size(), Eigen::VectorXcd::Zero(kept));
  for (const auto& e : scene.excitation) {
    const auto k = static_cast<std::size_t>(std::find(h.begin(), h.end(), e.harmonic) - h.begin());
    const auto& dofs = scene.structure.find(e.node)->dofs;
    // amplitude cos(n w t + phase) = Re(amplitude e^{i phase} e^{i n w t})
    // A static force (n = 0) has no phase but its sign: amplitude cos(phase).
    const std::complex<double> a = e.harmonic == 0
                                       ? std::complex<double>(e.amplitude * std::cos(e.phase))
                                       : std::polar(e.amplitude, e.phase);
    for (std::size_t d = 0; d < dofs.size(); ++d)
      excitation_[k](kept_index(dofs[d])) += a * e.direction[d];
  }
  // The residual flexibility F of a harmonic index is kept x kept: it is reduced, as the
  // structure fetches it, to what the harmonics of that index need (G F G^H, G F f) and to its
  // rows at the responses the output reads (the excitation's and the responses' DOFs).
  contact_receptance_.resize(h.size());
  ReducedStructure::FlexibilityUse use;
  use.response_rows = observed_kept_rows(scene, kept_dofs_);
  // The stability analysis sees every index's F between the contacts (index_flexibility).
  const bool stability = scene.output.stability;
  use.reduce = [this, stability](int index, const Eigen::MatrixXcd& f) {
    for (std::size_t k = 0; k < harmonic_index_.size(); ++k) {
      if (harmonic_index_[k] != index) continue;
      contact_receptance_[k].flexibility = gather_hermitian(gather_[k], f);
      contact_receptance_[k].flexible_motion = gather_[k] * (f * excitation_[k]);
    }
    if (stability) keep_index_flexibility(index, f);
  };
  structure_ = std::make_shared<const ReducedStructure>(structure, kept_dofs_, indices, &use);
  for (int index : indices) {  // a basis with non-diagonal damping keeps F whole
    const ReducedStructure::Basis& b = structure_->basis(index);
    if (stability && b.residual_flexibility.size() > 0)
      keep_index_flexibility(index, b.residual_flexibility);
  }
  for (std::size_t k = 0; k < h.size(); ++k) {
    const ReducedStructure::Basis& b = structure_->basis(harmonic_index_[k]);
    ContactReceptance& cr = contact_receptance_[k];
    cr.modal = b.diagonal_damping;
    if (cr.modal) {
      cr.projected = gather_[k] * b.rows;
      // Without cyclic phase factors and with real modes P is real: Rc_n is then formed by
      // one real product of twice the rows instead of a complex one (half the flops).
      if (cr.projected.size() == 0 || cr.projected.imag().cwiseAbs().maxCoeff() == 0.0)
        cr.projected_real = cr.projected.real();
      cr.modal_force = b.rows.adjoint() * excitation_[k];
    }
  }
}

void HarmonicBalanceModel::keep_index_flexibility(int index, const Eigen::MatrixXcd& f) {
  const double phi = cyclic_.enabled() ? 2.0 * std::numbers::pi / cyclic_.sectors : 0.0;
  SparseGather g(components_, static_cast<Eigen::Index>(kept_dofs_.size()));
  for (int offset = -1; offset <= 1; ++offset) {
    const int slot = offset + 1;
    g += side_gather_[static_cast<std::size_t>(slot)].cast<std::complex<double>>() *
         std::polar(1.0, -index * phi * offset);
  }
  index_flexibility_[index] = gather_hermitian(g, f);
}

Eigen::MatrixXcd gather_hermitian(const SparseGather& g, const Eigen::MatrixXcd& f) {
  // G F G^H = G (G F^H)^H = G (G F)^H for Hermitian F; symmetrised against rounding.
  const Eigen::MatrixXcd gf = g * f;  // components x kept
  Eigen::MatrixXcd out = g * gf.adjoint();
  out = (0.5 * (out + out.adjoint())).eval();
  return out;
}

HarmonicBalanceModel::~HarmonicBalanceModel() = default;

std::vector<ContactModel> HarmonicBalanceModel::instantiate_contacts(
    const Scene& scene, const HarmonicLayout& trace_layout) {
  TraceOptions trace_options;
  trace_options.max_passes = scene.harmonic_balance.max_trace_passes;
  trace_options.newton_on_periodic_state = scene.harmonic_balance.periodic_state_newton;
  trace_options.along_motion = scene.harmonic_balance.trace_along_motion;
  std::vector<ContactModel> contacts;
  for (const auto& spec : scene.contacts) {
    ContactModel c;
    c.name = spec.name;
    c.law = std::make_unique<ContactLawInstance>(spec.plugin, spec.values);
    c.tracer = std::make_unique<PeriodicTracer>(*c.law, trace_layout, trace_options);
    contacts.push_back(std::move(c));
  }
  return contacts;
}

HarmonicBalanceModel::HarmonicBalanceModel(const HarmonicBalanceModel& base, const Scene& scene)
    : layout_(base.layout_),
      trace_layout_(base.trace_layout_),
      mode_(base.mode_),
      structure_(base.structure_),
      kept_dofs_(base.kept_dofs_),
      contacts_(instantiate_contacts(scene, trace_layout_)),
      gather_(base.gather_),
      harmonic_index_(base.harmonic_index_),
      cyclic_(base.cyclic_),
      side_gather_(base.side_gather_),
      index_flexibility_(base.index_flexibility_),
      contact_receptance_(base.contact_receptance_),
      excitation_(base.excitation_),
      components_(base.components_),
      contact_threads_(base.contact_threads_),
      unknown_count_(base.unknown_count_),
      traces_(base.contacts_.size()) {
  if (contacts_.size() != base.contacts_.size())
    throw std::invalid_argument(
        "HarmonicBalanceModel::with_contact_params: " + std::to_string(contacts_.size()) +
        " contacts, not " + std::to_string(base.contacts_.size()));
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    ContactModel& c = contacts_[i];
    const ContactModel& was = base.contacts_[i];
    if (c.name != was.name || c.tracer->components() != was.tracer->components())
      throw std::invalid_argument("HarmonicBalanceModel::with_contact_params: contact '" + c.name +
                                  "' is not '" + was.name + "' with the same components");
    c.offset = was.offset;
  }
}

std::unique_ptr<HarmonicBalanceModel> HarmonicBalanceModel::with_contact_params(
    const Scene& scene) const {
  return std::unique_ptr<HarmonicBalanceModel>(new HarmonicBalanceModel(*this, scene));
}

std::unique_ptr<HarmonicBalanceModel> HarmonicBalanceModel::with_excitation_scaled(
    const Scene& scene, int harmonic, double scale) const {
  if (harmonic < 1 || !std::isfinite(scale))
    throw std::invalid_argument("with_excitation_scaled: a harmonic >= 1 and a finite scale, not " +
                                std::to_string(harmonic) + " and " + std::to_string(scale));
  std::unique_ptr<HarmonicBalanceModel> scaled(new HarmonicBalanceModel(*this, scene));
  const auto& h = layout_.harmonics();
  for (std::size_t k = 0; k < h.size(); ++k) {
    if (h[k] != harmonic) continue;
    scaled->excitation_[k] *= scale;
    ContactReceptance& cr = scaled->contact_receptance_[k];
    cr.modal_force *= scale;
    cr.flexible_motion *= scale;
  }
  return scaled;
}

std::vector<HarmonicBalanceModel::ReceptanceForm> HarmonicBalanceModel::receptance_forms() const {
  std::vector<ReceptanceForm> out;
  for (std::size_t k = 0; k < contact_receptance_.size(); ++k) {
    const ContactReceptance& cr = contact_receptance_[k];
    ReceptanceForm f;
    f.harmonic = layout_.harmonics()[k];
    f.harmonic_index = harmonic_index_[k];
    f.modal = cr.modal;
    f.modes = cr.modal ? cr.projected.cols() : structure_->basis(harmonic_index_[k]).rows.cols();
    f.residual_flexibility = structure_->basis(harmonic_index_[k]).has_residual_flexibility();
    out.push_back(f);
  }
  return out;
}

Eigen::Index HarmonicBalanceModel::kept_index(std::size_t dof) const {
  auto it = std::find(kept_dofs_.begin(), kept_dofs_.end(), dof);
  return it == kept_dofs_.end() ? -1 : static_cast<Eigen::Index>(it - kept_dofs_.begin());
}

void HarmonicBalanceModel::set_contact_threads(int n) {
  contact_threads_ =
      n > 0 ? n : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

void HarmonicBalanceModel::gather_forces(const Eigen::VectorXd& y, Eigen::VectorXd& forces,
                                         bool with_jacobian, std::string* message, bool& ok) const {
  const int c = layout_.coefficient_count();
  const std::size_t count = contacts_.size();
  forces.setZero(unknown_count_);
  ok = true;
  work_.jacobian_at.resize(0);  // traces_ are overwritten from here on
  // Each contact is traced into its own traces_[i], with its own tracer and law instance;
  // failures and statistics are gathered afterwards, in contact order, on this thread.
  std::vector<char> traced(count, 0);
  std::vector<std::string> errors(count);
  const auto trace_range = [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const auto& contact = contacts_[i];
      const Eigen::Index first = static_cast<Eigen::Index>(contact.offset) * c;
      const Eigen::VectorXd u = y.segment(first, contact.tracer->unknown_count());
      traced[i] = contact.tracer->trace(u, with_jacobian ? mode_ : JacobianMode::kNone, traces_[i],
                                        &errors[i]);
      if (!traced[i]) return;  // this range stops at its first failure
    }
  };
  // Traces with the Jacobian are worth threads (0.1 to 1 ms per contact); the forces alone
  // (tens of microseconds per contact, less than starting a thread) only for many contacts.
  // At least one range, empty for a scene without contacts.
  const std::size_t threads =
      with_jacobian || count >= kThreadedForceTraces
          ? std::clamp<std::size_t>(count, 1,
                                    static_cast<std::size_t>(std::max(1, contact_threads_)))
          : 1;
  run_on_threads(
      threads, [&](std::size_t t) { trace_range(t * count / threads, (t + 1) * count / threads); });
  for (std::size_t i = 0; i < count; ++i) {
    const auto& contact = contacts_[i];
    if (!traced[i]) {
      if (message) *message = "contact '" + contact.name + "': " + errors[i];
      ok = false;
      return;
    }
    const ContactTrace& t = traces_[i];
    if (t.used_finite_differences) ++stats_.contacts_with_fd_jacobian;
    ++stats_.traces;
    stats_.trace_passes += t.passes;
    stats_.trace_newton_steps += t.newton_passes;
    if (!t.periodic) {
      ++stats_.non_periodic_traces;
      stats_.last_trace_diagnostic = "contact '" + contact.name + "': " + t.diagnostic;
    }
    forces.segment(static_cast<Eigen::Index>(contact.offset) * c, contact.tracer->unknown_count()) =
        t.force_coefficients;
  }
  if (with_jacobian) work_.jacobian_at = y;
}

Eigen::VectorXd HarmonicBalanceModel::linear_response(double w) const {
  const int c = layout_.coefficient_count();
  const auto& h = layout_.harmonics();
  Eigen::VectorXd u0 = Eigen::VectorXd::Zero(unknown_count_);
  for (std::size_t k = 0; k < h.size(); ++k) {
    if (excitation_[k].cwiseAbs().maxCoeff() == 0.0) continue;
    const ContactReceptance& cr = contact_receptance_[k];
    Eigen::VectorXcd x;
    if (cr.modal) {
      // G R(W) f = P (q / z(W)) + G F f: the structure's F may have been reduced to G F f.
      const ReducedStructure::Basis& b = structure_->basis(harmonic_index_[k]);
      const double big_w = h[k] * w;
      Eigen::VectorXcd modal = cr.modal_force;
      for (Eigen::Index q = 0; q < modal.size(); ++q) {
        const double wr = b.frequencies(q);
        modal(q) /= std::complex<double>(wr * wr - big_w * big_w, big_w * b.damping(q, q));
      }
      x = cr.projected * modal;
      if (cr.flexible_motion.size()) x += cr.flexible_motion;
    } else {
      x = gather_[k] * structure_->respond(harmonic_index_[k], h[k] * w, excitation_[k]);
    }
    for (int a = 0; a < components_; ++a) {
      u0(a * c + layout_.cos_index(k)) = x(a).real();
      if (h[k] > 0) u0(a * c + layout_.sin_index(k)) = -x(a).imag();
    }
  }
  return u0;
}

void HarmonicBalanceModel::form_modal_receptance(const ContactReceptance& cr, Workspace& ws,
                                                 Eigen::Ref<Eigen::MatrixXcd> rc) const {
  // Rc = P diag(1/z) P^H by one level-3 product (BLAS when built with OpenBLAS).
  const Eigen::Index modes = ws.inv_z.size();
  if (cr.projected_real.size()) {
    // Real P: [Re Rc; Im Rc] = [P diag(Re 1/z); P diag(Im 1/z)] P^T.
    ws.scaled_real.resize(2 * components_, modes);
    ws.scaled_real.topRows(components_).noalias() =
        cr.projected_real * ws.inv_z.real().asDiagonal();
    ws.scaled_real.bottomRows(components_).noalias() =
        cr.projected_real * ws.inv_z.imag().asDiagonal();
    ws.stacked_real.resize(2 * components_, components_);
    multiply(1.0, ws.scaled_real, MatrixOperation::kNone, cr.projected_real,
             MatrixOperation::kTranspose, 0.0, ws.stacked_real);
    rc.real() = ws.stacked_real.topRows(components_);
    rc.imag() = ws.stacked_real.bottomRows(components_);
  } else {
    ws.scaled.resize(components_, modes);
    ws.scaled.noalias() = cr.projected * ws.inv_z.asDiagonal();
    multiply(1.0, ws.scaled, MatrixOperation::kNone, cr.projected, MatrixOperation::kAdjoint, 0.0,
             rc);
  }
}

void HarmonicBalanceModel::assemble_jacobian(Eigen::MatrixXd& jacobian) const {
  const int c = layout_.coefficient_count();
  const auto& h = layout_.harmonics();
  const std::complex<double> imaginary_unit(0.0, 1.0);
  Workspace& ws = work_;
  // J = I + Rc dF/dU. dF/dU is block diagonal (one block T per contact, whose unknowns are
  // contiguous) and Rc is block diagonal over the harmonics, so the columns of contact i in
  // the rows of harmonic n are Rc_n[:, i's components] (T's cos rows - i T's sin rows) of
  // harmonic n: components x d x p complex multiply-adds per harmonic and contact, about
  // 4 d (H + 1) / (2H + 1) per entry of J, each entry written once.
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    const Eigen::Index first = static_cast<Eigen::Index>(contacts_[i].offset) * c;
    const Eigen::Index p = contacts_[i].tracer->unknown_count();
    const Eigen::Index d = p / c;
    const Eigen::MatrixXd& block = traces_[i].jacobian;
    for (std::size_t k = 0; k < h.size(); ++k) {
      const int ci = layout_.cos_index(k), si = layout_.sin_index(k);
      ws.force_block.resize(d, p);
      for (Eigen::Index b = 0; b < d; ++b) {
        if (h[k] > 0)
          ws.force_block.row(b) = block.row(b * c + ci).cast<std::complex<double>>() -
                                  imaginary_unit * block.row(b * c + si);
        else
          ws.force_block.row(b) = block.row(b * c + ci).cast<std::complex<double>>();
      }
      ws.product.noalias() =
          ws.contact_receptance.block(
              0, static_cast<Eigen::Index>(k) * components_ + contacts_[i].offset, components_, d) *
          ws.force_block;
      for (int a = 0; a < components_; ++a) {
        jacobian.row(a * c + ci).segment(first, p) = ws.product.row(a).real();
        if (h[k] > 0) jacobian.row(a * c + si).segment(first, p) = -ws.product.row(a).imag();
      }
    }
  }
}

bool HarmonicBalanceModel::evaluate(const Eigen::VectorXd& y, Eigen::VectorXd& residual,
                                    Eigen::MatrixXd* jacobian, std::string* message) const {
  return evaluate_into(y, residual, jacobian, nullptr, message);
}

bool HarmonicBalanceModel::evaluate_operator(const Eigen::VectorXd& y, Eigen::VectorXd& residual,
                                             std::shared_ptr<const JacobianOperator>* jacobian,
                                             std::string* message) const {
  return evaluate_into(y, residual, nullptr, jacobian, message);
}

bool HarmonicBalanceModel::evaluate_autonomous(const Eigen::VectorXd& y, double xi,
                                               Eigen::VectorXd& residual, Eigen::MatrixXd* jacobian,
                                               std::string* message) const {
  if (!std::isfinite(xi)) {
    if (message) *message = "the damping shift xi is not finite";
    return false;
  }
  Autonomy autonomy{xi, {}};
  Eigen::MatrixXd formed;
  if (!evaluate_into(y, residual, jacobian != nullptr ? &formed : nullptr, nullptr, message,
                     &autonomy))
    return false;
  if (jacobian != nullptr) {
    const Eigen::Index n = unknown_count_;
    jacobian->resize(n, n + 2);
    jacobian->leftCols(n + 1) = formed;
    jacobian->col(n + 1) = autonomy.xi_column;
  }
  return true;
}

Eigen::VectorXcd HarmonicBalanceModel::contact_force_amplitudes(const Eigen::VectorXd& y,
                                                                std::size_t k) const {
  const auto& h = layout_.harmonics();
  if (k >= h.size()) throw std::invalid_argument("contact_force_amplitudes: not a kept harmonic");
  Eigen::VectorXd traced;
  const Eigen::VectorXd* forces = &work_.forces;
  if (work_.forces_at.size() != y.size() || (work_.forces_at.array() != y.array()).any()) {
    bool ok = true;
    std::string message;
    gather_forces(y, traced, false, &message, ok);
    if (!ok) throw std::runtime_error("contact_force_amplitudes: " + message);
    forces = &traced;
  }
  const int c = layout_.coefficient_count();
  Eigen::VectorXcd out(components_);
  for (int a = 0; a < components_; ++a)
    out(a) = std::complex<double>((*forces)(a * c + layout_.cos_index(k)),
                                  h[k] > 0 ? -(*forces)(a * c + layout_.sin_index(k)) : 0.0);
  return out;
}

std::complex<double> HarmonicBalanceModel::modal_coordinate(const Eigen::VectorXd& y, double xi,
                                                            std::size_t k, Eigen::Index mode,
                                                            Eigen::VectorXcd* gradient) const {
  const auto& h = layout_.harmonics();
  if (k >= h.size() || h[k] < 1)
    throw std::invalid_argument("modal_coordinate: not a kept harmonic n >= 1");
  const ContactReceptance& cr = contact_receptance_[k];
  if (!cr.modal)
    throw std::invalid_argument(
        "modal_coordinate: harmonic " + std::to_string(h[k]) +
        " has non-diagonal modal damping (its receptance is formed, not modal)");
  if (mode < 0 || mode >= cr.projected.cols())
    throw std::invalid_argument("modal_coordinate: mode " + std::to_string(mode) + " of " +
                                std::to_string(cr.projected.cols()));
  const int c = layout_.coefficient_count();
  const Eigen::Index n = unknown_count_;
  const int hn = h[k];
  const int ci = layout_.cos_index(k), si = layout_.sin_index(k);
  const Eigen::VectorXcd p = cr.projected.col(mode);
  // p^H F_n, F_n(a) = F_c - i F_s
  const std::complex<double> projected_force = p.dot(contact_force_amplitudes(y, k));
  const ReducedStructure::Basis& b = structure_->basis(harmonic_index_[k]);
  const double big_w = hn * y(n);
  const double wr = b.frequencies(mode);
  const double damping = b.damping(mode, mode) - xi;
  const std::complex<double> imaginary_unit(0.0, 1.0);
  const std::complex<double> z = wr * wr - big_w * big_w + imaginary_unit * big_w * damping;
  const std::complex<double> q = -projected_force / z;
  if (gradient == nullptr) return q;
  const Workspace& ws = work_;
  if (ws.jacobian_at.size() != y.size() || (ws.jacobian_at.array() != y.array()).any())
    throw std::logic_error(
        "modal_coordinate: the last evaluation with the Jacobian was not at this point");
  gradient->setZero(n + 2);
  // dq/dU = -(1/z) p^H dF_n/dU, row by row of the contacts' force blocks.
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    const int first_component = contacts_[i].offset;
    const Eigen::Index first = static_cast<Eigen::Index>(first_component) * c;
    const Eigen::Index size = contacts_[i].tracer->unknown_count();
    const Eigen::MatrixXd& block = traces_[i].jacobian;
    for (Eigen::Index local = 0; local < size / c; ++local) {
      const auto a = static_cast<Eigen::Index>(first_component) + local;
      const std::complex<double> weight = -std::conj(p(a)) / z;
      const auto cos_row = block.row(local * c + ci);
      const auto sin_row = block.row(local * c + si);
      for (Eigen::Index col = 0; col < size; ++col)
        (*gradient)(first + col) += weight * std::complex<double>(cos_row(col), -sin_row(col));
    }
  }
  // dz/dw = n (-2 W + i (c - xi)), dz/dxi = -i W; dq/d. = -q / z dz/d.
  (*gradient)(n) = -q / z * (static_cast<double>(hn) * (-2.0 * big_w + imaginary_unit * damping));
  (*gradient)(n + 1) = -q / z * (-imaginary_unit * big_w);
  return q;
}

void HarmonicBalanceModel::modal_impedances(const ReducedStructure::Basis& b, int hn, double w,
                                            double xi, bool xi_derivative, Workspace& ws) {
  // z_r = w_r^2 - W^2 + i W (c_r - xi) at W = hn w; d(1/z_r)/dw = -hn z_r' / z_r^2.
  const std::complex<double> imaginary_unit(0.0, 1.0);
  const double big_w = hn * w;
  const Eigen::Index m = b.frequencies.size();
  ws.inv_z.resize(m);
  ws.dinv_z.resize(m);
  if (xi_derivative) ws.xi_inv_z.resize(m);
  for (Eigen::Index q = 0; q < m; ++q) {
    const double wr = b.frequencies(q);
    const double damping = b.damping(q, q) - xi;
    const std::complex<double> z = wr * wr - big_w * big_w + imaginary_unit * big_w * damping;
    ws.inv_z(q) = 1.0 / z;
    ws.dinv_z(q) = -static_cast<double>(hn) * (-2.0 * big_w + imaginary_unit * damping) / (z * z);
    // d(1/z)/dxi = -(dz/dxi) / z^2 = i W / z^2
    if (xi_derivative) ws.xi_inv_z(q) = imaginary_unit * big_w / (z * z);
  }
}

bool HarmonicBalanceModel::evaluate_into(const Eigen::VectorXd& y, Eigen::VectorXd& residual,
                                         Eigen::MatrixXd* jacobian,
                                         std::shared_ptr<const JacobianOperator>* op,
                                         std::string* message, Autonomy* autonomy) const {
  using Clock = std::chrono::steady_clock;
  const auto elapsed = [](Clock::time_point since) {
    return std::chrono::duration<double>(Clock::now() - since).count();
  };
  const int c = layout_.coefficient_count();
  const Eigen::Index n = unknown_count_;
  const double w = y(n);
  const bool derivatives = jacobian != nullptr || op != nullptr;
  ++stats_.residual_evaluations;
  if (derivatives) ++stats_.jacobian_evaluations;
  Workspace& ws = work_;
  auto t_part = Clock::now();
  bool ok = true;
  ws.forces_at.resize(0);
  gather_forces(y, ws.forces, derivatives, message, ok);
  stats_.contact_seconds += elapsed(t_part);
  if (!ok) return false;
  ws.forces_at = y;
  const Eigen::VectorXd& forces = ws.forces;

  // Per kept harmonic n, with complex amplitudes X = c - i s (layout of HarmonicLayout):
  //   e_n = U_n - U0_n + Rc_n F_n = U_n + m_n,  m_n = Rc_n F_n - U0_n = G R (G^H F_n - f_n),
  // so that the residual needs matrix-vector products only. The Jacobian needs Rc_n itself
  // (components x components), kept per harmonic for the assembly below.
  t_part = Clock::now();
  residual = y.head(n);
  if (jacobian) {
    jacobian->resize(n, n + 1);  // the first n columns are all written by the assembly
    jacobian->col(n).setZero();
    ws.contact_receptance.resize(static_cast<Eigen::Index>(components_),
                                 static_cast<Eigen::Index>(components_) *
                                     static_cast<Eigen::Index>(layout_.harmonics().size()));
  }
  const auto& h = layout_.harmonics();
  std::vector<HarmonicReceptance> receptances(op != nullptr ? h.size() : 0);
  Eigen::VectorXd parameter_column;
  if (op != nullptr) parameter_column.setZero(n);
  const double xi = autonomy != nullptr ? autonomy->xi : 0.0;
  if (autonomy != nullptr && derivatives) autonomy->xi_column.setZero(n);
  for (std::size_t k = 0; k < h.size(); ++k) {
    const int hn = h[k];
    const int ci = layout_.cos_index(k), si = layout_.sin_index(k);
    const ContactReceptance& cr = contact_receptance_[k];
    // The autonomous form drops the dynamic excitation (harmonic 0's static load stays).
    const bool excited = autonomy == nullptr || hn == 0;
    ws.force.resize(components_);
    for (int a = 0; a < components_; ++a)
      ws.force(a) = std::complex<double>(forces(a * c + ci), hn > 0 ? -forces(a * c + si) : 0.0);
    auto rc = ws.contact_receptance.middleCols(static_cast<Eigen::Index>(k) * components_,
                                               jacobian ? components_ : 0);
    if (cr.modal) {
      modal_impedances(structure_->basis(harmonic_index_[k]), hn, w, xi,
                       autonomy != nullptr && derivatives, ws);
      // Phi^H (G^H F - f) = P^H F - q
      ws.modal.noalias() = cr.projected.adjoint() * ws.force;
      if (excited) ws.modal -= cr.modal_force;
      ws.motion.noalias() = cr.projected * ws.inv_z.cwiseProduct(ws.modal);
      if (cr.flexibility.size()) {
        // G F G^H is Hermitian: its lower triangle is read once (half the bytes).
        ws.motion.noalias() += cr.flexibility.selfadjointView<Eigen::Lower>() * ws.force;
        if (excited) ws.motion -= cr.flexible_motion;
      }
      if (derivatives)
        ws.motion_derivative.noalias() = cr.projected * ws.dinv_z.cwiseProduct(ws.modal);
      if (autonomy != nullptr && derivatives) {
        ws.xi_motion.noalias() = cr.projected * ws.xi_inv_z.cwiseProduct(ws.modal);
        for (int a = 0; a < components_; ++a) {
          autonomy->xi_column(a * c + ci) += ws.xi_motion(a).real();
          if (hn > 0) autonomy->xi_column(a * c + si) -= ws.xi_motion(a).imag();
        }
      }
      if (jacobian) {
        form_modal_receptance(cr, ws, rc);
        if (cr.flexibility.size()) rc += cr.flexibility;
      }
      if (op != nullptr) {
        receptances[k].projected = &cr.projected;
        receptances[k].flexibility = cr.flexibility.size() ? &cr.flexibility : nullptr;
        receptances[k].inv_z = ws.inv_z;
      }
    } else {
      if (autonomy != nullptr && hn > 0) {
        if (message)
          *message = "harmonic " + std::to_string(hn) +
                     ": the autonomous form needs diagonal modal damping (this structure's "
                     "receptance is formed from a non-diagonal one)";
        stats_.receptance_seconds += elapsed(t_part);
        return false;
      }
      structure_->receptance(harmonic_index_[k], hn * w, ws.receptance,
                             derivatives ? &ws.receptance_derivative : nullptr);
      const SparseGather& g = gather_[k];
      ws.modal.noalias() = g.adjoint() * ws.force;  // G^H F - f over the kept DOFs
      ws.modal -= excitation_[k];
      ws.motion.noalias() = g * (ws.receptance * ws.modal);
      if (derivatives) {
        ws.motion_derivative.noalias() =
            static_cast<double>(hn) * (g * (ws.receptance_derivative * ws.modal));
        ws.scaled.noalias() = g * ws.receptance;  // G R
      }
      // G R G^H = (conj(G) (G R)^T)^T: sparse times dense products only.
      if (jacobian) rc = (g.conjugate() * ws.scaled.transpose()).transpose();
      if (op != nullptr)
        receptances[k].formed = (g.conjugate() * ws.scaled.transpose()).transpose();
    }
    if (op != nullptr) {
      receptances[k].harmonic = hn;
      receptances[k].cos_index = ci;
      receptances[k].sin_index = si;
    }
    const bool receptance_finite =
        (!jacobian || rc.allFinite()) &&
        (op == nullptr || (receptances[k].formed.allFinite() && receptances[k].inv_z.allFinite()));
    if (!ws.motion.allFinite() || !receptance_finite) {
      if (message)
        *message = "receptance at harmonic " + std::to_string(hn) + " is singular (" +
                   (hn == 0 ? "a rigid-body mode: drop harmonic 0 or ground the structure"
                            : "undamped resonance") +
                   ")";
      stats_.receptance_seconds += elapsed(t_part);
      return false;
    }
    for (int a = 0; a < components_; ++a) {
      residual(a * c + ci) += ws.motion(a).real();
      if (hn > 0) residual(a * c + si) -= ws.motion(a).imag();
    }
    if (!derivatives) continue;
    Eigen::Ref<Eigen::VectorXd> column = jacobian != nullptr
                                             ? Eigen::Ref<Eigen::VectorXd>(jacobian->col(n))
                                             : Eigen::Ref<Eigen::VectorXd>(parameter_column);
    for (int a = 0; a < components_; ++a) {
      column(a * c + ci) += ws.motion_derivative(a).real();
      if (hn > 0) column(a * c + si) -= ws.motion_derivative(a).imag();
    }
  }
  stats_.receptance_seconds += elapsed(t_part);
  if (!residual.allFinite()) {
    if (message) *message = "the residual is not finite at w = " + std::to_string(w) + " rad/s";
    return false;
  }
  return finish_jacobian(w, jacobian, op, std::move(receptances), std::move(parameter_column),
                         message);
}

bool HarmonicBalanceModel::finish_jacobian(double w, Eigen::MatrixXd* jacobian,
                                           std::shared_ptr<const JacobianOperator>* op,
                                           std::vector<HarmonicReceptance>&& receptances,
                                           Eigen::VectorXd&& parameter_column,
                                           std::string* message) const {
  const auto started = std::chrono::steady_clock::now();
  const auto elapsed = [&started] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  };
  const int c = layout_.coefficient_count();
  const Eigen::Index n = unknown_count_;
  if (op != nullptr) {
    std::vector<ContactTangent> tangents(contacts_.size());
    for (std::size_t i = 0; i < contacts_.size(); ++i) {
      tangents[i].first = static_cast<Eigen::Index>(contacts_[i].offset) * c;
      tangents[i].block = traces_[i].jacobian;
      if (!tangents[i].block.allFinite()) {
        if (message) *message = "the Jacobian is not finite at w = " + std::to_string(w) + " rad/s";
        return false;
      }
    }
    *op = std::make_shared<HarmonicJacobian>(c, components_, std::move(receptances),
                                             std::move(tangents), std::move(parameter_column),
                                             contact_threads_);
    stats_.assembly_seconds += elapsed();
    return true;
  }
  if (!jacobian) return true;

  assemble_jacobian(*jacobian);
  jacobian->leftCols(n).diagonal().array() += 1.0;
  stats_.assembly_seconds += elapsed();
  if (!jacobian->allFinite()) {
    if (message) *message = "the Jacobian is not finite at w = " + std::to_string(w) + " rad/s";
    return false;
  }
  return true;
}

Eigen::VectorXd HarmonicBalanceModel::point_record(const Eigen::VectorXd& y) const {
  const Workspace& ws = work_;
  if (ws.forces_at.size() != y.size() || (ws.forces_at.array() != y.array()).any()) return {};
  return ws.forces;
}

std::vector<Eigen::VectorXcd> HarmonicBalanceModel::kept_response(
    const Eigen::VectorXd& y, const Eigen::VectorXd& kept_forces) const {
  const int c = layout_.coefficient_count();
  const double w = y(unknown_count_);
  Eigen::VectorXd traced;
  if (kept_forces.size() != unknown_count_) {
    bool ok = true;
    std::string message;
    gather_forces(y, traced, false, &message, ok);
    if (!ok) throw std::runtime_error("response recovery: " + message);
  }
  const Eigen::VectorXd& forces = kept_forces.size() == unknown_count_ ? kept_forces : traced;
  const auto& h = layout_.harmonics();
  std::vector<Eigen::VectorXcd> out;
  for (std::size_t k = 0; k < h.size(); ++k) {
    Eigen::VectorXcd f_local(components_);
    for (int a = 0; a < components_; ++a) {
      const double fc = forces(a * c + layout_.cos_index(k));
      const double fs = h[k] > 0 ? forces(a * c + layout_.sin_index(k)) : 0.0;
      f_local(a) = std::complex<double>(fc, -fs);
    }
    out.push_back(structure_->respond(harmonic_index_[k], h[k] * w,
                                      excitation_[k] - gather_[k].adjoint() * f_local));
  }
  return out;
}

std::vector<Eigen::MatrixXcd> HarmonicBalanceModel::kept_response_jacobian(
    const Eigen::VectorXd& y, const std::vector<Eigen::Index>& dofs) const {
  const Workspace& ws = work_;
  if (ws.jacobian_at.size() != y.size() || (ws.jacobian_at.array() != y.array()).any() ||
      ws.forces_at.size() != y.size() || (ws.forces_at.array() != y.array()).any())
    throw std::logic_error(
        "kept_response_jacobian: the last evaluation with the Jacobian was not at this point");
  const int c = layout_.coefficient_count();
  const Eigen::Index n = unknown_count_;
  const double w = y(n);
  const auto& h = layout_.harmonics();
  const auto rows = static_cast<Eigen::Index>(dofs.size());
  const std::complex<double> imaginary_unit(0.0, 1.0);
  std::vector<Eigen::MatrixXcd> out;
  Eigen::MatrixXcd by_forces(rows, n);  // dX/dF
  Eigen::VectorXcd unit = Eigen::VectorXcd::Zero(components_);
  Eigen::VectorXcd f_local(components_);
  Eigen::VectorXcd derivative;
  for (std::size_t k = 0; k < h.size(); ++k) {
    const int hn = h[k];
    const int ci = layout_.cos_index(k), si = layout_.sin_index(k);
    const double big_w = hn * w;
    const SparseGather& g = gather_[k];
    // X_k = R (f - G^H F_k) with F_k(a) = F_c - i F_s: dX/dF_c = -R G^H e_a, dX/dF_s = i R G^H e_a.
    by_forces.setZero();
    for (int a = 0; a < components_; ++a) {
      unit(a) = 1.0;
      const Eigen::VectorXcd x = structure_->respond(harmonic_index_[k], big_w, g.adjoint() * unit);
      unit(a) = 0.0;
      for (Eigen::Index r = 0; r < rows; ++r) {
        by_forces(r, a * c + ci) = -x(dofs[static_cast<std::size_t>(r)]);
        if (hn > 0)
          by_forces(r, a * c + si) = imaginary_unit * x(dofs[static_cast<std::size_t>(r)]);
      }
      f_local(a) =
          std::complex<double>(ws.forces(a * c + ci), hn > 0 ? -ws.forces(a * c + si) : 0.0);
    }
    Eigen::MatrixXcd d = Eigen::MatrixXcd::Zero(rows, n + 1);
    for (std::size_t i = 0; i < contacts_.size(); ++i) {
      const Eigen::Index first = static_cast<Eigen::Index>(contacts_[i].offset) * c;
      const Eigen::Index size = contacts_[i].tracer->unknown_count();
      d.middleCols(first, size).noalias() =
          by_forces.middleCols(first, size) * traces_[i].jacobian.cast<std::complex<double>>();
    }
    structure_->respond(harmonic_index_[k], big_w, excitation_[k] - g.adjoint() * f_local,
                        &derivative);
    for (Eigen::Index r = 0; r < rows; ++r)
      d(r, n) = static_cast<double>(hn) * derivative(dofs[static_cast<std::size_t>(r)]);
    out.push_back(std::move(d));
  }
  return out;
}

bool HarmonicBalanceModel::trace_contact(std::size_t i, const Eigen::VectorXd& y, ContactTrace& out,
                                         std::string* error) const {
  const int c = layout_.coefficient_count();
  const auto& contact = contacts_[i];
  return contact.tracer->trace(
      y.segment(static_cast<Eigen::Index>(contact.offset) * c, contact.tracer->unknown_count()),
      JacobianMode::kNone, out, error);
}

}  // namespace frichb::core
