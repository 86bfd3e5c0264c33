// FricHB plugin SDK: an elastic Coulomb slider on a friction circle, advanced along the
// motion of one step (the cubic through the step's end positions and rates), with its
// stick, slip, separation and re-contact events located inside the step.
//
// The contact: tangential force T = kt (u_t - w) in the plane (t1, t2), slider (stick point)
// w, friction circle |T| <= mu N, normal force N >= 0, where N and kt depend on the normal
// displacement u_n only (a NormalSide, below). Phases and their motion:
//   open    N = 0:   T = 0, w = u_t (the slider is released; contact resumes unloaded);
//   stick   |T| < mu N, or |T| = mu N with lambda <= 0:  w constant;
//   slip    |T| = mu N, T = mu N (cos a, sin a), w = u_t - T / kt, with the direction a
//           solving  a' = kt (u_t' . e_a) / (mu N),  e_a = (-sin a, cos a),  and the slip
//           rate lambda = e . u_t' + mu N kt' / kt^2 - (mu N)' / kt >= 0  (e = T / |T|).
// (' is d/ds along the step.) Slip ends where lambda falls to 0 (slip to stick), stick ends
// where |T| reaches mu N (stick to slip), contact ends and resumes where N crosses 0.
//
// The step's motion: s in [0, 1] from the previous sample to this one, and
//   u(s) = h00 u0 + h10 v0 + h01 u1 + h11 v1   (cubic Hermite; v = du/ds at each end),
// which a host interpolating a harmonic series gives to fourth order in the sample spacing
// (with v0 = v1 = u1 - u0 it is the chord). Events are located on this cubic by a scan of
// kEventScan points and a bracketed root (stick to slip, open and closed), or inside the slip
// integration (slip to stick); the direction a is integrated by classical Runge-Kutta with
// enough sub-steps that kt |u_t'| / (mu N) times a sub-step stays below kMaxRateStep, and by
// backward Euler in the sub-steps where that product exceeds 1 (next to N = 0, at an opening
// or a re-contact, where the direction relaxes onto its quasi-steady value at an unbounded
// rate). Contact resumes unloaded (T = 0, w = u_t): stuck when the stuck force just after
// the contact stays within mu N (kt |u_t'| <= mu N' where kt > 0 at contact), else slipping
// in the direction of u_t'. The step solves the law on the cubic to about 1e-8 of
// mu N (measured: 4.4e-8 at a = 100 mu N / kt on a circle, below 1e-9 near the stick limit),
// so the error of a trace is that of the interpolated motion, fourth order in the spacing,
// plus the host's quadrature at the kinks.
//
// Scalar may be double (value only) or Dual<M> (value and tangents): event locations are
// finished by one Newton step in Scalar, so their derivatives are the implicit-function ones
// and the tangents are the exact derivatives of the computed step.
//
// Kinks: where the force's rate jumps inside the step (stick to slip; open to closed and
// back) the step reports the location and the jump, for hosts that correct their quadrature.
//
// Threading: stateless; one call allocates nothing. Failure: none (a degenerate input, such as
// mu N = 0 or a zero-length step, takes the limit of the law).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <type_traits>

#include "frichb/plugin/abi.h"
#include "frichb/plugin/dual.hpp"
#include "frichb/plugin/tangents.hpp"

namespace frichb::sdk {

// The motion of one step: positions and rates (d/ds) at both ends, local frame (t1, t2, n), m;
// s in [0, 1] is the step's fraction. Plain data: HermiteCubic evaluates it.
template <class S>
struct StepMotion {
  std::array<S, 3> u0, u1, v0, v1;
};

// A step's motion as the polynomial u(s) = a + b s + c s^2 + d s^3 (the cubic Hermite of a
// StepMotion), evaluated by Horner's rule: what the slider evaluates many times per step.
template <class S>
class HermiteCubic {
 public:
  HermiteCubic() = default;
  explicit HermiteCubic(const StepMotion<S>& m) {
    for (std::size_t i = 0; i < 3; ++i) {
      a_[i] = m.u0[i];
      b_[i] = m.v0[i];
      c_[i] = 3.0 * (m.u1[i] - m.u0[i]) - 2.0 * m.v0[i] - m.v1[i];
      d_[i] = 2.0 * (m.u0[i] - m.u1[i]) + m.v0[i] + m.v1[i];
    }
  }
  std::array<S, 3> position(const S& s) const {
    std::array<S, 3> u;
    for (std::size_t i = 0; i < 3; ++i) u[i] = position_of(i, s);
    return u;
  }
  // position(y) - position(x), without the cancellation of subtracting two positions when y
  // is near x: (y - x) (b + c (x + y) + d (x^2 + x y + y^2)).
  std::array<S, 3> between(const S& x, const S& y) const {
    std::array<S, 3> u;
    const S sum = x + y, square = x * x + x * y + y * y;
    for (std::size_t i = 0; i < 3; ++i) u[i] = (y - x) * (b_[i] + c_[i] * sum + d_[i] * square);
    return u;
  }
  std::array<S, 3> rate(const S& s) const {
    std::array<S, 3> v;
    for (std::size_t i = 0; i < 3; ++i) v[i] = rate_of(i, s);
    return v;
  }
  // One component of position(s) and rate(s), by the same operations.
  S position_of(std::size_t i, const S& s) const {
    return a_[i] + s * (b_[i] + s * (c_[i] + s * d_[i]));
  }
  S rate_of(std::size_t i, const S& s) const { return b_[i] + s * (2.0 * c_[i] + 3.0 * s * d_[i]); }
  // The control points of component i on s in [0, 1] (the cubic's Bernstein form): the curve
  // lies in their convex hull, so they bound it over the whole step.
  std::array<S, 4> control_points(std::size_t i) const {
    return {a_[i], a_[i] + b_[i] / 3.0, a_[i] + (2.0 * b_[i] + c_[i]) / 3.0,
            a_[i] + b_[i] + c_[i] + d_[i]};
  }
  // The same cubic in doubles (the values of a dual-number one).
  HermiteCubic<double> values() const {
    HermiteCubic<double> out;
    for (std::size_t i = 0; i < 3; ++i)
      out.set(i, value_of(a_[i]), value_of(b_[i]), value_of(c_[i]), value_of(d_[i]));
    return out;
  }
  void set(std::size_t i, const S& a, const S& b, const S& c, const S& d) {
    a_[i] = a;
    b_[i] = b;
    c_[i] = c;
    d_[i] = d;
  }

