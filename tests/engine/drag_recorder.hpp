#pragma once
// The record of a drag test (tests/engine/test_friction.cpp, test_line_friction.cpp): per
// increment, the time, the imposed travel, the drag force (the x reactions of the dragged nodes,
// which balance the friction on them), the contact's summary and Newton's residuals.
#include "engine/solver/simulation.hpp"

#include <vector>

namespace yarnsim::test {

struct DragSample {
  double time, u, force; ///< s, m (the table at time), N
  ContactSummary contact;
  std::vector<double> residuals;
};

class DragRecorder final : public SimulationObserver {
public:
  /// `nodes`: the dragged nodes; `drag`: their imposed x travel (m) against time.
  DragRecorder(std::vector<int> nodes, TimeTable drag)
      : nodes_(std::move(nodes)), table_(std::move(drag)) {}
  void on_increment(const Simulation& sim, const IncrementReport& r) override {
    double rx = 0;
    for (int node : nodes_)
      rx += sim.reactions()(0, node);
    samples.push_back(
        {r.time, table_.at(r.time), rx, sim.contact()->summary(), r.residual_history});
  }
  std::vector<DragSample> samples;

private:
  std::vector<int> nodes_;
  TimeTable table_;
};

} // namespace yarnsim::test
