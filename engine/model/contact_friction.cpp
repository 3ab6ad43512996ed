#include "engine/model/contact_friction.hpp"

#include <fmt/format.h>

namespace yarnsim {

void read_contact_friction(const deck::CheckedTable& t, const InterfaceLawParameters& law,
                           FrictionParameters& friction, std::string_view explicit_step) {
  const bool one = t.present("friction");
  const bool two = t.present("static_friction") || t.present("kinetic_friction");
  if (one && two) {
    t.error(t.present("static_friction") ? "static_friction" : "kinetic_friction",
            "give either 'friction' (one coefficient) or 'static_friction' and "
            "'kinetic_friction', not both");
    return;
  }
  if (one) {
    friction.mu_static = friction.mu_kinetic = t.number("friction").value_or(0);
  } else if (two) {
    if (!t.present("static_friction"))
      t.missing("static_friction", "a number >= kinetic_friction, with 'kinetic_friction'");
    if (!t.present("kinetic_friction"))
      t.missing("kinetic_friction", "a number <= static_friction, with 'static_friction'");
    friction.mu_static = t.number("static_friction").value_or(0);
    friction.mu_kinetic = t.number("kinetic_friction").value_or(0);
    if (friction.mu_kinetic > friction.mu_static)
      t.error("kinetic_friction",
              fmt::format("expected kinetic_friction <= static_friction ({}), found {}",
                          friction.mu_static, friction.mu_kinetic));
  }
  if (!friction.active()) {
    for (const char* key : {"tangential_penalty", "elastic_slip", "tangential_damping",
                            "torsional_friction", "torsional_radius", "torsional_penalty"})
      if (t.present(key))
        t.error(key, fmt::format("'{}' applies only with friction (a coefficient above 0)", key));
    return;
  }
  friction.tangential_damping = t.number("tangential_damping").value_or(0);
  friction.torsional = t.boolean("torsional_friction").value_or(false);
  for (const char* key : {"torsional_radius", "torsional_penalty"})
    if (t.present(key) && !friction.torsional)
      t.error(key, fmt::format("'{}' applies only with torsional_friction = true", key));
  if (friction.torsional) {
    friction.torsional_radius = t.number("torsional_radius").value_or(0);   // 0: the default
    friction.torsional_penalty = t.number("torsional_penalty").value_or(0); // 0: the default
  }
  if (t.present("elastic_slip")) {
    // The stick stiffness mu f_n / gamma in place of a constant penalty.
    friction.elastic_slip = t.number("elastic_slip").value_or(0);
    if (t.present("tangential_penalty"))
      t.error("tangential_penalty", "give either 'tangential_penalty' (a constant stick "
                                    "stiffness) or 'elastic_slip' (the stiffness mu f_n / "
                                    "elastic_slip), not both");
    if (!explicit_step.empty())
      t.error("elastic_slip",
              fmt::format("'elastic_slip' is not available on the explicit path in this version "
                          "(its stable step needs a constant stick stiffness; {} is explicit): "
                          "give tangential_penalty instead",
                          explicit_step));
  } else if (t.present("tangential_penalty"))
    friction.tangential_penalty = t.number("tangential_penalty").value_or(0);
  else if (law.exponent == 1.0)
    friction.tangential_penalty = law.penalty; // N/m, the normal linear penalty
  else
    t.missing("tangential_penalty", "a number > 0 (N/m), or an elastic_slip (m), with friction on "
                                    "a power law (whose penalty is not in N/m)");
}

} // namespace yarnsim