 private:
  std::array<S, 3> a_{}, b_{}, c_{}, d_{};
};

// The normal side of a contact at one normal displacement: N (N), dN/du_n (N/m), kt (N/m),
// dkt/du_n (N/m^2).
template <class S>
struct NormalSide {
  S normal, dnormal, stiffness, dstiffness;
};

// One location inside a step where the force's rate jumps: s in [0, 1] and
// (dF/ds after) - (dF/ds before), (T1, T2, N), N. At a contact change of a Normal with an
// onset (below), also the onset: F ~ onset |s - s*|^onset_power on the closed side
// (onset_side +1: after s*, a closing; -1: before, an opening); onset_power 0: none.
template <class S>
struct ForceKink {
  S s{0.0};
  std::array<S, 3> rate_jump{S(0.0), S(0.0), S(0.0)};
  std::array<S, 3> onset{S(0.0), S(0.0), S(0.0)};
  double onset_power = 0.0;
  double onset_side = 0.0;
};

template <class S>
struct SliderStep {
  std::array<S, 3> force;   // (T1, T2, N) at s = 1, N
  std::array<S, 2> slider;  // w at s = 1, m
  static constexpr int kMaxKinks = 8;
  std::array<ForceKink<S>, kMaxKinks> kinks{};
  int kink_count = 0;  // kinks beyond kMaxKinks in one step are not reported
};

// `Normal` provides, for a Scalar normal displacement u_n:
//   Scalar closure(const Scalar& un) const;      > 0 exactly where N > 0 (m or N: any scale)
//   NormalSide<Scalar> side(const Scalar& un) const;   the closed contact's N, kt
// and `mu` is the friction coefficient (>= 0). Optionally, for a contact whose N and kt
// vanish at contact like powers of the penetration d (Hertz: N ~ c_n d^1.5, kt ~ c_t d^0.5):
//   static constexpr double kOnsetPower = p;                 N ~ d^p, kt ~ d^(p - 1)
//   Scalar normal_onset(const Scalar& un_rate) const;        N ~ normal_onset |s - s_c|^p
//   Scalar stiffness_onset(const Scalar& un_rate) const;     kt ~ stiffness_onset |s - s_c|^(p-1)
// for a contact change at s_c crossed at the normal rate un_rate (du_n/ds): the kinks of the
// contact changes then carry the force's onset (ForceKink). side() is called where
// closure > 0 and at the located contact changes, where rounding may leave closure a hair
// below 0: there it returns the closed side's limit at closure = 0 (N = 0; for a law whose kt
// also vanishes at contact, such as Hertz, zeros for all four, the open contact's, rather
// than an extension of its formulas past contact, which can have N > 0 with kt < 0).
// Optionally, for a Normal whose closure and stick radius mu N / kt never decrease as u_n
// grows (where closed):
//   static constexpr bool kMonotone = true;
// then a step whose whole cubic provably keeps the contact closed (open) and a stuck slider
// inside its circle (the cubic's control points bound it) skips the event scans: the same
// result, bit for bit, as the scans, which find no event there.
template <class Normal>
class FrictionCircleSlider {
 public:
  static constexpr int kEventScan = 16;        // scan points per step for the events
  static constexpr double kMaxRateStep = 0.2;  // bound on kt |u_t'| ds / (mu N) per sub-step
  static constexpr int kMaxSubsteps = 512;
  static constexpr int kMaxSegments = 64;

  FrictionCircleSlider(const Normal& normal, double mu) : normal_(normal), mu_(mu) {}

  template <class S>
  SliderStep<S> advance(const std::array<S, 2>& slider_prev, const StepMotion<S>& step) const {
    const HermiteCubic<S> motion(step);
    SliderStep<S> out;
    if (!(mu_ > 0)) return frictionless(motion);
    Phase<S> ph;
    ph.w = slider_prev;
    S s(0.0);
    const HermiteCubic<double> md = motion.values();
    start(ph, motion, s);
    // At most kMaxSegments phases per step (the laws' motions have a handful); a step with
    // more ends in the phase it has reached, evaluated at s = 1.
    for (int segment = 0; segment < kMaxSegments && s < 1.0; ++segment) {
      if (ph.mode == Mode::kOpen) {
        open_segment(ph, motion, md, s, out);
      } else if (ph.mode == Mode::kStick) {
        stick_segment(ph, motion, md, s, out);
      } else {
        slip_segment(ph, motion, md, s, out);
      }
    }
    finish(ph, motion, out);
    return out;
  }

 private:
  enum class Mode { kOpen, kStick, kSlip };
  template <class S>
  struct Phase {
    Mode mode = Mode::kStick;
    std::array<S, 2> w;
    S angle{0.0};  // the force's direction in slip
    // Stuck since contact resumed at contact_s (w = u_t there): the elastic offset u_t - w is
    // then taken as the motion since contact_s, which keeps its direction where both are tiny.
    bool from_contact = false;
    S contact_s{0.0};
  };

