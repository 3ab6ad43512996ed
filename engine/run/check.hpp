#pragma once
// `yarnsim check DECK`: what a deck's model holds, without running it: its size, its contact
// definitions with the candidate pairs a broad-phase search finds at the initial configuration
// and the clearance each formulation sees, the stable step of the explicit path, its steps.

#include "engine/model/model.hpp"

#include <string>

namespace yarnsim {

class Simulation;

/// "spline contact: initial clearance 0.00785 mm (smallest gap ...)": the line a run prints
/// before its first increment; empty without contact.
std::string initial_clearance_line(const Simulation& simulation);

/// The report of `yarnsim check`, several lines, each ending with a line break. Builds a
/// Simulation of the model (assembly pattern, contact stage evaluated at the initial
/// configuration); throws what its constructor throws.
std::string check_report(const Model& model);

} // namespace yarnsim
