#include "engine/run/run.hpp"

#include "engine/output/checkpoint_file.hpp"
#include "engine/output/csv_reader.hpp"
#include "engine/output/csv_writer.hpp"
#include "engine/output/results_file.hpp"
#include "engine/output/serial_writer.hpp"
#include "engine/run/check.hpp"
#include "engine/solver/checkpoint.hpp"
#include "engine/solver/distributed.hpp"
#include "engine/solver/simulation.hpp"
#include "engine/textile/biaxial.hpp"
#include "engine/textile/shear_kinematics.hpp"
#include "engine/textile/shear_tests.hpp"
#include "yarnsim/version.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <deque>
#include <fmt/format.h>
#include <initializer_list>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <system_error>
#include <unistd.h>

namespace yarnsim {

namespace {

using Clock = std::chrono::steady_clock;

/// --stop-after N (0: none): stops the run, as interrupted, after the first increment at or
/// beyond increment N unless it is the run's last.
void stop_after(int n, const IncrementReport& r, bool last) {
  if (n > 0 && r.increment >= n && !last)
    throw Interrupted(fmt::format("stopped at t = {:.6g} s after increment {} (--stop-after {})",
                                  r.time, r.increment, n));
}

std::string hms(double seconds) {
  if (!(seconds >= 0) || seconds > 1e7)
    return "--:--:--";
  const long s = static_cast<long>(seconds + 0.5);
  return fmt::format("{:02d}:{:02d}:{:02d}", s / 3600, (s / 60) % 60, s % 60);
}

/// A CSV file of a run: its name in the output folder and its columns with units.
struct CsvFile {
  std::string name;
  std::vector<std::string> columns;
};

/// A row for a CSV file, computed by the solver thread and written by the writer: numbers, or
/// cells already formatted when the row holds names (cells not empty).
struct CsvRow {
  CsvRow(const CsvFile* f, std::vector<double> v) : file(f), values(std::move(v)) {}
  CsvRow(const CsvFile* f, std::vector<std::string> c) : file(f), cells(std::move(c)) {}

  const CsvFile* file;
  std::vector<double> values;
  std::vector<std::string> cells;
};

/// The CSV files of a run, each created on its first row; a restart goes on with those the
/// checkpoint lists, as they were then. After construction only the writer thread uses it.
class CsvFiles {
public:
  CsvFiles(std::filesystem::path dir, const std::map<std::string, long>& resume)
      : dir_(std::move(dir)) {
    for (const auto& [name, rows] : resume)
      files_.emplace(
          name, std::make_unique<output::CsvWriter>(dir_ / name, std::vector<std::string>{}, rows));
  }

  /// Creates the file now (with its header) unless it is there already.
  void open(const CsvFile& file) {
    if (!files_.count(file.name))
      files_.emplace(file.name,
                     std::make_unique<output::CsvWriter>(dir_ / file.name, file.columns));
  }

  void write(const CsvRow& row) {
    open(*row.file);
    if (row.cells.empty())
      files_.at(row.file->name)->row(row.values);
    else
      files_.at(row.file->name)->row(row.cells);
  }

  /// Rows per file, for the checkpoint.
  std::map<std::string, long> rows() const {
    std::map<std::string, long> out;
    for (const auto& [name, writer] : files_)
      out[name] = writer->rows();
    return out;
  }

private:
  std::filesystem::path dir_;
  std::map<std::string, std::unique_ptr<output::CsvWriter>> files_;
};

/// One CSV per monitor, a row per completed increment.
class Monitors {
public:
  explicit Monitors(const Model& model) : model_(model) {
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
      files_.push_back({m.name + ".csv", std::move(cols)});
    }
  }

  const std::vector<CsvFile>& files() const { return files_; }

  /// The monitors' rows of the last converged increment.
  void rows(const Simulation& sim, double time, std::vector<CsvRow>& out) const {
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
      out.push_back({&files_[k], std::move(row)});
    }
  }

private:
  const Model& model_;
  std::vector<CsvFile> files_;
};

/// The curves of a fabric test in curves.csv, a row per increment, and the scalars of its
/// first columns in results.h5.
class TestCurves {
public:
  virtual ~TestCurves() = default;
  /// The values of the last converged increment, in the order of the columns after time.
  virtual std::vector<double> values(const Simulation& sim) = 0;
  /// Names of the leading values that results.h5 also stores per output step.
  virtual std::vector<std::string> scalar_names() const = 0;
  /// Said once at the end of the run (empty: nothing).
  virtual std::string closing_note() const { return {}; }
  /// A restart: the curves' first `rows` data rows in `file` (curves.csv as the checkpoint left
  /// it) are the run's history so far. Throws std::runtime_error when the file cannot give it.
  virtual void resume(const std::filesystem::path& /*file*/, long /*rows*/) {}

  /// The row of curves.csv for values v of time.
  CsvRow row(double time, const std::vector<double>& v) const {
    std::vector<double> row{time};
    row.insert(row.end(), v.begin(), v.end());
    return {&file_, std::move(row)};
  }

protected:
  CsvFile file_{"curves.csv", {"time [s]"}};
};