  // u_t(s) - w of a stuck slider.
  template <class S>
  static std::array<S, 2> offset(const Phase<S>& ph, const HermiteCubic<S>& m, const S& s) {
    if (ph.from_contact) {
      const auto d = m.between(ph.contact_s, s);
      return {d[0], d[1]};
    }
    const auto u = m.position(s);
    return {u[0] - ph.w[0], u[1] - ph.w[1]};
  }
  template <class S>
  static Phase<double> values(const Phase<S>& ph) {
    Phase<double> d;
    d.mode = ph.mode;
    d.w = {value_of(ph.w[0]), value_of(ph.w[1])};
    d.angle = value_of(ph.angle);
    d.from_contact = ph.from_contact;
    d.contact_s = value_of(ph.contact_s);
    return d;
  }

  // mu = 0: no tangential force, the slider follows u_t; the normal force opens and closes
  // with its kinks.
  template <class S>
  SliderStep<S> frictionless(const HermiteCubic<S>& m) const {
    SliderStep<S> out;
    const HermiteCubic<double> md = m.values();
    S s(0.0);
    bool closed = normal_.closure(m.position(s)[2]) > 0;
    for (int guard = 0; guard < 16; ++guard) {
      const S change = contact_change(m, md, s, closed);
      if (!(change <= 1.0)) break;
      s = change;
      const S rate = normal_.side(m.position(s)[2]).dnormal * m.rate(s)[2];
      add_onset(add_kink(out, s, {S(0.0), S(0.0), closed ? S(0.0) - rate : rate}), m, s, !closed,
                false, S(0.0));
      closed = !closed;
    }
    const auto u = m.position(S(1.0));
    out.slider = {u[0], u[1]};
    out.force = {S(0.0), S(0.0), closed ? normal_.side(u[2]).normal : S(0.0)};
    return out;
  }

  // |kt (u_t - w)|^2 - (mu N)^2 at s (> 0: outside the circle), for a closed contact.
  template <class S>
  // In the slider's own measure |u_t - w|^2 - (mu N / kt)^2, m^2, whose stick radius
  // mu N / kt is 0 where the contact is open (kt = 0): a stuck slider with an offset is then
  // outside it, so a Hertz contact approaching an opening stuck always meets the circle first.
  S stick_excess(const Phase<S>& ph, const HermiteCubic<S>& m, const S& s) const {
    const auto u = m.position(s);
    const auto n = normal_.side(u[2]);
    const auto d = offset(ph, m, s);
    const S radius = n.stiffness > 0 ? mu_ * n.normal / n.stiffness : S(0.0);
    return d[0] * d[0] + d[1] * d[1] - radius * radius;
  }

  // lambda at s for a slider in slip with direction `angle` (per unit s, m).
  template <class S>
  S slip_rate(const HermiteCubic<S>& m, const S& s, const S& angle) const {
    const auto u = m.position(s);
    const auto v = m.rate(s);
    const auto n = normal_.side(u[2]);
    const S c = cos(angle), sn = sin(angle);
    const S kt_rate = n.dstiffness * v[2], normal_rate = n.dnormal * v[2];
    return c * v[0] + sn * v[1] + mu_ * n.normal * kt_rate / (n.stiffness * n.stiffness) -
           mu_ * normal_rate / n.stiffness;
  }

  // What the direction's rate reads of the motion at one s: u_n and u_t' (in Scalar) and the
  // normal side there (in double, with its derivatives in u_n).
  template <class S>
  struct SlipMotion {
    S un, v0, v1;
    NormalSide<double> side;
  };
  template <class S>
  SlipMotion<S> slip_motion(const HermiteCubic<S>& m, const S& s) const {
    SlipMotion<S> at{m.position_of(2, s), m.rate_of(0, s), m.rate_of(1, s), {}};
    at.side = normal_.side(value_of(at.un));
    return at;
  }

  // d angle / ds = kt (u_t' . e_a) / (mu N) on the motion `at`. In dual numbers the value is
  // the double code's, by the same operations, and the derivatives come by the chain rule
  // through the four quantities it reads (u_n, u_t1', u_t2', the angle), with its partials
  // written out: what the slip's sub-steps spend most of a derivative pass on.
  template <class S>
  S turning_rate(const SlipMotion<S>& at, const S& angle) const {
    const auto& n = at.side;
    // At N = 0 (the opening point of a slip segment) the direction no longer matters: the
    // force vanishes there and the slider is released.
    if (!(n.normal > 0)) return S(0.0);
    const double a = value_of(angle), c = std::cos(a), sn = std::sin(a);
    const double v0 = value_of(at.v0), v1 = value_of(at.v1);
    const double turning = c * v1 - sn * v0, limit = mu_ * n.normal;
    const double rate = n.stiffness * turning / limit;
    if constexpr (std::is_same_v<S, double>) {
      return rate;
    } else {
      const double per_length = n.stiffness / limit;
      return S::from_partials(
          rate,
          std::array<double, 4>{(n.dstiffness * turning - rate * mu_ * n.dnormal) / limit,
                                -per_length * sn, per_length * c, -per_length * (sn * v1 + c * v0)},
          std::array<const S*, 4>{&at.un, &at.v0, &at.v1, &angle});
    }
  }
  template <class S>
  S angle_rate(const HermiteCubic<S>& m, const S& s, const S& angle) const {
    return turning_rate(slip_motion(m, s), angle);
  }

  // Decides the phase at s (the step's start): open, a slider outside the circle returned
  // onto it (a state a host gave or the start of a trace), then stick or slip by lambda.
  template <class S>
  void start(Phase<S>& ph, const HermiteCubic<S>& m, const S& s) const {
    const auto u = m.position(s);
    if (!(normal_.closure(u[2]) > 0) || !(mu_ > 0)) {
      ph.mode = Mode::kOpen;
      return;
    }
    enter_closed(ph, m, s);
  }

