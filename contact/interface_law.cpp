#include "contact/interface_law.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace yarnsim::contact {

namespace {

void require(bool condition, const char* what, double value) {
  if (!condition) {
    std::ostringstream message;
    message << "interface law: expected " << what << ", found " << value;
    throw std::invalid_argument(message.str());
  }
}

} // namespace

LinearPenalty::LinearPenalty(double eps) : eps_(eps) {
  require(std::isfinite(eps) && eps > 0.0, "a finite penalty eps > 0 (N/m)", eps);
}

double LinearPenalty::force(double p, double /*rate*/) const {
  return p > 0.0 ? eps_ * p : 0.0;
}

double LinearPenalty::stiffness(double p, double /*rate*/) const {
  return p > 0.0 ? eps_ : 0.0;
}

double LinearPenalty::potential(double p) const {
  return p > 0.0 ? 0.5 * eps_ * p * p : 0.0;
}

RegularisedPenalty::RegularisedPenalty(double eps, double g0) : eps_(eps), g0_(g0) {
  require(std::isfinite(eps) && eps > 0.0, "a finite penalty eps > 0 (N/m)", eps);
  require(std::isfinite(g0) && g0 > 0.0, "a finite regularisation gap g0 > 0 (m)", g0);
}

double RegularisedPenalty::force(double p, double /*rate*/) const {
  if (p >= 0.0)
    return eps_ * (p + 0.5 * g0_);
  const double q = p + g0_;
  return q > 0.0 ? eps_ * q * q / (2.0 * g0_) : 0.0;
}

double RegularisedPenalty::stiffness(double p, double /*rate*/) const {
  if (p >= 0.0)
    return eps_;
  const double q = p + g0_;
  return q > 0.0 ? eps_ * q / g0_ : 0.0;
}

double RegularisedPenalty::potential(double p) const {
  // U = eps q^3 / (6 g0) up to p = 0 (q = p + g0), then eps g0^2 / 6 + eps (g0 p / 2 + p^2 / 2).
  if (p >= 0.0)
    return eps_ * (g0_ * g0_ / 6.0 + 0.5 * p * (g0_ + p));
  const double q = p + g0_;
  return q > 0.0 ? eps_ * q * q * q / (6.0 * g0_) : 0.0;
}

PowerLaw::PowerLaw(double eps, double exponent) : eps_(eps), n_(exponent) {
  require(std::isfinite(eps) && eps > 0.0, "a finite coefficient eps > 0 (N/m^n)", eps);
  require(std::isfinite(exponent) && exponent >= 1.0,
          "a finite exponent n >= 1 (df/dp must stay finite at p = 0)", exponent);
}

double PowerLaw::force(double p, double /*rate*/) const {
  return p > 0.0 ? eps_ * std::pow(p, n_) : 0.0;
}

double PowerLaw::stiffness(double p, double /*rate*/) const {
  return p > 0.0 ? eps_ * n_ * std::pow(p, n_ - 1.0) : 0.0;
}

double PowerLaw::potential(double p) const {
  return p > 0.0 ? eps_ * std::pow(p, n_ + 1.0) / (n_ + 1.0) : 0.0;
}

DampedLaw::DampedLaw(std::shared_ptr<const InterfaceLaw> elastic, double c)
    : elastic_(std::move(elastic)), c_(c) {
  if (!elastic_) {
    throw std::invalid_argument("interface law: DampedLaw expected an elastic law, found null");
  }
  require(std::isfinite(c) && c >= 0.0, "a finite damping coefficient c >= 0 (N s/m)", c);
}

double DampedLaw::force(double p, double rate) const {
  if (p <= -onset()) {
    return 0.0;
  }
  const double f = elastic_->force(p, 0.0) + c_ * rate;
  return f > 0.0 ? f : 0.0;
}

double DampedLaw::stiffness(double p, double rate) const {
  if (p <= -onset() || elastic_->force(p, 0.0) + c_ * rate <= 0.0) {
    return 0.0;
  }
  return elastic_->stiffness(p, 0.0);
}

double DampedLaw::damping(double p, double rate) const {
  if (p <= -onset() || elastic_->force(p, 0.0) + c_ * rate <= 0.0) {
    return 0.0;
  }
  return c_;
}

double DampedLaw::potential(double p) const {
  return elastic_->potential(p);
}

} // namespace yarnsim::contact
