#include "engine/run/run.hpp"

#include "engine/output/csv_writer.hpp"
#include "engine/output/results_file.hpp"
#include "engine/solver/simulation.hpp"
#include "yarnsim/version.hpp"

#include <chrono>
#include <cstdio>
#include <fmt/format.h>
#include <memory>
#include <unistd.h>

namespace yarnsim {

namespace {

using Clock = std::chrono::steady_clock;

std::string hms(double seconds) {
  if (!(seconds >= 0) || seconds > 1e7)
    return "--:--:--";
  const long s = static_cast<long>(seconds + 0.5);
  return fmt::format("{:02d}:{:02d}:{:02d}", s / 3600, (s / 60) % 60, s % 60);
}

/// One CSV per monitor, a row per completed increment.
class MonitorWriter {
public:
  MonitorWriter(const Model& model, const std::filesystem::path& dir) : model_(model) {
    for (const Monitor& m : model.monitors) {
      std::vector<std::string> cols{"time [s]"};
      switch (m.type) {
      case MonitorType::Node:
        cols.insert(cols.end(), {"x [m]", "y [m]", "z [m]", "ux [m]", "uy [m]", "uz [m]",
                                 "rx [rad]", "ry [rad]", "rz [rad]"});
        break;
      case MonitorType::NodeSet:
        cols.insert(cols.end(), {"reaction_x [N]", "reaction_y [N]", "reaction_z [N]",
                                 "reaction_mx [N m]", "reaction_my [N m]", "reaction_mz [N m]",
                                 "mean_x [m]", "mean_y [m]", "mean_z [m]"});
        break;
      case MonitorType::Element:
        for (int g = 1; g <= 2; ++g)
          for (const char* q : {"N1 [N]", "N2 [N]", "N3 [N]", "M1 [N m]", "M2 [N m]", "M3 [N m]"})
            cols.push_back(fmt::format("gauss{}_{}", g, q));
        break;
      }
      writers_.push_back(std::make_unique<output::CsvWriter>(dir / (m.name + ".csv"), cols));
    }
  }

  void write(const Simulation& sim, double time) {
    const State& s = sim.state();
    Eigen::Matrix<double, 6, Eigen::Dynamic> resultants;
    for (std::size_t k = 0; k < model_.monitors.size(); ++k) {
      const Monitor& m = model_.monitors[k];
      std::vector<double> row{time};
      if (m.type == MonitorType::Node) {
        const Eigen::Vector3d x = s.x_n.col(m.target);
        const Eigen::Vector3d u = x - model_.nodes[m.target];
        const Eigen::Vector3d r = s.rotation_n.col(m.target);
        row.insert(row.end(), {x.x(), x.y(), x.z(), u.x(), u.y(), u.z(), r.x(), r.y(), r.z()});
      } else if (m.type == MonitorType::NodeSet) {
        Eigen::Matrix<double, 6, 1> R = Eigen::Matrix<double, 6, 1>::Zero();
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        const auto& nodes = model_.node_sets[m.target].nodes;
        for (int n : nodes) {
          R += sim.reactions().col(n);
          mean += s.x_n.col(n);
        }
        mean /= std::max<std::size_t>(1, nodes.size());
        for (int i = 0; i < 6; ++i)
          row.push_back(R(i));
        row.insert(row.end(), {mean.x(), mean.y(), mean.z()});
      } else {
        if (resultants.cols() == 0)
          resultants = sim.section_resultants();
        for (int g = 0; g < 2; ++g)
          for (int i = 0; i < 6; ++i)
            row.push_back(resultants(i, 2 * m.target + g));
      }
      writers_[k]->row(row);
    }
  }

private:
  const Model& model_;
  std::vector<std::unique_ptr<output::CsvWriter>> writers_;
};

/// The force-strain curves of a biaxial test (paper §5, Fig. 3): per increment the mean strain
/// of the warp and of the weft yarns (change of the in-plane distance between a yarn's two ends
/// over its in-plane length) and the total reaction along each direction, positive in tension
/// (the mean of the pull at a yarn's two ends), then the force of every yarn.
class BiaxialCurves {
public:
  BiaxialCurves(const Model& model, const std::filesystem::path& dir)
      : model_(model), test_(*model.biaxial) {
    std::vector<std::string> cols{"time [s]", "strain_warp [-]", "strain_weft [-]",
                                  "force_warp [N]", "force_weft [N]"};
    for (std::size_t i = 0; i < test_.warp_start.size(); ++i)
      cols.push_back(fmt::format("warp{} [N]", i + 1));
    for (std::size_t i = 0; i < test_.weft_start.size(); ++i)
      cols.push_back(fmt::format("weft{} [N]", i + 1));
    csv_ = std::make_unique<output::CsvWriter>(dir / "curves.csv", cols);
  }