/// The force-strain curves of a biaxial test (paper §5, Fig. 3): per increment
/// the reading of the test (textile::read_biaxial), then the force of every yarn.
class BiaxialCurves final : public TestCurves {
public:
  explicit BiaxialCurves(const Model& model) : model_(model), test_(*model.biaxial) {
    file_.columns.insert(file_.columns.end(), {"strain_warp [-]", "strain_weft [-]",
                                               "force_warp [N]", "force_weft [N]"});
    for (std::size_t i = 0; i < test_.warp_start.size(); ++i)
      file_.columns.push_back(fmt::format("warp{} [N]", i + 1));
    for (std::size_t i = 0; i < test_.weft_start.size(); ++i)
      file_.columns.push_back(fmt::format("weft{} [N]", i + 1));
    file_.columns.insert(file_.columns.end(), {"crimp_warp [-]", "crimp_weft [-]"});
  }

  /// Strains and forces of the last converged increment: strain_warp, strain_weft, force_warp,
  /// force_weft, then per yarn, then the crimps. A uniaxial test's free direction has no
  /// prescribed DOF: its forces are 0.
  std::vector<double> values(const Simulation& sim) override {
    const textile::BiaxialReading r =
        textile::read_biaxial(model_, sim.state().x_n, sim.reactions());
    std::vector<double> out{r.strain_warp, r.strain_weft, r.force_warp, r.force_weft};
    out.insert(out.end(), r.yarn_forces.begin(), r.yarn_forces.end());
    out.insert(out.end(), {r.crimp_warp, r.crimp_weft});
    return out;
  }

  std::vector<std::string> scalar_names() const override {
    return {"strain_warp", "strain_weft", "force_warp", "force_weft"};
  }

private:
  const Model& model_;
  const BiaxialTest& test_;
};

/// Whether a step of the model has mass-proportional damping on a path that counts its
/// dissipation (dynamic and explicit steps).
bool has_mass_damping(const Model& model) {
  for (const SolutionStep& step : model.steps)
    if (step.type != StepType::Static && (step.rayleigh_mass > 0 || step.rayleigh_out_of_plane > 0))
      return true;
  return false;
}

/// The first `rows` rows of curves.csv of a run being restarted, which must hold the columns
/// `names` (`test` names the test's curves in the error).
output::CsvTable resumed_curves(const std::filesystem::path& file, long rows,
                                std::initializer_list<const char*> names, const char* test) {
  output::CsvTable table = output::read_csv_table(file, rows);
  for (const char* name : names)
    if (table.column(name) < 0)
      throw std::runtime_error(
          fmt::format("{} has no column '{}' to resume {} curves", file.string(), name, test));
  return table;
}

/// The curves of a picture frame (docs/shear-tests.md): the crosshead's travel and force, the
/// frame's shear angle and the one measured on the central yarns, the benchmark's shear forces,
/// the stored energies and, with contact between yarns of one direction, how many of those
/// contacts are active (locking).
class PictureFrameCurves final : public TestCurves {
public:
  explicit PictureFrameCurves(const Model& model) : model_(model), test_(*model.picture_frame) {
    file_.columns.insert(file_.columns.end(),
                         {"displacement [m]", "force [N]", "frame_angle [deg]",
                          "measured_angle [deg]", "angle_spread [deg]", "shear_force [N]",
                          "normalised_shear_force [N/m]", "strain_energy [J]", "contact_energy [J]",
                          "kinetic_energy [J]"});
    for (const SplineContactDefinition& c : model.spline_contacts)
      parallel_ = parallel_ || (c.self_contact && !c.within_spline);
    if (parallel_)
      file_.columns.push_back("parallel_contacts [-]");
    friction_ = has_friction(model);
    if (friction_)
      file_.columns.push_back("friction_dissipation [J]");
    damping_ = has_mass_damping(model);
    if (damping_)
      file_.columns.push_back("damping_dissipation [J]");
  }

  std::vector<double> values(const Simulation& sim) override {
    const double time = sim.state().time;
    const textile::PictureFrameReading r =
        textile::read_picture_frame(model_, time, sim.state().x_n, sim.reactions());
    std::vector<double> out{r.displacement,
                            r.force,
                            r.frame_angle,
                            r.measured.mean,
                            r.measured.spread,
                            r.shear_force,
                            r.normalised_shear_force,
                            sim.strain_energy(),
                            sim.contact_energy(),
                            sim.kinetic_energy()};
    if (parallel_) {
      long n = 0;
      if (const ContactStage* contact = sim.contact())
        for (const ContactPoint& p : contact->points())
          if (!p.surface && model_.spline_contacts[p.definition].self_contact &&
              !model_.spline_contacts[p.definition].within_spline)
            ++n;
      out.push_back(static_cast<double>(n));
      if (n > 0 && !locked_at_)
        locked_at_ = r.frame_angle;
    }
    if (friction_)
      out.push_back(sim.contact() ? sim.contact()->summary().dissipation : 0.0);
    if (damping_)
      out.push_back(sim.energy_balance().damping);
    return out;
  }

  std::vector<std::string> scalar_names() const override {
    return {"displacement", "force", "frame_angle", "measured_angle"};
  }