  template <class S>
  void enter_closed(Phase<S>& ph, const HermiteCubic<S>& m, const S& s) const {
    const auto u = m.position(s);
    const auto n = normal_.side(u[2]);
    const S d0 = u[0] - ph.w[0], d1 = u[1] - ph.w[1];
    const S limit = mu_ * n.normal;
    // A slider on the circle (a step that ended in slip) is recomputed here from u - w, which
    // loses the rounding of u where the circle's radius mu N / kt is tiny next to u (near an
    // opening): within that rounding the slider counts as on the circle, and lambda decides.
    const double rounding = 8.0 * std::numeric_limits<double>::epsilon() * value_of(n.stiffness) *
                            (std::abs(value_of(u[0])) + std::abs(value_of(u[1])) +
                             std::abs(value_of(ph.w[0])) + std::abs(value_of(ph.w[1])));
    const double inside = value_of(limit) * (1.0 - 1e-12) - rounding;
    // Clearly inside the circle (compared in squares with room for their rounding): stuck,
    // as the comparison below would find, without its hypot.
    const double kt = value_of(n.stiffness), e0 = value_of(d0), e1 = value_of(d1);
    if (inside > 0 && kt * kt * (e0 * e0 + e1 * e1) < inside * inside * (1.0 - 1e-9)) {
      ph.mode = Mode::kStick;
      return;
    }
    const S trial = n.stiffness * hypot(d0, d1);
    if (trial < limit * (1.0 - 1e-12) - rounding || !(trial > 0)) {
      ph.mode = Mode::kStick;
      return;
    }
    ph.angle = atan2(d1, d0);
    if (trial > limit) {
      ph.w[0] = u[0] - limit * cos(ph.angle) / n.stiffness;
      ph.w[1] = u[1] - limit * sin(ph.angle) / n.stiffness;
    }
    ph.mode = value_of(slip_rate(m, s, ph.angle)) > 0 ? Mode::kSlip : Mode::kStick;
  }

  // First s in (from, to] where f changes sign from its value's sign at `from` (scan and
  // bracketed Illinois in double), or `to` + 1 when it does not.
  template <class F>
  static double first_crossing(const F& f, double from, double to, double f_from, int scan) {
    double a = from, fa = f_from;
    for (int k = 1; k <= scan; ++k) {
      const double b = from + (to - from) * k / scan;
      const double fb = f(b);
      if ((fa <= 0) != (fb <= 0)) return refine(f, a, fa, b, fb);
      a = b;
      fa = fb;
    }
    return to + 1.0;
  }
  template <class F>
  static double refine(const F& f, double a, double fa, double b, double fb) {
    int side = 0;
    for (int it = 0; it < 100 && b - a > 1e-15; ++it) {
      const double c = (a * fb - b * fa) / (fb - fa);
      const double x = (c > a && c < b) ? c : 0.5 * (a + b);
      const double fx = f(x);
      if ((fx <= 0) == (fa <= 0)) {
        a = x;
        fa = fx;
        if (side == -1) fb *= 0.5;
        side = -1;
      } else {
        b = x;
        fb = fx;
        if (side == 1) fa *= 0.5;
        side = 1;
      }
      if (fx == 0) return x;
    }
    return b;
  }
  // One Newton step in S at a root s* of g found in double: the value stays s*, the
  // derivatives become the implicit-function ones. `g_value` evaluates g in double.
  template <class S, class G, class GD>
  static S polish(double root, const G& g_scalar, const GD& g_value) {
    const double h = 1e-6;
    const double slope = (g_value(root + h) - g_value(root - h)) / (2 * h);
    const S at = g_scalar(S(root));
    if (!(std::abs(slope) > 0)) return S(root);
    return S(root) - (at - value_of(at)) / slope;
  }

  static constexpr bool kBounded = requires { requires Normal::kMonotone; };

  // The lowest and highest control point of component i, widened by the rounding of the
  // cubic's evaluation (a few units in the last place of its largest term).
  static std::array<double, 2> hull(const HermiteCubic<double>& m, std::size_t i) {
    const auto p = m.control_points(i);
    const auto [lo, hi] = std::minmax({p[0], p[1], p[2], p[3]});
    const double slack = 16.0 * std::numeric_limits<double>::epsilon() *
                         std::max({std::abs(p[0]), std::abs(p[1]), std::abs(p[2]), std::abs(p[3])});
    return {lo - slack, hi + slack};
  }

  // Whether a Normal with kMonotone provably keeps its side over the whole step (closed:
  // closure > 0, open: closure <= 0): closure never decreases with u_n, so its values at
  // u_n's lowest and highest control points bound it.
  bool keeps_side(const HermiteCubic<double>& md, bool closed) const {
    if constexpr (kBounded) {
      const auto [lo, hi] = hull(md, 2);
      return closed ? normal_.closure(lo) > 0 : !(normal_.closure(hi) > 0);
    } else {
      return false;
    }
  }

  // Whether a stuck slider of a Normal with kMonotone provably stays strictly inside its
  // circle over the whole step: |u_t - w| (convex) is at most its largest value at the
  // tangential control points, and the radius mu N / kt at least its value at u_n's lowest.
  bool stays_stuck(const Phase<double>& ph, const HermiteCubic<double>& md) const {
    if constexpr (kBounded) {
      const auto t1 = md.control_points(0), t2 = md.control_points(1);
      double reach = 0, size = std::abs(ph.w[0]) + std::abs(ph.w[1]);
      for (std::size_t k = 0; k < 4; ++k) {
        const double d0 = t1[k] - ph.w[0], d1 = t2[k] - ph.w[1];
        reach = std::max(reach, d0 * d0 + d1 * d1);
        size = std::max(size, std::abs(t1[k]) + std::abs(t2[k]));
      }
      const double lo = hull(md, 2)[0];
      if (!(normal_.closure(lo) > 0)) return false;
      const auto n = normal_.side(lo);
      if (!(n.stiffness > 0)) return false;
      const double radius = mu_ * n.normal / n.stiffness;
      const double slack = 16.0 * std::numeric_limits<double>::epsilon() * size;
      return std::sqrt(reach) + slack < radius * (1.0 - 1e-9);
    } else {
      return false;
    }
  }