  /// Strains and forces of the last converged increment: strain_warp, strain_weft, force_warp,
  /// force_weft, then per yarn.
  std::vector<double> values(const Simulation& sim) const {
    std::vector<double> yarn_forces;
    double strain[2] = {0, 0}, force[2] = {0, 0};
    for (int dir = 0; dir < 2; ++dir) {
      const auto& starts = dir == 0 ? test_.warp_start : test_.weft_start;
      const auto& ends = dir == 0 ? test_.warp_end : test_.weft_end;
      const double length = dir == 0 ? test_.length_warp : test_.length_weft;
      for (std::size_t i = 0; i < starts.size(); ++i) {
        const int a = model_.node_sets[starts[i]].nodes.front();
        const int b = model_.node_sets[ends[i]].nodes.front();
        const Eigen::Vector2d d0 = (model_.nodes[b] - model_.nodes[a]).head<2>();
        const Eigen::Vector2d d = (sim.state().x_n.col(b) - sim.state().x_n.col(a)).head<2>();
        strain[dir] += (d.norm() - d0.norm()) / length / starts.size();
        const Eigen::Vector3d axis(d0.x() / d0.norm(), d0.y() / d0.norm(), 0.0);
        const double f = 0.5 * (sim.reactions().col(b).head<3>().dot(axis) -
                                sim.reactions().col(a).head<3>().dot(axis));
        force[dir] += f;
        yarn_forces.push_back(f);
      }
    }
    std::vector<double> out{strain[0], strain[1], force[0], force[1]};
    out.insert(out.end(), yarn_forces.begin(), yarn_forces.end());
    return out;
  }

  void write(const Simulation& sim, double time) {
    std::vector<double> row{time};
    const std::vector<double> v = values(sim);
    row.insert(row.end(), v.begin(), v.end());
    csv_->row(row);
  }

private:
  const Model& model_;
  const BiaxialTest& test_;
  std::unique_ptr<output::CsvWriter> csv_;
};

/// Writes results, monitors and the progress line after each converged increment.
class RunObserver final : public SimulationObserver {
public:
  RunObserver(const Model& model, const RunOptions& options, output::ResultsFile& results,
              MonitorWriter& monitors)
      : model_(model), options_(options), results_(results), monitors_(monitors),
        tty_(isatty(fileno(stderr))), start_(Clock::now()), last_print_(start_) {
    t_end_ = model.steps.back().end_time;
  }