  std::string closing_note() const override {
    if (!parallel_)
      return {};
    const double geometry = test_.locking_angle * 180 / std::numbers::pi;
    if (locked_at_)
      return fmt::format("neighbouring parallel yarns first touched at a frame angle of {:.2f} "
                         "degrees (the yarn widths and spacings predict {:.2f} degrees)",
                         *locked_at_, geometry);
    return fmt::format("neighbouring parallel yarns did not touch in this run (the yarn widths "
                       "and spacings predict it at {:.2f} degrees)",
                       geometry);
  }

  /// The frame angle where parallel yarns first touched, from the rows kept: a restart reports
  /// the locking the run before it found.
  void resume(const std::filesystem::path& file, long rows) override {
    if (!parallel_)
      return;
    const output::CsvTable table = resumed_curves(
        file, rows, {"frame_angle [deg]", "parallel_contacts [-]"}, "the picture frame's");
    const std::vector<double> angle = table.numbers("frame_angle [deg]");
    const std::vector<double> parallel = table.numbers("parallel_contacts [-]");
    for (std::size_t k = 0; k < angle.size() && !locked_at_; ++k)
      if (parallel[k] > 0)
        locked_at_ = angle[k];
  }

private:
  const Model& model_;
  const PictureFrameTest& test_;
  bool parallel_ = false;
  bool friction_ = false;
  bool damping_ = false;
  std::optional<double> locked_at_; ///< degrees, the frame angle of the first parallel contact
};

/// The curves of a bias extension (docs/shear-tests.md): the top clamp's travel and pull, the
/// central zone's ideal and measured shear angles, the benchmark's normalised shear force by its
/// energy method (marched over the increments so far: each value needs only the curve below its
/// angle), the stored energies and, with friction, the energy it dissipated.
class BiasExtensionCurves final : public TestCurves {
public:
  explicit BiasExtensionCurves(const Model& model)
      : model_(model), test_(*model.bias_extension), friction_(has_friction(model)),
        damping_(has_mass_damping(model)) {
    file_.columns.insert(file_.columns.end(), {"displacement [m]", "force [N]", "ideal_angle [deg]",
                                               "measured_angle [deg]", "angle_spread [deg]",
                                               "normalised_shear_force [N/m]", "strain_energy [J]",
                                               "contact_energy [J]", "kinetic_energy [J]"});
    if (friction_)
      file_.columns.push_back("friction_dissipation [J]");
    if (damping_)
      file_.columns.push_back("damping_dissipation [J]");
    // The unloaded specimen: the energy method's start.
    gamma_.push_back(0.0);
    force_.push_back(0.0);
  }

  std::vector<double> values(const Simulation& sim) override {
    const textile::BiasExtensionReading r =
        textile::read_bias_extension(model_, sim.state().time, sim.state().x_n, sim.reactions());
    const double gamma = r.ideal_angle * std::numbers::pi / 180;
    // At gamma = 0 the method's fixed point F / (2 W); a repeated angle has no value of its own.
    double normalised =
        gamma == 0 ? r.force / (2 * test_.width) : std::numeric_limits<double>::quiet_NaN();
    if (gamma > gamma_.back()) {
      gamma_.push_back(gamma);
      force_.push_back(r.force);
      normalised =
          textile::bias_extension_normalised_force(gamma_, force_, test_.height, test_.width)
              .back();
    }
    std::vector<double> out{
        r.displacement,      r.force,    r.ideal_angle,       r.measured.mean,
        r.measured.spread,   normalised, sim.strain_energy(), sim.contact_energy(),
        sim.kinetic_energy()};
    if (friction_)
      out.push_back(sim.contact() ? sim.contact()->summary().dissipation : 0.0);
    if (damping_)
      out.push_back(sim.energy_balance().damping);
    return out;
  }

  std::vector<std::string> scalar_names() const override {
    return {"displacement", "force", "ideal_angle", "measured_angle"};
  }

  /// The ideal angles and forces of the rows kept: the energy method marches over them.
  void resume(const std::filesystem::path& file, long rows) override {
    const output::CsvTable table =
        resumed_curves(file, rows, {"ideal_angle [deg]", "force [N]"}, "the bias extension's");
    const std::vector<double> angle = table.numbers("ideal_angle [deg]");
    const std::vector<double> force = table.numbers("force [N]");
    for (std::size_t k = 0; k < angle.size(); ++k) {
      const double gamma = angle[k] * std::numbers::pi / 180;
      if (gamma > gamma_.back()) {
        gamma_.push_back(gamma);
        force_.push_back(force[k]);
      }
    }
  }

private:
  const Model& model_;
  const BiasExtensionTest& test_;
  bool friction_;
  bool damping_;
  std::vector<double> gamma_, force_; ///< rad and N, the curve so far (from the unloaded start)
};

/// The curves of the model's test, if it has one.
std::unique_ptr<TestCurves> test_curves(const Model& model) {
  if (model.biaxial)
    return std::make_unique<BiaxialCurves>(model);
  if (model.picture_frame)
    return std::make_unique<PictureFrameCurves>(model);
  if (model.bias_extension)
    return std::make_unique<BiasExtensionCurves>(model);
  return nullptr;
}