  // The first s after `s` where a closed (open) contact opens (closes), or 2. The start
  // counts as being on its side even where rounding puts it on the other.
  template <class S>
  S contact_change(const HermiteCubic<S>& m, const HermiteCubic<double>& md, const S& s,
                   bool closed) const {
    if (keeps_side(md, closed)) return S(2.0);
    auto g = [&](double x) { return value_of(normal_.closure(md.position(x)[2])); };
    const double from = value_of(s);
    const double at = g(from);
    const double start = closed ? std::max(at, std::numeric_limits<double>::min())
                                : std::min(at, -std::numeric_limits<double>::min());
    const double root = first_crossing(g, from, 1.0, start, kEventScan);
    if (root > 1.0) return S(2.0);
    return polish<S>(
        root, [&](const S& x) { return normal_.closure(m.position(x)[2]); }, g);
  }

  // Appends a kink; nullptr when the step's kinks are full.
  template <class S>
  static ForceKink<S>* add_kink(SliderStep<S>& out, const S& s, const std::array<S, 3>& jump) {
    if (out.kink_count >= SliderStep<S>::kMaxKinks) return nullptr;
    auto& kink = out.kinks[static_cast<std::size_t>(out.kink_count++)];
    kink = ForceKink<S>{};
    kink.s = s;
    kink.rate_jump = jump;
    return &kink;
  }
  // Whether a contact resuming at s_c slips from the start (see open_segment).
  bool slips_at_contact(const HermiteCubic<double>& md, double sc) const {
    if constexpr (requires { Normal::kOnsetPower; }) {
      const auto v = md.rate(sc);
      return normal_.stiffness_onset(v[2]) * std::hypot(v[0], v[1]) >
             mu_ * normal_.normal_onset(v[2]);
    } else {
      const double after = sc + 1e-6 * (1.0 - sc);
      const auto offset = md.between(sc, after);
      const auto n = normal_.side(md.position(after)[2]);
      return n.stiffness * std::hypot(offset[0], offset[1]) > mu_ * n.normal;
    }
  }

  // The force's onset at a contact change at s (closing: the contact closed after s; else
  // opening: closed before s), for a Normal that declares one: N ~ normal_onset |s - s_c|^p;
  // slipping, T = mu N (cos a, sin a); stuck from a closing, T = kt (u_t(s) - u_t(s_c)) ~
  // stiffness_onset u_t' |s - s_c|^p; stuck at an opening the offset vanishes with kt (the
  // stick radius mu N / kt ~ d shrinks to 0), so T has no term of order p; mu = 0: T = 0.
  template <class S>
  void add_onset(ForceKink<S>* kink, const HermiteCubic<S>& m, const S& s, bool closing,
                 bool slipping, const S& angle) const {
    if constexpr (requires { Normal::kOnsetPower; }) {
      if (kink == nullptr) return;
      const auto v = m.rate(s);
      const S normal = normal_.normal_onset(v[2]);
      kink->onset = {S(0.0), S(0.0), normal};
      if (slipping) {
        kink->onset[0] = mu_ * normal * cos(angle);
        kink->onset[1] = mu_ * normal * sin(angle);
      } else if (closing && mu_ > 0) {
        const S stiffness = normal_.stiffness_onset(v[2]);
        kink->onset[0] = stiffness * v[0];
        kink->onset[1] = stiffness * v[1];
      }
      kink->onset_power = Normal::kOnsetPower;
      kink->onset_side = closing ? 1.0 : -1.0;
    }
  }
  template <class S>
  static std::array<S, 3> difference(const std::array<S, 3>& a, const std::array<S, 3>& b) {
    return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
  }

  // dF/ds of a closed contact at s: stuck (w fixed) or slipping with direction `angle`.
  template <class S>
  std::array<S, 3> closed_rate(const HermiteCubic<S>& m, const S& s, bool slipping,
                               const std::array<S, 2>& w, const S& angle) const {
    const auto u = m.position(s);
    const auto v = m.rate(s);
    const auto n = normal_.side(u[2]);
    const S normal_rate = n.dnormal * v[2];
    if (!slipping) {
      const S kt_rate = n.dstiffness * v[2];
      return {kt_rate * (u[0] - w[0]) + n.stiffness * v[0],
              kt_rate * (u[1] - w[1]) + n.stiffness * v[1], normal_rate};
    }
    // dT/ds = mu N' e + mu N a' e_a, with mu N a' = kt (u_t' . e_a) taken without the
    // division by N (its derivatives stay finite as N -> 0). At N = 0 the direction has
    // relaxed onto u_t' (its rate is unbounded there), and the term is 0, its limit.
    const S c = cos(angle), sn = sin(angle);
    const S turning = n.normal > 0 ? n.stiffness * (c * v[1] - sn * v[0]) : S(0.0);
    return {mu_ * normal_rate * c - sn * turning, mu_ * normal_rate * sn + c * turning,
            normal_rate};
  }

  template <class S>
  void open_segment(Phase<S>& ph, const HermiteCubic<S>& m, const HermiteCubic<double>& md, S& s,
                    SliderStep<S>& out) const {
    const S closes = contact_change(m, md, s, false);
    if (!(closes <= 1.0)) {
      s = S(1.0);
      return;
    }
    s = closes;
    const auto u = m.position(s);
    ph.w = {u[0], u[1]};
    // Contact resumes unloaded: T = 0 and mu N = 0. It sticks when the stuck force grows
    // slower than the friction limit; else it slips from the start, in the direction of u_t'
    // (the one bounded solution of the direction's equation, whose rate kt / (mu N) is
    // infinite there). Both grow from 0 at the same order in s - s_c. A Normal with an onset
    // compares their leading terms, stiffness_onset |u_t'| against mu normal_onset (the
    // choice then agrees with the onset reported, continuously at equality); else they are
    // compared just after the contact, at s_c + 1e-6 (1 - s_c), on the stuck offset
    // u_t(s) - u_t(s_c) taken without cancellation (kt |u_t'| against mu N').
    const auto v = m.rate(s);
    if (slips_at_contact(md, value_of(s))) {
      ph.mode = Mode::kSlip;
      ph.from_contact = false;
      ph.angle = atan2(v[1], v[0]);
      add_onset(add_kink(out, s, closed_rate(m, s, true, ph.w, ph.angle)), m, s, true, true,
                ph.angle);
      return;
    }
    ph.mode = Mode::kStick;
    ph.from_contact = true;
    ph.contact_s = s;
    add_onset(add_kink(out, s, closed_rate(m, s, false, ph.w, S(0.0))), m, s, true, false, S(0.0));
  }