  void on_increment(const Simulation& sim, const IncrementReport& r) override {
    monitors_.write(sim, r.time);
    if (model_.biaxial) {
      if (!curves_)
        curves_ = std::make_unique<BiaxialCurves>(model_, options_.output_dir);
      curves_->write(sim, r.time);
    }
    const ContactStage* contact = sim.contact();
    if (contact) {
      if (!contact_csv_)
        contact_csv_ = std::make_unique<output::CsvWriter>(
            options_.output_dir / "contact.csv",
            std::vector<std::string>{"time [s]", "candidates [-]", "active [-]",
                                     "max_penetration [m]", "max_force [N]"});
      const std::vector<double> row{r.time, double(contact->candidates()),
                                    double(contact->active()), contact->max_penetration(),
                                    contact->max_force()};
      contact_csv_->row(row);
      contact_status_ = fmt::format("  contacts {}  max penetration {:.3g} m", contact->active(),
                                    contact->max_penetration());
    }
    const SolutionStep& step = model_.steps[r.step];
    // Energy monitor of explicit steps (docs/input.md, "Explicit steps").
    if (step.type == StepType::Explicit && options_.progress && r.step != explicit_reported_) {
      const ExplicitStatus& x = sim.explicit_status();
      clear_line();
      fmt::print(stderr,
                 "step {} (explicit): dt = {:.4g} s, stable limit {:.4g} s (set by {}), mass "
                 "scaling added {:.4g} kg ({:.3g} % of the mass, {:.3g} % of the rotary "
                 "inertia)\n",
                 r.step + 1, x.dt, x.stable_dt, x.limited_by, x.added_mass, x.added_mass_percent,
                 x.added_rotary_percent);
      explicit_reported_ = r.step;
    }
    if (step.type == StepType::Explicit && step.energy_monitor) {
      if (!energy_csv_)
        energy_csv_ = std::make_unique<output::CsvWriter>(
            options_.output_dir / "energy.csv",
            std::vector<std::string>{"time [s]", "kinetic [J]", "internal [J]", "contact [J]",
                                     "external_work [J]", "prescribed_work [J]", "damping [J]",
                                     "balance_error [J]", "kinetic/internal [-]"});
      const EnergyBalance e = sim.energy_balance();
      const double stored = e.internal + e.contact;
      energy_csv_->row(std::vector<double>{r.time, e.kinetic, e.internal, e.contact,
                                           e.external_work, e.prescribed_work, e.damping, e.error,
                                           stored > 0 ? e.kinetic / stored : 0.0});
    }
    const bool last = r.time >= t_end_ * (1 - 1e-12);
    if (r.increment % std::max(1, step.output_every) == 0 || last) {
      output::StepResults out;
      out.increment = r.increment;
      out.time = r.time;
      out.positions = sim.state().x_n;
      out.rotations = sim.state().rotation_n;
      out.reactions = sim.reactions();
      out.section_resultants = sim.section_resultants();
      out.scalars = {{"iterations", double(r.iterations)}, {"dt", r.dt}};
      if (const ContactStage* c = sim.contact()) {
        const std::vector<ContactPoint> points = c->points();
        const int np = static_cast<int>(points.size());
        out.contacts.position.resize(3, np);
        out.contacts.normal.resize(3, np);
        out.contacts.gap.resize(np);
        out.contacts.force.resize(np);
        for (int k = 0; k < np; ++k) {
          out.contacts.position.col(k) = points[k].position;
          out.contacts.normal.col(k) = points[k].normal;
          out.contacts.gap(k) = points[k].gap;
          out.contacts.force(k) = points[k].force;
        }
        out.scalars.push_back({"active_contacts", double(np)});
        out.scalars.push_back({"max_penetration", c->max_penetration()});
      }
      if (curves_) {
        const std::vector<double> v = curves_->values(sim);
        const char* names[] = {"strain_warp", "strain_weft", "force_warp", "force_weft"};
        for (int k = 0; k < 4; ++k)
          out.scalars.push_back({names[k], v[k]});
      }
      results_.write_step(out);
    }
    iterations_ += r.iterations;
    if (options_.progress)
      print_progress(r, last);
  }

  void on_attempt_failed(const Simulation&, double time, double dt,
                         const std::string& why) override {
    if (options_.progress) {
      clear_line();
      fmt::print(stderr, "  t = {:.6g} s, dt = {:.3g} s: {}; halving the step\n", time, dt, why);
    }
  }

  void finish() {
    if (options_.progress && tty_)
      fmt::print(stderr, "\n");
  }

private:
  void clear_line() {
    if (tty_ && printed_)
      fmt::print(stderr, "\r\033[K");
  }