/// contact_points.csv: a row per active contact point, in the contact stage's order (spline
/// contacts, then surface contacts; by definition, then by pair), so the file does not depend on
/// the thread count.
class ContactPointsFile {
public:
  explicit ContactPointsFile(const Model& model)
      : model_(model), friction_(has_friction(model)), torsion_(has_torsional_friction(model)) {
    file_.name = "contact_points.csv";
    file_.columns = {"increment [-]", "time [s]", "contact", "a",     "a_segment [-]", "b",
                     "b_segment [-]", "x [m]",    "y [m]",   "z [m]", "gap [m]",       "force [N]",
                     "nx [-]",        "ny [-]",   "nz [-]"};
    // With friction: the tangential force on a, the state and the slip since the point closed.
    if (friction_)
      file_.columns.insert(file_.columns.end(),
                           {"ftx [N]", "fty [N]", "ftz [N]", "state", "slip [m]"});
    // With torsional friction: the torque about the normal, the twist's state and its slip.
    if (torsion_)
      file_.columns.insert(file_.columns.end(),
                           {"torque [N m]", "twist_state", "twist_slip [rad]"});
  }

  const CsvFile& file() const { return file_; }

  /// The rows of the active contact points of the last converged state of increment (time s).
  /// Segments are numbered from 1: along the spline for spline contact, the deck's element
  /// number for surface contact.
  void rows(const ContactStage& contact, int increment, double time,
            std::vector<CsvRow>& out) const {
    for (const ContactPoint& p : contact.points()) {
      const std::string& definition = p.surface ? model_.surface_contacts[p.definition].name
                                                : model_.spline_contacts[p.definition].name;
      auto body = [&](int k) -> const std::string& {
        return p.surface ? model_.surfaces[p.body[k]].name : model_.splines[p.body[k]].name;
      };
      auto number = [](double v) { return fmt::format("{}", v); };
      std::vector<std::string> cells{fmt::format("{}", increment),
                                     number(time),
                                     definition,
                                     body(0),
                                     fmt::format("{}", p.segment[0] + 1),
                                     body(1),
                                     fmt::format("{}", p.segment[1] + 1),
                                     number(p.position.x()),
                                     number(p.position.y()),
                                     number(p.position.z()),
                                     number(p.gap),
                                     number(p.force),
                                     number(p.normal.x()),
                                     number(p.normal.y()),
                                     number(p.normal.z())};
      if (friction_) {
        static constexpr const char* kState[] = {"none", "stick", "slip"};
        cells.insert(cells.end(),
                     {number(p.tangential_force.x()), number(p.tangential_force.y()),
                      number(p.tangential_force.z()), kState[p.friction], number(p.slip)});
      }
      if (torsion_) {
        static constexpr const char* kState[] = {"none", "stick", "slip"};
        cells.insert(cells.end(), {number(p.torque), kState[p.twist], number(p.twist_slip)});
      }
      out.emplace_back(&file_, std::move(cells));
    }
  }

private:
  const Model& model_;
  bool friction_;
  bool torsion_;
  CsvFile file_;
};

/// Columns of contact.csv.
std::vector<std::string> contact_csv_columns(bool friction, bool torsion) {
  std::vector<std::string> columns{"time [s]",      "candidates [-]",
                                   "active [-]",    "max_penetration [m]",
                                   "max_force [N]", "total_force [N]"};
  if (friction)
    columns.insert(columns.end(),
                   {"stick [-]", "slip [-]", "tangential_force [N]", "friction_dissipation [J]"});
  if (torsion)
    columns.insert(columns.end(), {"twist_stick [-]", "twist_slip [-]", "friction_torque [N m]"});
  return columns;
}

/// Everything a completed increment writes, computed by the solver thread.
struct IncrementOutput {
  std::vector<CsvRow> rows;
  std::optional<output::StepResults> step;
  std::shared_ptr<const SimulationCheckpoint> checkpoint; ///< null: not written this time
};

/// Hands each converged increment's results, monitor rows and checkpoint to the serial writer,
/// and prints the progress line.
class RunObserver final : public SimulationObserver {
public:
  RunObserver(const Model& model, const RunOptions& options, const std::string& deck_hash,
              output::ResultsFile& results, const Monitors& monitors,
              const ContactPointsFile& contact_points, CsvFiles& csv, output::SerialWriter& writer)
      : model_(model), options_(options), deck_hash_(deck_hash), results_(results),
        monitors_(monitors), csv_(csv), writer_(writer), tty_(isatty(fileno(stderr))),
        start_(Clock::now()), last_print_(start_), contact_points_(contact_points) {
    t_end_ = model.steps.back().end_time;
    curves_ = test_curves(model);
  }

  /// A restart: the test's curves so far, from the rows of curves.csv the checkpoint kept.
  void resume_curves(const std::map<std::string, long>& csv_rows) {
    if (!curves_)
      return;
    const auto it = csv_rows.find("curves.csv");
    curves_->resume(options_.output_dir / "curves.csv", it == csv_rows.end() ? 0 : it->second);
  }

