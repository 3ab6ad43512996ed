#pragma once
// The loading step of a fabric test (biaxial tension, picture frame, ...): how long the test
// runs, on which path (Newmark, static, central difference) and with which increments. Every
// test of engine/textile builds its SolutionStep here and ramps its motions with ramp_fraction.

#include "engine/model/model.hpp"

#include <string_view>

namespace yarnsim::textile {

/// Shape of a test's ramp from 0 to its final value over the loading time.
enum class LoadingRamp {
  Linear, ///< s(tau) = tau: the paper's; the ends start moving with a jump in velocity
  /// s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5 (quintic smooth step: zero velocity and acceleration
  /// at both ends), tabulated at 400 equal intervals. Excites fewer stress waves on the explicit
  /// path; the peak rate is 15/8 of the linear one.
  Smooth,
};

/// Settings of the explicit path (central difference, mass scaling) of a test's step.
struct ExplicitLoading {
  /// s; the mass-scaling target step. 0: no mass scaling (then dt must be given and below the
  /// stable limit, ~8.4e-8 s on the paper's fabric). Negative: loading_time / 50 000, what the
  /// paper's k = 1 case needs to stay within 5 % of the implicit curve past the toe
  /// (docs/verification.md).
  double mass_scaling_dt = -1;
  double dt = 0;              ///< s; 0: mass_scaling_dt
  double safety_factor = 0.8; ///< stable step = safety_factor x 2 / omega_max
  int stable_dt_every = 100;  ///< increments between estimates of the stable step
  int output_every = 0;       ///< 0: about 200 outputs over the step
  bool energy_monitor = true; ///< energy.csv
};

/// The step of a test: one SolutionStep of `loading_time` after the model's last step.
struct LoadingParameters {
  double loading_time = 1; ///< s, duration of the ramp from zero
  /// Dynamic (Newmark, the paper's), Static, or Explicit (central difference with `explicit_`).
  StepType type = StepType::Dynamic;
  LoadingRamp ramp = LoadingRamp::Linear;
  double dt = 0;     ///< s; 0: loading_time / 100
  double dt_min = 0; ///< s; 0: loading_time * 1e-6
  double dt_max = 0; ///< s; 0: loading_time / 50
  int max_iterations = 20;
  double tol_force = 1e-4;
  double tol_increment = 1e-4;
  double newmark_beta = 0.3;  ///< the paper's
  double newmark_gamma = 0.5; ///< the paper's
  /// Implicit steps: SolutionStep::secant_predictor (the bias extension's default).
  bool secant_predictor = false;
  int output_every = 1;      ///< implicit steps
  ExplicitLoading explicit_; ///< explicit steps
  /// Rayleigh damping C = rayleigh_mass M + rayleigh_stiffness K (1/s, s) of dynamic and
  /// explicit steps. rayleigh_mass < 0 (the tension tests' default): kStabilisingDamping on
  /// dynamic steps, 0 on explicit ones; the shear tests default to 0 (shear_tests.hpp).
  double rayleigh_mass = -1;
  double rayleigh_stiffness = 0;
  /// 1/s, mass-proportional damping of the out-of-plane (z) translations alone (dynamic tests).
  /// < 0 (the shear tests' default, shear_tests.hpp): kStabilisingDamping on dynamic steps, 0 on
  /// the others. It holds the yarns that float across the weave's clearance, as the tension
  /// tests' damping does, without resisting the shear tests' in-plane rigid motions.
  double rayleigh_out_of_plane = 0;
};

/// 1/s: the mass-proportional damping a dynamic (Newmark) test step has unless its deck says
/// otherwise. It stabilises the yarns that float free within the weave's clearance before their
/// crossings close: their only stiffness across the clearance is the out-of-plane bending of a
/// whole yarn (~EI / L^3, below 1 N/m on 24 x 24 yarns of the paper's fabric), against the
/// contact penalty of 1.5e6 N/m, and without it Newton's corrections in the toe are as large as
/// the clearance and the 24 x 24 biaxial test stalls in its first increments. As a damping ratio
/// c / (2 omega) it overdamps the floating modes (omega of a few rad/s) and is below 1e-4 for
/// the yarns' load-carrying axial and bending modes; its force on a test moving at v is c m v
/// (m the moving mass). Chosen by measurement (docs/performance.md): on the paper's 6 x 6 and a
/// 12 x 12 weave the biaxial forces move by less than 1e-4 past 0.5 % strain, and the 24 x 24
/// test goes from stalling to 57 increments. Every run reports the energy it dissipated.
inline constexpr double kStabilisingDamping = 2e5;

/// The step of `p` from t0 to t0 + loading_time. Throws std::invalid_argument, the message
/// starting with "<test>: ", for a loading time <= 0, increments out of order (dt_min <= dt <=
/// dt_max <= loading time), an explicit step outside (0, loading time] or a safety factor
/// outside (0, 1].
SolutionStep loading_step(const LoadingParameters& p, double t0, std::string_view test);

/// A test's preliminary step (a picture frame's pretension, a bias extension's compaction) of
/// `duration` from t0: `p`'s settings (type, tolerances, Newmark, explicit) with the default
/// increments of that duration. Throws as loading_step.
SolutionStep preliminary_step(const LoadingParameters& p, double duration, double t0,
                              std::string_view test);

/// s(tau) of `shape` at tau in [0, 1] (0 at 0, 1 at 1).
double ramp_fraction(LoadingRamp shape, double tau);

/// A table that ramps from 0 at t0 to `value` at t1 along `shape` (the smooth step tabulated at
/// 400 equal intervals); exactly 0 when value is 0.
TimeTable ramp_table(double t0, double t1, double value, LoadingRamp shape);

} // namespace yarnsim::textile