  void print_progress(const IncrementReport& r, bool last) {
    const auto now = Clock::now();
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    const double since = std::chrono::duration<double>(now - last_print_).count();
    // On a terminal refresh at most 10 times a second; in a log every 5 s and at the end.
    if (!last && since < (tty_ ? 0.1 : 5.0) && printed_)
      return;
    const double t0 = 0.0;
    const double done = (r.time - t0) / std::max(t_end_ - t0, 1e-300);
    const double eta = done > 0 ? elapsed * (1 - done) / done : -1;
    const std::string line =
        fmt::format("step {}/{}  t = {:.5g}/{:.5g} s  dt = {:.3g} s  increment {}  iterations {} "
                    "(total {}){}  elapsed {}  ETA {}",
                    r.step + 1, model_.steps.size(), r.time, t_end_, r.dt, r.increment,
                    r.iterations, iterations_, contact_status_, hms(elapsed), hms(eta));
    clear_line();
    if (tty_)
      fmt::print(stderr, "{}", line);
    else
      fmt::print(stderr, "{}\n", line);
    std::fflush(stderr);
    printed_ = true;
    last_print_ = now;
  }

  const Model& model_;
  const RunOptions& options_;
  output::ResultsFile& results_;
  MonitorWriter& monitors_;
  bool tty_;
  bool printed_ = false;
  Clock::time_point start_, last_print_;
  double t_end_ = 0;
  long iterations_ = 0;
  std::unique_ptr<output::CsvWriter> contact_csv_;
  std::unique_ptr<output::CsvWriter> energy_csv_; ///< explicit steps
  int explicit_reported_ = -1;                    ///< last explicit step announced
  std::unique_ptr<BiaxialCurves> curves_;
  std::string contact_status_;
};

double node_radius_of(const Section& s, double element_length) {
  if (s.shape != SectionShape::General && s.a > 0)
    return std::max(s.a, s.b);
  return 0.05 * element_length; // stiffness-only section: a thin tube for drawing
}

} // namespace

RunSummary run_model(const Model& model, const RunOptions& options) {
  const auto start = Clock::now();
  Simulation sim(model, SimulationOptions{options.linear_solver, options.stop_requested});

  output::Mesh mesh;
  const int n = static_cast<int>(model.nodes.size());
  mesh.reference_positions.resize(3, n);
  for (int i = 0; i < n; ++i)
    mesh.reference_positions.col(i) = model.nodes[i];
  mesh.node_radius = Eigen::VectorXd::Zero(n);
  for (std::size_t e = 0; e < model.elements.size(); ++e) {
    const BeamElement& el = model.elements[e];
    mesh.elements.push_back(el.nodes);
    const double length = sim.assembler().references()[e].weight.sum();
    for (int node : el.nodes)
      mesh.node_radius(node) =
          std::max(mesh.node_radius(node), node_radius_of(model.sections[el.section], length));
  }
  if (sim.contact() && options.progress)
    fmt::print(stderr,
               "{} contact: initial clearance {:.6g} mm (smallest gap the contact sees before "
               "loading{})\n",
               sim.contact()->formulations(), 1e3 * sim.initial_contact_clearance(),
               model.spline_contacts.empty() ? "" : "; the splines' effective gap");
  output::ResultsFile results(
      options.output_dir, mesh,
      output::RunMetadata{options.deck_text, options.deck_path, kVersion, options.threads});
  MonitorWriter monitors(model, options.output_dir);
  RunObserver observer(model, options, results, monitors);
  try {
    sim.run(&observer);
  } catch (const Interrupted& e) {
    observer.finish();
    results.close("interrupted", e.what());
    throw;
  } catch (const std::exception& e) {
    observer.finish();
    results.close(fmt::format("failed: {}", e.what()), e.what());
    throw;
  }
  observer.finish();
  RunSummary summary;
  summary.increments = sim.state().increment;
  summary.iterations = sim.total_iterations();
  summary.wall_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  summary.final_positions = sim.state().x_n;
  if (sim.contact())
    summary.final_contacts = sim.contact()->points();
  summary.linear_solver = sim.linear_solver_name();
  results.close("completed",
                fmt::format("{} increments, {} Newton iterations, {:.3f} s, linear solver {}",
                            summary.increments, summary.iterations, summary.wall_seconds,
                            sim.linear_solver_name()));
  return summary;
}

} // namespace yarnsim