  /// The rows of the initial state (time 0, increment 0) in every CSV file the run writes, before
  /// its first increment: the reference configuration, as the monitors read it then (zero
  /// displacements, rotations, reactions and section forces; the contacts of the initial
  /// configuration). Not called on a restart: its files hold these rows already.
  void write_initial_rows(const Simulation& sim) {
    auto out = std::make_shared<IncrementOutput>();
    std::vector<double> curve_values;
    csv_rows(sim, 0, 0.0, curve_values, out->rows);
    const bool energy = std::any_of(model_.steps.begin(), model_.steps.end(), [](const auto& s) {
      return s.type == StepType::Explicit && s.energy_monitor;
    });
    if (energy) {
      // The balance error is measured from its value at the start of an explicit step; before
      // any step it is zero by that definition.
      out->rows.push_back(energy_row(0.0, sim.energy_balance(), 0.0));
    }
    writer_.post([this, out] {
      for (const CsvRow& row : out->rows)
        csv_.write(row);
    });
  }

  void on_increment(const Simulation& sim, const IncrementReport& r) override {
    auto out = std::make_shared<IncrementOutput>();
    std::vector<double> curve_values;
    csv_rows(sim, r.increment, r.time, curve_values, out->rows);
    const ContactStage* contact = sim.contact();
    if (contact)
      contact_status_ = fmt::format("  contacts {}  max penetration {:.3g} m", contact->active(),
                                    contact->max_penetration());
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
      const EnergyBalance e = sim.energy_balance();
      out->rows.push_back(energy_row(r.time, e, e.error));
    }
    const bool last = r.time >= t_end_ * (1 - 1e-12);
    if (r.increment % std::max(1, step.output_every) == 0 || last) {
      output::StepResults& o = out->step.emplace();
      o.increment = r.increment;
      o.time = r.time;
      o.positions = sim.state().x_n;
      o.rotations = sim.state().rotation_n;
      o.reactions = sim.reactions();
      o.section_resultants = sim.section_resultants();
      o.scalars = {{"iterations", double(r.iterations)}, {"dt", r.dt}};
      if (contact) {
        const std::vector<ContactPoint> points = contact->points();
        const int np = static_cast<int>(points.size());
        o.contacts.position.resize(3, np);
        o.contacts.normal.resize(3, np);
        o.contacts.gap.resize(np);
        o.contacts.force.resize(np);
        for (int k = 0; k < np; ++k) {
          o.contacts.position.col(k) = points[k].position;
          o.contacts.normal.col(k) = points[k].normal;
          o.contacts.gap(k) = points[k].gap;
          o.contacts.force(k) = points[k].force;
        }
        if (friction_) {
          o.contacts.tangential_force.resize(3, np);
          o.contacts.stick.resize(np);
          o.contacts.slip.resize(np);
          for (int k = 0; k < np; ++k) {
            o.contacts.tangential_force.col(k) = points[k].tangential_force;
            o.contacts.stick(k) = points[k].friction == 1 ? 1.0 : 0.0;
            o.contacts.slip(k) = points[k].slip;
          }
        }
        if (torsion_) {
          o.contacts.torque.resize(np);
          for (int k = 0; k < np; ++k)
            o.contacts.torque(k) = points[k].torque;
        }
        o.scalars.push_back({"active_contacts", double(np)});
        o.scalars.push_back({"max_penetration", contact->max_penetration()});
      }
      if (curves_) {
        const std::vector<std::string> names = curves_->scalar_names();
        for (std::size_t k = 0; k < names.size(); ++k)
          o.scalars.push_back({names[k], curve_values[k]});
      }
    }
    // The checkpoint is taken after every increment, written at most once a second and after the
    // last increment when the run ends (flush_checkpoint): a run killed outright loses at most
    // a second of work, one that stops otherwise none.
    latest_ = std::make_shared<const SimulationCheckpoint>(sim.checkpoint());
    const auto now = Clock::now();
    latest_written_ = now - last_checkpoint_ >= kCheckpointInterval;
    if (latest_written_) {
      out->checkpoint = latest_;
      last_checkpoint_ = now;
    }
    // Written in this order by the writer thread while the solver goes on: the rows, the step,
    // then the checkpoint, which thus never claims output that is not on disk.
    writer_.post([this, out] {
      for (const CsvRow& row : out->rows)
        csv_.write(row);
      if (out->step)
        results_.write_step(*out->step);
      if (out->checkpoint)
        write_checkpoint(*out->checkpoint);
    });
    if (options_.progress)
      print_progress(r, sim.total_iterations(), last);
    stop_after(options_.stop_after, r, last);
  }

  void on_notice(const Simulation&, const std::string& what) override {
    clear_line();
    fmt::print(stderr, "note: {}\n", what);
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
    if (curves_)
      if (const std::string note = curves_->closing_note(); !note.empty())
        fmt::print(stderr, "note: {}\n", note);
  }

  /// Queues the checkpoint of the last completed increment unless it was written already.
  void flush_checkpoint() {
    if (!latest_ || latest_written_)
      return;
    writer_.post([this, checkpoint = latest_] { write_checkpoint(*checkpoint); });
    latest_written_ = true;
  }

