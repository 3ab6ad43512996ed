#include "engine/run/check.hpp"

#include "engine/contact/spline_contact_set.hpp"
#include "engine/contact/surface_contact_set.hpp"
#include "engine/solver/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <numbers>

namespace yarnsim {

namespace {

const char* step_name(StepType t) {
  return t == StepType::Explicit ? "explicit" : t == StepType::Static ? "static" : "dynamic";
}

std::string law_text(const InterfaceLawParameters& law) {
  if (law.exponent == 1 && law.regularisation > 0)
    return fmt::format("linear, penalty {:g} N/m, regularised over {:g} m", law.penalty,
                       law.regularisation);
  return law.exponent == 1 ? fmt::format("linear, penalty {:g} N/m", law.penalty)
                           : fmt::format("power, penalty {:g} N/m^{:g}", law.penalty, law.exponent);
}

/// One formulation's figures at the initial configuration.
std::string contact_set_line(const char* name, const ContactSet& set) {
  const ContactSummary& s = set.summary();
  return fmt::format("  {} contact at the initial configuration: {} candidate pair(s) from the "
                     "broad phase, {} active, smallest gap {}\n",
                     name, s.candidates, s.active,
                     std::isfinite(s.min_gap) ? fmt::format("{:.6g} mm", 1e3 * s.min_gap)
                                              : std::string("none (no projection in range)"));
}

/// ", torsional friction at the crossings (...)" where a contact has it, else empty.
std::string torsion_text(const FrictionParameters& f) {
  if (!(f.active() && f.torsional))
    return {};
  return fmt::format(", torsional friction at the crossings (radius {}, penalty {})",
                     f.torsional_radius > 0 ? fmt::format("{:.6g} mm", 1e3 * f.torsional_radius)
                                            : std::string("from the yarn widths"),
                     f.torsional_penalty > 0
                         ? fmt::format("{:.6g} N mm/rad", 1e3 * f.torsional_penalty)
                     : f.elastic_slip > 0 ? std::string("mu f_n radius^2 / elastic slip")
                                          : std::string("tangential penalty x radius^2"));
}

/// A friction law's coefficients and stick stiffness: the constant tangential penalty (with one
/// coefficient, also the stick displacement per newton of normal force), or the elastic slip.
std::string friction_text(const FrictionParameters& f) {
  if (!f.active())
    return ", frictionless";
  const std::string mu = f.mu_static == f.mu_kinetic
                             ? fmt::format("mu = {:g}", f.mu_static)
                             : fmt::format("mu_s = {:g}, mu_k = {:g}", f.mu_static, f.mu_kinetic);
  if (f.elastic_slip > 0)
    return fmt::format(", friction {}, elastic slip {:.6g} mm (the stick stiffness mu f_n / "
                       "elastic slip)",
                       mu, 1e3 * f.elastic_slip);
  if (f.mu_static == f.mu_kinetic)
    return fmt::format(", friction {}, tangential penalty {:.6g} N/m (the stick displacement "
                       "mu f_n / eps_t is {:.3g} mm per N of normal force)",
                       mu, f.tangential_penalty, 1e3 * f.mu_static / f.tangential_penalty);
  return fmt::format(", friction {}, tangential penalty {:.6g} N/m", mu, f.tangential_penalty);
}

} // namespace

std::string initial_clearance_line(const Simulation& sim) {
  if (!sim.contact())
    return {};
  return fmt::format("{} contact: initial clearance {:.6g} mm (smallest gap the contact sees "
                     "before loading{})\n",
                     sim.contact()->formulations(), 1e3 * sim.initial_contact_clearance(),
                     sim.model().spline_contacts.empty() ? "" : "; the splines' effective gap");
}

std::string check_report(const Model& model) {
  const Simulation sim(model);
  std::string out;
  const std::size_t n = model.nodes.size();
  out += fmt::format("model: {} nodes, {} elements (3-node beams), {} DOF ({} free, {} fixed or "
                     "prescribed)\n",
                     n, model.elements.size(), 6 * n, sim.assembler().n_equations(),
                     6 * n - static_cast<std::size_t>(sim.assembler().n_equations()));
  if (model.biaxial) {
    const BiaxialTest& b = *model.biaxial;
    if (b.uniaxial)
      out += fmt::format("yarns: {} warp + {} weft (uniaxial test: the {} pulled to {:g} % "
                         "strain, the {} yarns' ends free)\n",
                         b.warp_start.size(), b.weft_start.size(),
                         *b.uniaxial == FabricDirection::Warp ? "warp" : "weft", 100 * b.max_strain,
                         *b.uniaxial == FabricDirection::Warp ? "weft" : "warp");
    else
      out +=
          fmt::format("yarns: {} warp + {} weft (biaxial test, k = {:g}, to {:g} % strain)\n",
                      b.warp_start.size(), b.weft_start.size(), b.strain_ratio, 100 * b.max_strain);
  }
  if (model.picture_frame) {
    const PictureFrameTest& f = *model.picture_frame;
    constexpr double deg = 180 / std::numbers::pi;
    out += fmt::format(
        "picture frame: side {:g} mm, pretension {:g} %, to a shear angle of {:g} "
        "degrees, yarn ends {} ({} ends on the arms); the shear angle measured at {} crossings of "
        "the central {:g} % of the side; neighbouring parallel yarns touch at "
        "{:.2f} degrees (acos(w / p))\n",
        1e3 * f.side, 100 * (f.stretch.value.back() - 1), f.max_angle * deg,
        f.clamped ? "clamped" : "pinned", f.ends.size(), f.central.size(), 100 * f.central_region,
        f.locking_angle * deg);
  }
  if (model.bias_extension) {
    const BiasExtensionTest& b = *model.bias_extension;
    constexpr double deg = 180 / std::numbers::pi;
    out += fmt::format(
        "bias extension: specimen {:g} x {:g} mm (free length {:g} mm, clamps {:g} mm), yarns at "
        "+-45 degrees, {} + {} nodes clamped; the top clamp travels {:g} mm (an ideal central "
        "shear angle of {:g} degrees); the shear angle measured at {} crossings of the central "
        "{:g} % of zone C; neighbouring parallel yarns touch at {:.2f} degrees (acos(w / p)){}\n",
        1e3 * b.width, 1e3 * (b.height + 2 * b.clamp_length), 1e3 * b.height, 1e3 * b.clamp_length,
        model.node_sets[b.bottom_clamp].nodes.size(), model.node_sets[b.top_clamp].nodes.size(),
        1e3 * b.displacement.value.back(), b.max_angle * deg, b.central.size(),
        100 * b.central_region, b.locking_angle * deg,
        b.compaction > 0 ? fmt::format("; the crossings compacted by {:g} mm before the pull "
                                       "(it starts at t = {:g} s)",
                                       1e3 * b.compaction, b.pull_start)
                         : std::string());
  }
  out += fmt::format("sections: {}, node sets: {}, splines: {}, surfaces: {}, monitors: {}\n",
                     model.sections.size(), model.node_sets.size(), model.splines.size(),
                     model.surfaces.size(), model.monitors.size());
  // The sections' stiffnesses (the first few): what reduce_lower_inertia and reduce_upper_inertia
  // of a fabric deck made of them.
  constexpr std::size_t kSectionsListed = 4;
  for (std::size_t k = 0; k < std::min(model.sections.size(), kSectionsListed); ++k) {
    const Section& s = model.sections[k];
    out += fmt::format("  section '{}': EA {:.4g} N, EI1 {:.4g} N m^2 (about axis 1), EI2 {:.4g} N "
                       "m^2 (about axis 2), GJ {:.4g} N m^2\n",
                       s.name, s.EA, s.EI1, s.EI2, s.GJ);
  }
  if (model.sections.size() > kSectionsListed)
    out += fmt::format("  ... and {} more sections\n", model.sections.size() - kSectionsListed);
  out += fmt::format("contact definitions: {}\n",
                     model.spline_contacts.size() + model.surface_contacts.size());
  for (const SplineContactDefinition& c : model.spline_contacts) {
    const FrictionParameters& f = c.friction;
    const std::string friction = friction_text(f);
    const std::string torsion = torsion_text(f);
    // Who touches whom: two groups, or one group within itself (its splines with each other,
    // and each spline with itself unless within_spline is off, as in a fabric's warp-warp).
    const std::string groups =
        !c.self_contact ? fmt::format("{} x {} splines", c.group_a.size(), c.group_b.size())
        : c.group_b.empty()
            ? fmt::format("{} splines with each other{}", c.group_a.size(),
                          c.within_spline ? " and themselves (self contact)" : "")
            : fmt::format("{} x {} splines (self contact)", c.group_a.size(), c.group_b.size());
    out += fmt::format("  spline contact '{}': {}, {}, margin {:.6g} mm{}\n", c.name, groups,
                       law_text(c.law), 1e3 * c.margin, friction + torsion);
  }
  for (const SurfaceContactDefinition& c : model.surface_contacts) {
    const FrictionParameters& f = c.friction;
    const std::string friction = friction_text(f);
    out += fmt::format("  surface contact '{}': {} x {} surfaces, {}, margin {:.6g} mm{}{}\n",
                       c.name, c.group_a.size(), c.group_b.size(), law_text(c.law), 1e3 * c.margin,
                       friction, torsion_text(f));
  }
  if (const ContactStage* contact = sim.contact()) {
    if (const SplineContactSet* s = contact->spline())
      out += contact_set_line("spline", *s);
    if (const SurfaceContactSet* s = contact->surface())
      out += contact_set_line("surface", *s);
    out += initial_clearance_line(sim);
  }
  // The explicit path's stable step: of each explicit step (with its mass scaling), or of the
  // model as it is when no step is explicit.
  bool any_explicit = false;
  double start = 0;
  out += fmt::format("steps: {}\n", model.steps.size());
  for (std::size_t k = 0; k < model.steps.size(); ++k) {
    const SolutionStep& s = model.steps[k];
    if (s.type == StepType::Explicit) {
      any_explicit = true;
      const ExplicitStatus e = sim.explicit_stability(s);
      out += fmt::format("  step {}: explicit, t = {:g} to {:g} s, dt {:g} s ({} increments); "
                         "stable step {:.4g} s (safety {:g} x critical {:.4g} s, set by {}){}\n",
                         k + 1, start, s.end_time, s.dt_initial,
                         static_cast<long>(std::ceil((s.end_time - start) / s.dt_initial - 1e-9)),
                         e.stable_dt, s.safety_factor, e.critical_dt, e.limited_by,
                         s.mass_scaling_dt > 0
                             ? fmt::format(" with mass scaled to {:g} s: {:.3g} % added mass",
                                           s.mass_scaling_dt, e.added_mass_percent)
                             : std::string());
    } else {
      out += fmt::format("  step {}: {}, t = {:g} to {:g} s, dt {:g} s (min {:g}, max {:g}), "
                         "{} Newton iterations at most\n",
                         k + 1, step_name(s.type), start, s.end_time, s.dt_initial, s.dt_min,
                         s.dt_max, s.max_iterations);
    }
    start = s.end_time;
  }
  // A contact with an elastic slip has no stable step (explicit decks refuse the key).
  std::string elastic;
  for (const SplineContactDefinition& c : model.spline_contacts)
    if (elastic.empty() && c.friction.active() && c.friction.elastic_slip > 0)
      elastic = c.name;
  for (const SurfaceContactDefinition& c : model.surface_contacts)
    if (elastic.empty() && c.friction.active() && c.friction.elastic_slip > 0)
      elastic = c.name;
  if (!any_explicit && !elastic.empty()) {
    out += fmt::format("explicit path (no step uses it): not available with the elastic slip of "
                       "contact '{}' (its stable step needs a constant stick stiffness)\n",
                       elastic);
  } else if (!any_explicit) {
    SolutionStep plain;
    plain.type = StepType::Explicit;
    const ExplicitStatus e = sim.explicit_stability(plain);
    out += fmt::format("explicit path (no step uses it): stable step {:.4g} s without mass "
                       "scaling (safety {:g} x critical {:.4g} s, set by {})\n",
                       e.stable_dt, plain.safety_factor, e.critical_dt, e.limited_by);
  }
  return out;
}

} // namespace yarnsim
