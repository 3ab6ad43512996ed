#pragma once

#include <memory>

namespace yarnsim::contact {

/// Normal interface law: the magnitude of the normal contact force from the penetration
/// p = -g_e (metres, eq. 12) and its rate dp/dt (m/s). formulation.md §4.
///
/// Contract for every implementation: the force is zero for p <= -onset() (no contact; onset() is
/// 0 but for a law that starts before the surfaces touch), never negative (no adhesion), and
/// `stiffness` and `damping` are its partial derivatives, also zero there. The elastic part
/// derives from `potential`, whose derivative is the force at zero rate; the contact kernels use
/// it as the pair's energy, and count a pair as in contact where p > -onset().
class InterfaceLaw {
public:
  virtual ~InterfaceLaw() = default;

  /// f(p, dp/dt), N.
  virtual double force(double penetration, double penetration_rate = 0.0) const = 0;

  /// df/dp, N/m.
  virtual double stiffness(double penetration, double penetration_rate = 0.0) const = 0;

  /// df/d(dp/dt), N s/m. Zero for laws without a rate term.
  virtual double damping(double /*penetration*/, double /*penetration_rate*/ = 0.0) const {
    return 0.0;
  }

  /// Elastic potential U(p) = integral of f(s, 0) ds from -onset() to p, J. Zero below.
  virtual double potential(double penetration) const = 0;

  /// The gap at which the law starts to act, m (>= 0): the force is non-zero where
  /// p > -onset(). 0 for laws that act from contact on.
  virtual double onset() const { return 0.0; }
};

/// Linear penalty f = eps p (Giraffe's EPN penalty); eps in N/m.
class LinearPenalty final : public InterfaceLaw {
public:
  /// Throws std::invalid_argument unless eps > 0 and finite.
  explicit LinearPenalty(double eps);

  double force(double penetration, double penetration_rate = 0.0) const override;
  double stiffness(double penetration, double penetration_rate = 0.0) const override;
  double potential(double penetration) const override;

  /// Penalty, N/m.
  double eps() const { return eps_; }

private:
  double eps_;
};

/// Linear penalty with a quadratic regularisation over a gap g0 before contact (Meier, Popp and
/// Wall, CMAME 308 (2016) 377-413, their regularised penalty law; eps in N/m, g0 in m):
///   f = 0                         p <= -g0
///   f = eps (p + g0)^2 / (2 g0)   -g0 < p < 0
///   f = eps (p + g0 / 2)          p >= 0
/// C1: the force and its slope are continuous, at p = -g0 (0 and 0) and at p = 0 (eps g0 / 2 and
/// eps), so Newton's tangent sees a pair from a gap of g0 on instead of switching from nothing to
/// eps where the surfaces touch. An equilibrium at force f lies g0 / 2 less deep than the linear
/// law's (f / eps - g0 / 2) while f > eps g0 / 2. onset() = g0.
class RegularisedPenalty final : public InterfaceLaw {
public:
  /// Throws std::invalid_argument unless eps > 0 and g0 > 0, both finite.
  RegularisedPenalty(double eps, double g0);

  double force(double penetration, double penetration_rate = 0.0) const override;
  double stiffness(double penetration, double penetration_rate = 0.0) const override;
  double potential(double penetration) const override;
  double onset() const override { return g0_; }

  /// Penalty, N/m.
  double eps() const { return eps_; }

private:
  double eps_;
  double g0_;
};

/// Power law f = eps p^n (Giraffe's exponent keyword); eps in N/m^n. The exponent must be >= 1 so
/// that df/dp is finite and continuous at p = 0 (for n = 1 it is the linear penalty).
class PowerLaw final : public InterfaceLaw {
public:
  /// Throws std::invalid_argument unless eps > 0 and n >= 1, both finite.
  PowerLaw(double eps, double exponent);

  double force(double penetration, double penetration_rate = 0.0) const override;
  double stiffness(double penetration, double penetration_rate = 0.0) const override;
  double potential(double penetration) const override;

  /// Coefficient, N/m^n.
  double eps() const { return eps_; }
  /// Exponent n, dimensionless.
  double exponent() const { return n_; }

private:
  double eps_;
  double n_;
};

/// An elastic law plus normal damping: f = max(0, f_e(p) + c dp/dt) while p > -onset(), else 0
/// (onset() the elastic law's).
/// The clamp keeps a separating contact from pulling (no adhesion); where it is active all
/// derivatives vanish. The potential is the elastic law's (damping is not conservative).
class DampedLaw final : public InterfaceLaw {
public:
  /// `elastic` is shared, not copied; c in N s/m. Throws std::invalid_argument for a null law or
  /// a negative or non-finite c.
  DampedLaw(std::shared_ptr<const InterfaceLaw> elastic, double c);

  double force(double penetration, double penetration_rate = 0.0) const override;
  double stiffness(double penetration, double penetration_rate = 0.0) const override;
  double damping(double penetration, double penetration_rate = 0.0) const override;
  double potential(double penetration) const override;
  double onset() const override { return elastic_->onset(); }

  /// Damping coefficient c, N s/m.
  double coefficient() const { return c_; }
  /// The elastic part.
  const InterfaceLaw& elastic() const { return *elastic_; }

private:
  std::shared_ptr<const InterfaceLaw> elastic_;
  double c_;
};

} // namespace yarnsim::contact