private:
  static constexpr std::chrono::seconds kCheckpointInterval{1};

  /// The rows of the monitors, curves.csv, contact.csv and contact_points.csv for the
  /// simulation's last converged state, increment at time (s); curve_values gets the test's
  /// reading when there is one.
  void csv_rows(const Simulation& sim, int increment, double time,
                std::vector<double>& curve_values, std::vector<CsvRow>& rows) const {
    monitors_.rows(sim, time, rows);
    if (curves_) {
      curve_values = curves_->values(sim);
      rows.push_back(curves_->row(time, curve_values));
    }
    if (const ContactStage* contact = sim.contact()) {
      const ContactSummary s = contact->summary();
      std::vector<double> values{
          time,        double(s.candidates), double(s.active), s.max_penetration,
          s.max_force, s.total_force};
      if (friction_)
        values.insert(values.end(),
                      {double(s.stick), double(s.slip), s.tangential_force, s.dissipation});
      if (torsion_)
        values.insert(values.end(), {double(s.twist_stick), double(s.twist_slip), s.torque});
      rows.push_back({&contact_csv_, std::move(values)});
      contact_points_.rows(*contact, increment, time, rows);
    }
  }

  /// On the writer thread, after the output of the increment it was taken at.
  void write_checkpoint(const SimulationCheckpoint& checkpoint) {
    output::write_checkpoint(options_.output_dir, checkpoint,
                             {results_.steps_written(), csv_.rows(), deck_hash_});
  }

  void clear_line() {
    if (tty_ && printed_)
      fmt::print(stderr, "\r\033[K");
  }

  /// total_iterations: the run's Newton iterations, failed attempts' included (as the closing
  /// `done` line counts them).
  void print_progress(const IncrementReport& r, int total_iterations, bool last) {
    const auto now = Clock::now();
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    const double since = std::chrono::duration<double>(now - last_print_).count();
    // On a terminal refresh at most 10 times a second; in a log every 5 s and at the end.
    if (!last && since < (tty_ ? 0.1 : 5.0) && printed_)
      return;
    const double t0 = 0.0;
    const double done = (r.time - t0) / std::max(t_end_ - t0, 1e-300);
    const double eta = done > 0 ? elapsed * (1 - done) / done : -1;
    const std::string line = fmt::format(
        "step {}/{}  t = {:.5g}/{:.5g} s  dt = {:.3g} s  increment {}  iterations {} "
        "({}total {}){}  elapsed {}  ETA {}",
        r.step + 1, model_.steps.size(), r.time, t_end_, r.dt, r.increment, r.iterations,
        r.closing_iterations > 0
            ? fmt::format("{} of them closing crossings; ", r.closing_iterations)
            : std::string(),
        total_iterations, contact_status_, hms(elapsed), hms(eta));
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
  const std::string& deck_hash_;
  output::ResultsFile& results_;
  const Monitors& monitors_;
  CsvFiles& csv_;
  output::SerialWriter& writer_;
  bool tty_;
  bool printed_ = false;
  Clock::time_point start_, last_print_;
  double t_end_ = 0;
  const bool friction_ = has_friction(model_);
  const bool torsion_ = has_torsional_friction(model_);
  /// With friction also: points in stick and in slip, the summed friction force and the energy
  /// friction has dissipated since the start (torsional friction's included); with torsional
  /// friction also: crossings whose twist sticks and slips, and the summed friction torque.
  const CsvFile contact_csv_{"contact.csv", contact_csv_columns(friction_, torsion_)};
  const ContactPointsFile& contact_points_;
  /// Explicit steps; with friction also the energy it dissipated.
  const CsvFile energy_csv_{
      "energy.csv",
      friction_
          ? std::vector<std::string>{"time [s]", "kinetic [J]", "internal [J]", "contact [J]",
                                     "external_work [J]", "prescribed_work [J]", "damping [J]",
                                     "friction [J]", "balance_error [J]", "kinetic/internal [-]"}
          : std::vector<std::string>{"time [s]", "kinetic [J]", "internal [J]", "contact [J]",
                                     "external_work [J]", "prescribed_work [J]", "damping [J]",
                                     "balance_error [J]", "kinetic/internal [-]"}};

  CsvRow energy_row(double time, const EnergyBalance& e, double error) const {
    const double stored = e.internal + e.contact;
    std::vector<double> v{
        time, e.kinetic, e.internal, e.contact, e.external_work, e.prescribed_work, e.damping};
    if (friction_)
      v.push_back(e.friction);
    v.insert(v.end(), {error, stored > 0 ? e.kinetic / stored : 0.0});
    return {&energy_csv_, std::move(v)};
  }
  int explicit_reported_ = -1; ///< last explicit step announced
  std::unique_ptr<TestCurves> curves_;
  std::string contact_status_;
  std::shared_ptr<const SimulationCheckpoint> latest_; ///< of the last completed increment
  bool latest_written_ = false;
  Clock::time_point last_checkpoint_{}; ///< when one was last handed to the writer
};

double node_radius_of(const Section& s, double element_length) {
  if (s.shape != SectionShape::General && s.a > 0)
    return std::max(s.a, s.b);
  return 0.05 * element_length; // stiffness-only section: a thin tube for drawing
}

