#include "frichb/core/model/peak_tracking.hpp"

#include <cmath>
#include <exception>
#include <stdexcept>
#include <utility>

namespace frichb::core {

struct PeakCondition::Local {
  Eigen::VectorXd residual;                       // R (n)
  Eigen::MatrixXd jacobian;                       // R_z (n x (n + 1))
  Eigen::PartialPivLU<Eigen::MatrixXd> bordered;  // [R_z; c^T], unscaled
  Eigen::VectorXd tangent;                        // unscaled t with c^T t = 1
};

PeakCondition::PeakCondition(const ParameterModels& models, std::vector<Eigen::Index> kept,
                             const std::vector<int>& harmonics, int samples,
                             Eigen::VectorXd z_scale, bool logarithmic, double lambda_scale)
    : models_(models),
      kept_(std::move(kept)),
      n_(z_scale.size() - 1),
      z_scale_(std::move(z_scale)),
      logarithmic_(logarithmic),
      lambda_scale_(lambda_scale),
      sampler_(std::make_unique<AmplitudeSampler>(harmonics, samples)) {
  if (n_ < 0 || !(lambda_scale_ > 0))
    throw std::invalid_argument("PeakCondition: needs the scales of (x, w) and of lambda");
}

PeakCondition::~PeakCondition() = default;

double PeakCondition::parameter(double lambda) const {
  return logarithmic_ ? std::exp(lambda) : lambda;
}

double PeakCondition::lambda(double p) const {
  return logarithmic_ ? std::log(p) : p;
}

void PeakCondition::set_reference(const Eigen::VectorXd& scaled_direction) const {
  if (scaled_direction.size() != n_ + 1 || !(scaled_direction.norm() > 0))
    throw std::invalid_argument("PeakCondition: a reference direction of n + 1 entries");
  reference_ = scaled_direction.normalized();
}

double PeakCondition::measure(const HarmonicBalanceModel& model, const Eigen::VectorXd& z) const {
  return sampler_->peak_amplitude(model.kept_response(z), kept_);
}

double PeakCondition::slope(const HarmonicBalanceModel& model, const Eigen::VectorXd& z,
                            const Eigen::VectorXd& t) const {
  return gradient(model, z).dot(t);
}

Eigen::VectorXd PeakCondition::gradient(const HarmonicBalanceModel& model,
                                        const Eigen::VectorXd& z) const {
  sampler_->peak_amplitude(model.kept_response(z, model.point_record(z)), kept_);
  const std::vector<Eigen::VectorXcd> q = sampler_->peak_gradient();
  const std::vector<Eigen::MatrixXcd> d = model.kept_response_jacobian(z, kept_);
  Eigen::VectorXd a = Eigen::VectorXd::Zero(n_ + 1);
  for (std::size_t k = 0; k < d.size(); ++k) a += (q[k].adjoint() * d[k]).real().transpose();
  return a.allFinite() ? a : difference_gradient(model, z);
}

Eigen::VectorXd PeakCondition::difference_gradient(const HarmonicBalanceModel& model,
                                                   const Eigen::VectorXd& z) const {
  Eigen::VectorXd a(n_ + 1);
  Eigen::VectorXd probe = z;
  for (Eigen::Index j = 0; j <= n_; ++j) {
    const double h = kMeasureStep * z_scale_(j);
    probe(j) = z(j) + h;
    const double up = measure(model, probe);
    probe(j) = z(j) - h;
    const double down = measure(model, probe);
    probe(j) = z(j);
    a(j) = (up - down) / (2 * h);
  }
  return a;
}

bool PeakCondition::local(const HarmonicBalanceModel& model, const Eigen::VectorXd& z, Local& out,
                          std::string* message) const {
  out.residual.resize(n_);
  out.jacobian.resize(n_, n_ + 1);
  if (!model.evaluate(z, out.residual, &out.jacobian, message)) return false;
  // The reference in unscaled variables: c_u = S^-1 c_s, so that c_u . t = c_s . (S^-1 t).
  Eigen::VectorXd c = Eigen::VectorXd::Zero(n_ + 1);
  if (reference_.size() == n_ + 1)
    c = reference_.cwiseQuotient(z_scale_);
  else
    c(n_) = 1.0 / z_scale_(n_);
  Eigen::MatrixXd b(n_ + 1, n_ + 1);
  b.topRows(n_) = out.jacobian;
  b.row(n_) = c.transpose();
  out.bordered.compute(b);
  Eigen::VectorXd e = Eigen::VectorXd::Zero(n_ + 1);
  e(n_) = 1.0;
  out.tangent = out.bordered.solve(e);
  if (!out.tangent.allFinite() || (b * out.tangent - e).norm() > 1e-6) {
    if (message != nullptr)
      *message =
          "the response curve's tangent is not defined there (the bordered system is singular)";
    return false;
  }
  return true;
}

bool PeakCondition::response_tangent(const Eigen::VectorXd& y, Eigen::VectorXd& tangent,
                                     std::string* message) const {
  try {
    const HarmonicBalanceModel& model = models_.at(parameter(y(n_ + 1)));
    Local here;
    if (!local(model, y.head(n_ + 1), here, message)) return false;
    tangent = here.tangent.cwiseQuotient(z_scale_);
    return true;
  } catch (const std::exception& e) {
    if (message != nullptr) *message = e.what();
    return false;
  }
}

Eigen::VectorXd PeakCondition::point_record(const Eigen::VectorXd& y) const {
  Eigen::VectorXd t;
  if (response_tangent(y, t, nullptr) && t.allFinite() && t.norm() > 0) reference_ = t.normalized();
  return {};
}

bool PeakCondition::shape(const Eigen::VectorXd& y, PointShape& out, std::string* message) const {
  const Eigen::Index m = n_ + 1;
  Eigen::VectorXd t, residual;
  Eigen::MatrixXd jacobian;
  if (!response_tangent(y, t, message) || !evaluate(y, residual, &jacobian, message)) return false;
  // t (scaled) back to the unscaled tangent with c . t = 1 that g is defined with.
  out.curvature = jacobian.row(n_).head(m).dot(t.cwiseProduct(z_scale_));
  // In scaled unknowns, so that the condition estimate means something.
  const Eigen::MatrixXd jz = jacobian.leftCols(m) * z_scale_.asDiagonal();
  const Eigen::FullPivLU<Eigen::MatrixXd> lu(jz);
  out.dy_dlambda.resize(0);
  if (lu.rank() == m && lu.rcond() >= 1e-13) {
    out.dy_dlambda.resize(m + 1);
    out.dy_dlambda.head(m) = z_scale_.cwiseProduct(lu.solve(-jacobian.col(m)));
    out.dy_dlambda(m) = 1.0;
    if (!out.dy_dlambda.allFinite()) out.dy_dlambda.resize(0);
  }
  return std::isfinite(out.curvature);
}

double PeakCondition::amplitude(const Eigen::VectorXd& y) const {
  return measure(models_.at(parameter(y(n_ + 1))), y.head(n_ + 1));
}

bool PeakCondition::amplitude_gradient(const Eigen::VectorXd& y, Eigen::VectorXd& out,
                                       std::string* message) const {
  try {
    const HarmonicBalanceModel& model = models_.at(parameter(y(n_ + 1)));
    Local here;
    if (!local(model, y.head(n_ + 1), here, message)) return false;
    out = gradient(model, y.head(n_ + 1));
    return true;
  } catch (const std::exception& e) {
    if (message != nullptr) *message = e.what();
    return false;
  }
}

double PeakCondition::directional_amplitude(const Eigen::VectorXd& y,
                                            const Eigen::VectorXd& dy) const {
  Eigen::VectorXd scale(n_ + 2);
  scale << z_scale_, lambda_scale_;
  const double h = kMeasureStep / dy.cwiseQuotient(scale).norm();
  // One-sided where the scene refuses the parameter on one side (p at a bound of its range).
  double ends[2] = {0.0, 0.0};
  bool made[2] = {false, false};
  for (int side = 0; side < 2; ++side) {
    try {
      ends[side] = amplitude(y + (side == 0 ? h : -h) * dy);
      made[side] = true;
    } catch (const std::exception&) {
      if (side == 1 && !made[0]) throw;
    }
  }
  if (made[0] && made[1]) return (ends[0] - ends[1]) / (2 * h);
  return made[0] ? (ends[0] - amplitude(y)) / h : (amplitude(y) - ends[1]) / h;
}

bool PeakCondition::evaluate(const Eigen::VectorXd& y, Eigen::VectorXd& residual,
                             Eigen::MatrixXd* jacobian, std::string* message) const {
  const Eigen::Index m = n_ + 1;  // equations
  const double lambda = y(m);
  const Eigen::VectorXd z = y.head(m);
  try {
    residual.resize(m);
    Local here;
    {
      const HarmonicBalanceModel& model = models_.at(parameter(lambda));
      if (!local(model, z, here, message)) return false;
      residual.head(n_) = here.residual;
      if (jacobian == nullptr) {
        residual(n_) = slope(model, z, here.tangent);
        return residual.allFinite();
      }
      jacobian->setZero(m, m + 1);
      jacobian->topLeftCorner(n_, m) = here.jacobian;
      const Eigen::VectorXd a = gradient(model, z);
      residual(n_) = a.dot(here.tangent);
      // R_z's derivative along t: its columns are d2R/dz_j dt (the second derivatives are
      // symmetric), and t^T d2A/dz2, grad A's derivative along t: central differences of the
      // quasi-analytical Jacobian and of the analytic gradient along t.
      const Eigen::VectorXd& t = here.tangent;
      const double s = kCurvatureStep / t.cwiseQuotient(z_scale_).norm();
      Eigen::VectorXd r(n_);
      Eigen::MatrixXd up(n_, m), down(n_, m);
      if (!model.evaluate(z + s * t, r, &up, message)) return false;
      const Eigen::VectorXd gradient_up = gradient(model, z + s * t);
      if (!model.evaluate(z - s * t, r, &down, message)) return false;
      const Eigen::VectorXd gradient_down = gradient(model, z - s * t);
      const Eigen::MatrixXd along = (up - down) / (2 * s);
      const Eigen::VectorXd hessian_t = (gradient_up - gradient_down) / (2 * s);
      // dt/dz = -B^-1 [along; 0], so grad A . dt/dz = -l^T along with B^T l = grad A.
      const Eigen::VectorXd l = here.bordered.transpose().solve(a);
      jacobian->row(n_).head(m) = hessian_t.transpose() - l.head(n_).transpose() * along;
    }
    // The parameter's column: the models at lambda +- h, central; one-sided where the scene
    // refuses one of the values (a range that starts at a bound of the parameter, such as a
    // normal load of 0).
    const double h = kParameterStep * lambda_scale_;
    Eigen::VectorXd ends[2];
    std::string refused;
    for (int side = 0; side < 2; ++side) {
      const HarmonicBalanceModel* model = nullptr;
      try {
        model = &models_.at(parameter(lambda + (side == 0 ? h : -h)));
      } catch (const std::exception& e) {
        refused = e.what();
        continue;
      }
      Local there;
      if (!local(*model, z, there, message)) return false;
      ends[side].resize(m);
      ends[side].head(n_) = there.residual;
      ends[side](n_) = slope(*model, z, there.tangent);
    }
    if (ends[0].size() != 0 && ends[1].size() != 0) {
      jacobian->col(m) = (ends[0] - ends[1]) / (2 * h);
    } else if (ends[0].size() != 0) {
      jacobian->col(m) = (ends[0] - residual) / h;
    } else if (ends[1].size() != 0) {
      jacobian->col(m) = (residual - ends[1]) / h;
    } else {
      if (message != nullptr) *message = refused;
      return false;
    }
    if (!residual.allFinite() || !jacobian->allFinite()) {
      if (message != nullptr) *message = "the peak condition is not finite there";
      return false;
    }
    return true;
  } catch (const std::exception& e) {
    if (message != nullptr) *message = e.what();
    return false;
  }
}

}  // namespace frichb::core
