#include "engine/textile/loading.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <stdexcept>

namespace yarnsim::textile {

SolutionStep loading_step(const LoadingParameters& p, double t0, std::string_view test) {
  const double T = p.loading_time;
  if (!(T > 0) || !std::isfinite(T))
    throw std::invalid_argument(fmt::format("{}: expected a loading time > 0, found {}", test, T));
  SolutionStep step;
  step.type = p.type;
  step.end_time = t0 + T;
  if (p.type == StepType::Explicit) {
    const ExplicitLoading& x = p.explicit_;
    step.mass_scaling_dt = x.mass_scaling_dt < 0 ? T / 50000 : x.mass_scaling_dt;
    step.dt_initial = x.dt > 0 ? x.dt : step.mass_scaling_dt;
    if (!(step.dt_initial > 0) || step.dt_initial > T)
      throw std::invalid_argument(
          fmt::format("{}: expected an explicit time step in (0, loading time {}] (dt, or "
                      "mass_scaling_dt when dt is not given), found {}",
                      test, T, step.dt_initial));
    if (!(x.safety_factor > 0 && x.safety_factor <= 1))
      throw std::invalid_argument(
          fmt::format("{}: expected a safety factor in (0, 1], found {}", test, x.safety_factor));
    step.dt_max = step.dt_initial;
    step.dt_min = 1e-3 * step.dt_initial;
    step.safety_factor = x.safety_factor;
    step.stable_dt_every = std::max(1, x.stable_dt_every);
    step.energy_monitor = x.energy_monitor;
    // About 200 outputs over the step unless asked otherwise.
    step.output_every =
        x.output_every > 0
            ? x.output_every
            : static_cast<int>(std::clamp(std::ceil(T / step.dt_initial / 200), 1.0, 1e9));
  } else if (p.type == StepType::Static || p.type == StepType::Dynamic) {
    step.dt_initial = p.dt > 0 ? p.dt : T / 100;
    step.dt_max = p.dt_max > 0 ? p.dt_max : std::max(T / 50, step.dt_initial);
    step.dt_min = p.dt_min > 0 ? p.dt_min : std::min(T * 1e-6, step.dt_initial);
    if (step.dt_initial > T || step.dt_min > step.dt_initial || step.dt_initial > step.dt_max)
      throw std::invalid_argument(fmt::format("{}: expected dt_min <= dt <= dt_max and dt <= "
                                              "the loading time {}, found {} <= {} <= {}",
                                              test, T, step.dt_min, step.dt_initial, step.dt_max));
    step.max_iterations = p.max_iterations;
    step.tol_force = p.tol_force;
    step.tol_increment = p.tol_increment;
    step.newmark_beta = p.newmark_beta;
    step.newmark_gamma = p.newmark_gamma;
    step.secant_predictor = p.secant_predictor;
    step.output_every = p.output_every;
  } else {
    throw std::invalid_argument(
        fmt::format("{}: expected a static, dynamic or explicit step", test));
  }
  const bool given = p.rayleigh_mass > 0 || p.rayleigh_stiffness > 0;
  if (p.type == StepType::Static && given)
    throw std::invalid_argument(fmt::format(
        "{}: Rayleigh damping applies only to dynamic and explicit steps; this one is static",
        test));
  if (!(p.rayleigh_stiffness >= 0) || !std::isfinite(p.rayleigh_stiffness) ||
      !std::isfinite(p.rayleigh_mass))
    throw std::invalid_argument(
        fmt::format("{}: expected Rayleigh coefficients >= 0, found mass {} and stiffness {}", test,
                    p.rayleigh_mass, p.rayleigh_stiffness));
  step.rayleigh_mass = p.rayleigh_mass >= 0          ? p.rayleigh_mass
                       : p.type == StepType::Dynamic ? kStabilisingDamping
                                                     : 0.0;
  step.rayleigh_stiffness = p.rayleigh_stiffness;
  if (!std::isfinite(p.rayleigh_out_of_plane) ||
      (p.rayleigh_out_of_plane > 0 && p.type != StepType::Dynamic))
    throw std::invalid_argument(
        fmt::format("{}: expected out-of-plane damping >= 0 on a dynamic step, found {}", test,
                    p.rayleigh_out_of_plane));
  step.rayleigh_out_of_plane = p.rayleigh_out_of_plane >= 0  ? p.rayleigh_out_of_plane
                               : p.type == StepType::Dynamic ? kStabilisingDamping
                                                             : 0.0;
  return step;
}

namespace {

/// value s(tau) of the quintic smooth step, multiplied in this order (the order of the first
/// version, so that tabulated ramps stay bitwise the same).
double smooth_step(double value, double tau) {
  return value * tau * tau * tau * (10 + tau * (-15 + 6 * tau));
}

} // namespace

double ramp_fraction(LoadingRamp shape, double tau) {
  tau = std::clamp(tau, 0.0, 1.0);
  return shape == LoadingRamp::Linear ? tau : smooth_step(1.0, tau);
}

SolutionStep preliminary_step(const LoadingParameters& p, double duration, double t0,
                              std::string_view test) {
  LoadingParameters q = p;
  q.loading_time = duration;
  q.dt = q.dt_max = q.dt_min = 0;
  return loading_step(q, t0, test);
}

TimeTable ramp_table(double t0, double t1, double value, LoadingRamp shape) {
  if (value == 0)
    return TimeTable::constant(0.0);
  if (shape == LoadingRamp::Linear)
    return TimeTable{{t0, t1}, {0.0, value}};
  constexpr int kIntervals = 400;
  TimeTable table;
  for (int i = 0; i <= kIntervals; ++i) {
    const double tau = static_cast<double>(i) / kIntervals;
    table.time.push_back(i == kIntervals ? t1 : t0 + tau * (t1 - t0));
    table.value.push_back(smooth_step(value, tau));
  }
  return table;
}

} // namespace yarnsim::textile