/// The section drawn on the yarn surface (results.xdmf): the contact's shape, or for a
/// stiffness-only section the thin tube of node_radius_of.
output::NodeSection drawn_section(const Section& s, double element_length) {
  switch (s.a > 0 ? s.shape : SectionShape::General) {
  case SectionShape::Circle:
    return {s.a, s.a, 2.0};
  case SectionShape::Ellipse:
    return {s.a, s.b, 2.0};
  case SectionShape::SuperEllipse:
    return {s.a, s.b, s.exponent};
  case SectionShape::General:
    break;
  }
  const double r = node_radius_of(s, element_length);
  return {r, r, 2.0};
}

/// The run's simulation, from the start or from the restart's checkpoint.
std::unique_ptr<Simulation>
make_simulation(const Model& model, const RunOptions& options,
                const std::optional<output::StoredCheckpoint>& restart) {
  const SimulationOptions sim_options{options.linear_solver, options.stop_requested};
  return restart ? std::make_unique<Simulation>(model, sim_options, restart->simulation)
                 : std::make_unique<Simulation>(model, sim_options);
}

/// What a completed run reports: its size, wall time since start, end state and energies.
RunSummary summarise(const Simulation& sim, Clock::time_point start) {
  RunSummary summary;
  summary.increments = sim.state().increment;
  summary.iterations = sim.total_iterations();
  summary.simplified_trials = sim.simplified_trials();
  summary.wall_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  summary.final_positions = sim.state().x_n;
  if (sim.contact())
    summary.final_contacts = sim.contact()->points();
  summary.linear_solver = sim.linear_solver_name();
  const EnergyBalance energy = sim.energy_balance();
  summary.damping_dissipation = energy.damping;
  summary.stored_energy = energy.internal + energy.contact;
  summary.stage_times = sim.stage_times();
  return summary;
}

/// Reads the checkpoint of options.restart_from and checks it belongs to this deck. Throws
/// output::RestartError.
output::StoredCheckpoint read_restart(const Model& model, const RunOptions& options,
                                      const std::string& deck_hash) {
  const std::filesystem::path& from = options.restart_from;
  output::StoredCheckpoint c = output::read_checkpoint(from);
  if (c.outputs.deck_hash != deck_hash)
    throw output::RestartError(fmt::format(
        "cannot restart from {}: its run was made from another deck (fingerprint {}, this deck "
        "{}: the text or the geometry it reads differ); a restart goes on with the same deck",
        from.string(), c.outputs.deck_hash, deck_hash));
  // Versions before surface contact restarts wrote checkpoints without its state.
  if (!model.surface_contacts.empty() && !c.simulation.surface_contact)
    throw output::RestartError(fmt::format(
        "cannot restart from {}: its checkpoint holds no surface contact state (contact '{}'; "
        "it was written by an earlier version, which did not save it)",
        from.string(), model.surface_contacts.front().name));
  return c;
}

/// read_restart, then puts the earlier run's results.h5, CSV files and checkpoint into the
/// output folder when it is another one. Throws output::RestartError.
output::StoredCheckpoint prepare_restart(const Model& model, const RunOptions& options,
                                         const std::string& deck_hash) {
  output::StoredCheckpoint c = read_restart(model, options, deck_hash);
  const std::filesystem::path& from = options.restart_from;
  const std::filesystem::path& to = options.output_dir;
  std::error_code ec;
  if (std::filesystem::exists(to) && std::filesystem::equivalent(from, to, ec))
    return c;
  std::filesystem::create_directories(to, ec);
  if (ec)
    throw std::runtime_error(
        fmt::format("cannot create the output folder {}: {}", to.string(), ec.message()));
  std::vector<std::string> files{"results.h5", output::kCheckpointName};
  for (const auto& [name, rows] : c.outputs.csv_rows)
    files.push_back(name);
  for (const std::string& name : files) {
    std::filesystem::copy_file(from / name, to / name,
                               std::filesystem::copy_options::overwrite_existing, ec);
    if (ec)
      throw output::RestartError(fmt::format("cannot restart from {}: copying {} to {}: {}",
                                             from.string(), name, to.string(), ec.message()));
  }
  return c;
}

} // namespace

