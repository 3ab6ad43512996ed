#pragma once
// Reads Simulation::attempt's iteration-limit failure, "no convergence in N iterations[, K of
// them closing crossings] (...)": the iterations that counted toward max_iterations, N - K (the
// iterates where crossings closed count apart: SimulationOptions::closing_iterations_apart).

#include <regex>
#include <string>

namespace yarnsim::test {

/// N - K of the message's "no convergence in N iterations[, K of them closing crossings]"
/// anywhere in `why`; -1 where it holds no such failure.
inline int iterations_toward_limit(const std::string& why) {
  static const std::regex failure(
      R"(no convergence in (\d+) iterations(, (\d+) of them closing crossings)? \()");
  std::smatch m;
  if (!std::regex_search(why, m, failure))
    return -1;
  return std::stoi(m[1].str()) - (m[3].matched ? std::stoi(m[3].str()) : 0);
}

} // namespace yarnsim::test
