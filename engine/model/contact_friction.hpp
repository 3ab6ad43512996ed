#pragma once
// The friction keys of a contact table, shared by the model deck's [[contacts]] and the fabric
// deck's [contact] (docs/input.md): `friction` (mu_s = mu_k), or `static_friction` and
// `kinetic_friction`; `tangential_penalty` (N/m; default: the normal penalty of a linear law)
// or `elastic_slip` (m: the stick stiffness mu f_n / elastic_slip);
// `torsional_friction` (true: a friction torque at the crossings), `torsional_radius` (m) and
// `torsional_penalty` (N m/rad), whose defaults (0 here) the contact stage derives per pair.
// Each table lists the eight keys in its own TableSpec.

#include "engine/model/deck_schema.hpp"
#include "engine/model/model.hpp"

#include <string_view>

namespace yarnsim {

/// Reads the friction keys of `t` into `friction` (left frictionless when there are none),
/// reporting their problems on `t`: both forms given, only one of static and kinetic, kinetic
/// above static, a tangential penalty, elastic slip or torsional key without friction, a
/// torsional radius or penalty without torsional_friction = true, both a tangential penalty and
/// an elastic slip, a tangential penalty missing with a power law (whose penalty is not in N/m),
/// an elastic slip in a deck with an explicit step (whose stable step needs a constant stick
/// stiffness). `law` is the table's normal law; `explicit_step` says which step of the deck is
/// explicit (for the message, e.g. "steps[2]"), empty when none is.
void read_contact_friction(const deck::CheckedTable& t, const InterfaceLawParameters& law,
                           FrictionParameters& friction, std::string_view explicit_step);

} // namespace yarnsim