  template <class S>
  void stick_segment(Phase<S>& ph, const HermiteCubic<S>& m, const HermiteCubic<double>& md, S& s,
                     SliderStep<S>& out) const {
    const S opens = contact_change(m, md, s, true);
    const double end = std::min(1.0, value_of(opens));
    const Phase<double> pd = values(ph);
    auto g = [&](double x) { return stick_excess(pd, md, x); };
    const double from = value_of(s);
    // At the start the excess is <= 0 (stuck): a crossing is a rise above 0.
    const double root = stays_stuck(pd, md)
                            ? end + 1.0
                            : first_crossing(g, from, end, std::min(g(from), 0.0), kEventScan);
    if (root <= end) {
      s = polish<S>(
          root, [&](const S& x) { return stick_excess(ph, m, x); }, g);
      const auto d = offset(ph, m, s);
      const S angle = atan2(d[1], d[0]);
      const double sd = value_of(s);
      if (!(value_of(slip_rate(md, sd, value_of(angle))) > 0)) {
        // Grazing the circle with the motion turning inwards: no slip, no kink; go on stuck.
        s = S(std::min(1.0, sd + 1e-9));
        return;
      }
      ph.angle = angle;
      ph.from_contact = false;
      ph.mode = Mode::kSlip;
      add_kink(out, s,
               difference(closed_rate(m, s, true, ph.w, ph.angle),
                          closed_rate(m, s, false, ph.w, S(0.0))));
      return;
    }
    if (opens <= 1.0) {
      s = opens;
      add_onset(
          add_kink(out, s,
                   difference({S(0.0), S(0.0), S(0.0)}, closed_rate(m, s, false, ph.w, S(0.0)))),
          m, s, false, false, S(0.0));
      ph.mode = Mode::kOpen;
      return;
    }
    s = S(1.0);
  }

  // Classical Runge-Kutta step of the direction from (s, angle) over ds.
  template <class S>
  S rk4(const HermiteCubic<S>& m, const S& s, const S& angle, const S& ds) const {
    const SlipMotion<S> middle = slip_motion(m, S(s + 0.5 * ds));
    const S k1 = angle_rate(m, s, angle);
    const S k2 = turning_rate(middle, angle + 0.5 * ds * k1);
    const S k3 = turning_rate(middle, angle + 0.5 * ds * k2);
    const S k4 = angle_rate(m, S(s + ds), angle + ds * k3);
    return angle + ds / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
  }

  // Backward Euler step of the direction (L-stable), for sub-steps where the direction's
  // relaxation rate kt |u_t'| / (mu N) times the sub-step is large: next to an opening or a
  // re-contact, where mu N -> 0. There the direction is pulled onto its quasi-steady value at
  // that rate, and any error is forgotten as fast; the force is small. Newton in Scalar.
  template <class S>
  S backward_euler(const HermiteCubic<S>& m, const S& s, const S& angle, const S& ds) const {
    // The motion at the sub-step's end, once for every iteration; its values for the slope.
    const SlipMotion<S> end = slip_motion(m, S(s + ds));
    const SlipMotion<double> end_value{value_of(end.un), value_of(end.v0), value_of(end.v1),
                                       end.side};
    S next = angle;
    for (int it = 0; it < 8; ++it) {
      const S residual = next - angle - ds * turning_rate(end, next);
      const double h = 1e-7, x = value_of(next);
      const double slope =
          1.0 - value_of(ds) * (turning_rate(end_value, x + h) - turning_rate(end_value, x - h)) /
                    (2 * h);
      next = next - residual / (std::abs(slope) > 1e-12 ? slope : 1.0);
      if (std::abs(value_of(residual)) < 1e-15) break;
    }
    return next;
  }

  template <class S>
  S advance_angle(const HermiteCubic<S>& m, const S& s, const S& angle, const S& ds,
                  bool stiff) const {
    return stiff ? backward_euler(m, s, angle, ds) : rk4(m, s, angle, ds);
  }

  // The relaxation rate kt |u_t'| / (mu N) at s (infinite where N = 0).
  double relaxation_rate(const HermiteCubic<double>& m, double s) const {
    const auto u = m.position(s);
    const auto v = m.rate(s);
    const auto n = normal_.side(u[2]);
    if (!(n.normal > 0)) return std::numeric_limits<double>::infinity();
    // sqrt of the sum of squares, not hypot: a rate, in the range of motion rates (no
    // overflow), that sizes sub-steps.
    return n.stiffness * std::sqrt(v[0] * v[0] + v[1] * v[1]) / (mu_ * n.normal);
  }

