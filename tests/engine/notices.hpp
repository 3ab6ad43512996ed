#pragma once
// A SimulationObserver that keeps what a run says once (`note: ...`: a tolerance below the
// round-off level, points without friction, a yarn that slid off the end of another).

#include "engine/solver/simulation.hpp"

#include <string>
#include <vector>

namespace yarnsim::test {

struct Notices : SimulationObserver {
  std::vector<std::string> said;
  void on_notice(const Simulation&, const std::string& what) override { said.push_back(what); }
};

} // namespace yarnsim::test