RunSummary run_model(const Model& model, const RunOptions& options) {
  const auto start = Clock::now();
  const std::string deck_hash = output::deck_fingerprint(options.deck_text, model);
  std::optional<output::StoredCheckpoint> restart;
  if (!options.restart_from.empty())
    restart = prepare_restart(model, options, deck_hash);
  const std::unique_ptr<Simulation> simulation = make_simulation(model, options, restart);
  Simulation& sim = *simulation;

  output::Mesh mesh;
  const int n = static_cast<int>(model.nodes.size());
  mesh.reference_positions.resize(3, n);
  for (int i = 0; i < n; ++i)
    mesh.reference_positions.col(i) = model.nodes[i];
  mesh.node_radius = Eigen::VectorXd::Zero(n);
  mesh.node_sections.resize(n);
  for (std::size_t e = 0; e < model.elements.size(); ++e) {
    const BeamElement& el = model.elements[e];
    mesh.elements.push_back(el.nodes);
    const double length = sim.assembler().references()[e].weight.sum();
    const Section& section = model.sections[el.section];
    for (int node : el.nodes) {
      mesh.node_radius(node) = std::max(mesh.node_radius(node), node_radius_of(section, length));
      mesh.node_sections[node] = drawn_section(section, length);
    }
  }
  // Where a surface contact holds an element, its surface is what the contact sees.
  for (const Surface& surface : model.surfaces)
    for (int e : surface.elements)
      for (int node : model.elements[e].nodes)
        mesh.node_sections[node] = {surface.a, surface.b, surface.exponent};
  mesh.reference_triads = sim.reference_triads();
  for (const Spline& spline : model.splines)
    mesh.contact_tubes.push_back({spline.nodes, spline.radius});
  if (sim.contact() && options.progress)
    fmt::print(stderr, "{}", initial_clearance_line(sim));
  // A solver asked for that takes the whole tangent gives every process the same answers, but
  // its factorisation, the largest cost of a large model, is not shared out.
  if (distributed::size() > 1 && !sim.shares_factorisation())
    fmt::print(stderr,
               "linear solver {}: each of the {} processes factorises the whole tangent (mumps "
               "and petsc share the factorisation out)\n",
               sim.linear_solver_name(), distributed::size());
  const output::RunMetadata meta{options.deck_text, options.deck_path, kVersion, options.threads};
  output::ResultsFile results =
      restart ? output::ResultsFile(options.output_dir, mesh, meta,
                                    output::ResultsFile::Continue{restart->outputs.results_steps})
              : output::ResultsFile(options.output_dir, mesh, meta);
  const Monitors monitors(model);
  CsvFiles csv(options.output_dir,
               restart ? restart->outputs.csv_rows : std::map<std::string, long>{});
  for (const CsvFile& file : monitors.files())
    csv.open(file);
  // contact_points.csv exists with its header even while no contact is active.
  const ContactPointsFile contact_points(model);
  if (sim.contact())
    csv.open(contact_points.file());
  if (restart)
    fmt::print(stderr, "restarting from {} after increment {} at t = {:.6g} s\n",
               options.restart_from.string(), sim.state().increment, sim.state().time);
  // Declared after the files its tasks write: destroyed (drained) before them.
  output::SerialWriter writer;
  RunObserver observer(model, options, deck_hash, results, monitors, contact_points, csv, writer);
  if (!restart)
    observer.write_initial_rows(sim);
  else
    observer.resume_curves(restart->outputs.csv_rows);
  // Every completed increment on disk before the files are closed; an error of the writer wins
  // over the reason the run stopped, since the files are then incomplete.
  auto drain = [&writer, &observer]() -> std::string {
    try {
      observer.flush_checkpoint();
      writer.drain();
    } catch (const std::exception& e) {
      return fmt::format("writing the results: {}", e.what());
    }
    return {};
  };
  try {
    sim.run(&observer);
    observer.flush_checkpoint();
    writer.drain();
  } catch (const Interrupted& e) {
    observer.finish();
    if (options.summary_on_stop)
      *options.summary_on_stop = summarise(sim, start);
    if (const std::string error = drain(); !error.empty()) {
      results.close(fmt::format("failed: {}", error), error);
      throw std::runtime_error(error);
    }
    results.close("interrupted", e.what());
    throw;
  } catch (const std::exception& e) {
    observer.finish();
    if (options.summary_on_stop)
      *options.summary_on_stop = summarise(sim, start);
    const std::string error = drain();
    const std::string why = error.empty() ? std::string(e.what()) : error;
    results.close(fmt::format("failed: {}", why), why);
    if (!error.empty())
      throw std::runtime_error(error);
    throw;
  }
  observer.finish();
  const RunSummary summary = summarise(sim, start);
  results.close("completed",
                fmt::format("{} increments, {} Newton iterations, {:.3f} s, linear solver {}",
                            summary.increments, summary.iterations, summary.wall_seconds,
                            sim.linear_solver_name()));
  return summary;
}

namespace {

/// A follower's increments: nothing to write; --stop-after stops it where it stops the leader.
class FollowerObserver final : public SimulationObserver {
public:
  FollowerObserver(const Model& model, int stop_after)
      : t_end_(model.steps.back().end_time), stop_after_(stop_after) {}
  void on_increment(const Simulation&, const IncrementReport& r) override {
    stop_after(stop_after_, r, r.time >= t_end_ * (1 - 1e-12));
  }

private:
  double t_end_;
  int stop_after_;
};

} // namespace

RunSummary follow_model(const Model& model, const RunOptions& options) {
  const auto start = Clock::now();
  std::optional<output::StoredCheckpoint> restart;
  if (!options.restart_from.empty())
    restart = read_restart(model, options, output::deck_fingerprint(options.deck_text, model));
  const std::unique_ptr<Simulation> simulation = make_simulation(model, options, restart);
  Simulation& sim = *simulation;
  FollowerObserver observer(model, options.stop_after);
  sim.run(&observer);
  return summarise(sim, start);
}

} // namespace yarnsim