  template <class S>
  void slip_segment(Phase<S>& ph, const HermiteCubic<S>& m, const HermiteCubic<double>& md, S& s,
                    SliderStep<S>& out) const {
    const S opens = contact_change(m, md, s, true);
    const S end = opens <= 1.0 ? opens : S(1.0);
    // Sub-steps from the largest rate kt |u_t'| / (mu N) on the scan points.
    // Sub-steps from the largest rate on the scan points (infinite where N = 0: the most
    // sub-steps, those next to the zero taken by backward Euler).
    double rate = 0;
    const double from = value_of(s), to = value_of(end);
    for (int k = 0; k <= kEventScan; ++k)
      rate = std::max(rate, relaxation_rate(md, from + (to - from) * k / kEventScan));
    const double wanted = std::ceil(std::min(rate * (to - from) / kMaxRateStep, 1e9));
    const int substeps = std::clamp(static_cast<int>(wanted), 1, kMaxSubsteps);
    const S ds = (end - s) / static_cast<double>(substeps);
    for (int k = 0; k < substeps; ++k) {
      const S next_s = k + 1 == substeps ? end : s + ds;
      const double sd = value_of(s), dsd = value_of(next_s) - sd;
      const bool stiff = relaxation_rate(md, sd + 0.5 * dsd) * dsd > 1.0;
      const S next = advance_angle(m, s, ph.angle, next_s - s, stiff);
      const double lam = slip_rate(md, value_of(next_s), value_of(next));
      if (lam < 0) {
        // Slip to stick inside this sub-step: the root of lambda along the same sub-step.
        const double a = value_of(s), b = value_of(next_s), a0 = value_of(ph.angle);
        auto angle_at = [&](double x) { return value_of(advance_angle(md, a, a0, x - a, stiff)); };
        auto g = [&](double x) { return value_of(slip_rate(md, x, angle_at(x))); };
        const double ga = g(a);
        const double root = ga <= 0 ? a : refine(g, a, ga, b, g(b));
        const S s_start = s, angle_start = ph.angle;
        auto g_scalar = [&](const S& x) {
          return slip_rate(m, x, advance_angle(m, s_start, angle_start, x - s_start, stiff));
        };
        s = polish<S>(root, g_scalar, g);
        ph.angle = advance_angle(m, s_start, angle_start, s - s_start, stiff);
        stick_at(ph, m, s);
        return;
      }
      s = next_s;
      ph.angle = next;
    }
    if (opens <= 1.0) {
      add_onset(
          add_kink(out, s,
                   difference({S(0.0), S(0.0), S(0.0)}, closed_rate(m, s, true, ph.w, ph.angle))),
          m, s, false, true, ph.angle);
      ph.mode = Mode::kOpen;
      return;
    }
    s = S(1.0);
    set_slider_from_angle(ph, m, s);
  }

  template <class S>
  void set_slider_from_angle(Phase<S>& ph, const HermiteCubic<S>& m, const S& s) const {
    const auto u = m.position(s);
    const auto n = normal_.side(u[2]);
    const S radius = n.stiffness > 0 ? mu_ * n.normal / n.stiffness : S(0.0);
    ph.w[0] = u[0] - radius * cos(ph.angle);
    ph.w[1] = u[1] - radius * sin(ph.angle);
  }

  template <class S>
  void stick_at(Phase<S>& ph, const HermiteCubic<S>& m, S& s) const {
    set_slider_from_angle(ph, m, s);
    ph.mode = Mode::kStick;
    ph.from_contact = false;
    // Slip ends with lambda = 0: the force's rate is continuous, no kink. Move past the root
    // so that the stick scan does not start on the circle.
    s = S(std::min(1.0, value_of(s) + 1e-12)) + (s - value_of(s));
  }

  template <class S>
  void finish(const Phase<S>& ph, const HermiteCubic<S>& m, SliderStep<S>& out) const {
    const S one(1.0);
    const auto u = m.position(one);
    out.force = {S(0.0), S(0.0), S(0.0)};
    if (ph.mode == Mode::kOpen) {
      out.slider = {u[0], u[1]};
      return;
    }
    const auto n = normal_.side(u[2]);
    out.force[2] = n.normal;
    if (ph.mode == Mode::kStick) {
      out.slider = ph.w;
      out.force[0] = n.stiffness * (u[0] - ph.w[0]);
      out.force[1] = n.stiffness * (u[1] - ph.w[1]);
      return;
    }
    const S limit = mu_ * n.normal;
    out.force[0] = limit * cos(ph.angle);
    out.force[1] = limit * sin(ph.angle);
    out.slider = {u[0] - out.force[0] / n.stiffness, u[1] - out.force[1] / n.stiffness};
  }

  Normal normal_;
  double mu_;
};

namespace detail {

// True when the host's kink buffer has the onset fields (ABI 1.3) and passed them.
inline bool has_onsets(const frichb_force_kinks& kinks) {
  return kinks.struct_size >= offsetof(frichb_force_kinks, donset) + sizeof(double*) &&
         kinks.onset != nullptr && kinks.onset_power != nullptr && kinks.onset_side != nullptr;
}

// The values of a slider step, in the ABI's layout: force (the normal component 0 unless
// `writes_normal`), state, and the kinks' locations and jumps.
template <class S>
void write_step_values(const SliderStep<S>& r, bool writes_normal, double* force_now,
                       double* state_now, frichb_force_kinks* kinks) {
  for (int a = 0; a < 3; ++a)
    force_now[a] = (a == 2 && !writes_normal) ? 0.0 : value_of(r.force[a]);
  state_now[0] = value_of(r.slider[0]);
  state_now[1] = value_of(r.slider[1]);
  if (kinks == nullptr) return;
  kinks->count = 0;
  for (int k = 0; k < r.kink_count && kinks->count < kinks->capacity; ++k, ++kinks->count) {
    const std::size_t at = kinks->count;
    kinks->fraction[at] = value_of(r.kinks[k].s);
    for (std::size_t a = 0; a < 3; ++a)
      kinks->rate_jump[at * 3 + a] =
          (a == 2 && !writes_normal) ? 0.0 : value_of(r.kinks[k].rate_jump[a]);
    if (!has_onsets(*kinks)) continue;
    kinks->onset_power[at] = r.kinks[k].onset_power;
    kinks->onset_side[at] = r.kinks[k].onset_side;
    for (std::size_t a = 0; a < 3; ++a)
      kinks->onset[at * 3 + a] = (a == 2 && !writes_normal) ? 0.0 : value_of(r.kinks[k].onset[a]);
  }
}

template <class S>
StepMotion<S> step_motion(const double* u_prev, const double* u_now,
                          const frichb_step_motion& motion) {
  StepMotion<S> m;
  for (int i = 0; i < 3; ++i) {
    m.u0[i] = S(u_prev[i]);
    m.u1[i] = S(u_now[i]);
    m.v0[i] = S(motion.rate_prev[i]);
    m.v1[i] = S(motion.rate_now[i]);
  }
  return m;
}

}  // namespace detail

// One step_along of a law whose tangential side is a FrictionCircleSlider (state: the
// slider, 2 values), for the ABI. Value only: in doubles. The state's derivative alone (a
// monodromy pass): on Dual<2> over the previous state. Every tangent: on Dual<14> over the
// inputs [state_prev (2), u_prev (3), u_now (3), rate_prev (3), rate_now (3)], which fills
// every tangent block and the kinks' derivatives. `writes_normal`: the law reports its normal
// force (else force_now[2] = 0, a normal it does not use).
template <class Normal>
void friction_circle_step_along(const FrictionCircleSlider<Normal>& slider, bool writes_normal,
                                const double* state_prev, const double* u_prev, const double* u_now,
                                const frichb_step_motion& motion, double* force_now,
                                double* state_now, const frichb_step_tangents* tangents,
                                const frichb_motion_tangents* motion_tangents,
                                frichb_force_kinks* kinks) {
  constexpr int kInputs = 14;
  const StepTangents tangent(tangents, 2);
  if (!tangent.wanted() && tangents != nullptr && tangents->dstate_dstate_prev != nullptr) {
    using D2 = Dual<2>;
    const auto r = slider.template advance<D2>(
        {D2::variable(state_prev[0], 0), D2::variable(state_prev[1], 1)},
        detail::step_motion<D2>(u_prev, u_now, motion));
    detail::write_step_values(r, writes_normal, force_now, state_now, kinks);
    for (int k = 0; k < 2; ++k)
      for (int l = 0; l < 2; ++l)
        tangents->dstate_dstate_prev[k * 2 + l] = r.slider[k].derivative(l);
    return;
  }
  if (!tangent.wanted() || motion_tangents == nullptr) {
    const auto r = slider.template advance<double>(
        {state_prev[0], state_prev[1]}, detail::step_motion<double>(u_prev, u_now, motion));
    detail::write_step_values(r, writes_normal, force_now, state_now, kinks);
    return;
  }
  using D = Dual<kInputs>;
  StepMotion<D> m;
  for (int i = 0; i < 3; ++i) {
    m.u0[i] = D::variable(u_prev[i], 2 + i);
    m.u1[i] = D::variable(u_now[i], 5 + i);
    m.v0[i] = D::variable(motion.rate_prev[i], 8 + i);
    m.v1[i] = D::variable(motion.rate_now[i], 11 + i);
  }
  const auto r =
      slider.template advance<D>({D::variable(state_prev[0], 0), D::variable(state_prev[1], 1)}, m);
  detail::write_step_values(r, writes_normal, force_now, state_now, kinks);
  tangent.zero();
  auto fu = tangent.dforce_du_now();
  auto fp = tangent.dforce_du_prev();
  auto fs = tangent.dforce_dstate_prev();
  auto su = tangent.dstate_du_now();
  auto sp = tangent.dstate_du_prev();
  auto ss = tangent.dstate_dstate_prev();
  const int rows = writes_normal ? 3 : 2;
  for (int a = 0; a < rows; ++a) {
    for (int i = 0; i < 3; ++i) {
      fp(a, i) = r.force[a].derivative(2 + i);
      fu(a, i) = r.force[a].derivative(5 + i);
      motion_tangents->dforce_drate_prev[a * 3 + i] = r.force[a].derivative(8 + i);
      motion_tangents->dforce_drate_now[a * 3 + i] = r.force[a].derivative(11 + i);
    }
    for (int k = 0; k < 2; ++k) fs(a, k) = r.force[a].derivative(k);
  }
  for (int k = 0; k < 2; ++k) {
    for (int i = 0; i < 3; ++i) {
      sp(k, i) = r.slider[k].derivative(2 + i);
      su(k, i) = r.slider[k].derivative(5 + i);
      motion_tangents->dstate_drate_prev[k * 3 + i] = r.slider[k].derivative(8 + i);
      motion_tangents->dstate_drate_now[k * 3 + i] = r.slider[k].derivative(11 + i);
    }
    for (int l = 0; l < 2; ++l) ss(k, l) = r.slider[k].derivative(l);
  }
  if (kinks == nullptr) return;
  for (std::size_t at = 0; at < kinks->count; ++at) {
    const auto& kink = r.kinks[at];
    for (int i = 0; i < kInputs && kinks->dfraction != nullptr; ++i)
      kinks->dfraction[at * kInputs + static_cast<std::size_t>(i)] = kink.s.derivative(i);
    for (int a = 0; a < 3 && kinks->drate_jump != nullptr; ++a)
      for (int i = 0; i < kInputs; ++i)
        kinks->drate_jump[(at * 3 + static_cast<std::size_t>(a)) * kInputs +
                          static_cast<std::size_t>(i)] =
            a < rows ? kink.rate_jump[static_cast<std::size_t>(a)].derivative(i) : 0.0;
    if (!detail::has_onsets(*kinks) || kinks->donset == nullptr) continue;
    for (int a = 0; a < 3; ++a)
      for (int i = 0; i < kInputs; ++i)
        kinks->donset[(at * 3 + static_cast<std::size_t>(a)) * kInputs +
                      static_cast<std::size_t>(i)] =
            a < rows ? kink.onset[static_cast<std::size_t>(a)].derivative(i) : 0.0;
  }
}

}  // namespace frichb::sdk
