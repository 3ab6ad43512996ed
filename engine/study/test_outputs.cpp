#include "engine/study/test_outputs.hpp"

#include "engine/output/csv_reader.hpp"
#include "engine/study/plots.hpp"
#include "engine/study/shear_stages.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fmt/format.h>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace yarnsim {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
/// Degrees: the summary's largest angle deviation is taken up to this frame (or ideal) angle, the
/// range where the benchmark expects the yarns to follow the test's kinematics.
constexpr double kDeviationRange = 30;

using output::CsvTable;

/// A cell of the study's own CSV files: quoted (RFC 4180) when it holds a comma, quote or line
/// break, as a label may.
std::string cell(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos)
    return text;
  std::string out = "\"";
  for (char c : text)
    out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string optional(double v) {
  return std::isfinite(v) ? fmt::format("{:.6g}", v) : std::string();
}

/// The last finite value, NaN when none.
double last_finite(const std::vector<double>& v) {
  for (auto it = v.rbegin(); it != v.rend(); ++it)
    if (std::isfinite(*it))
      return *it;
  return kNaN;
}

std::vector<double> scaled(std::vector<double> v, double factor) {
  for (double& x : v)
    x *= factor;
  return v;
}

/// The curves of one run that the summary and the plots use.
struct RunCurves {
  std::vector<double> time;
  // Uniaxial: the pulled and the free direction, and the crimps.
  std::vector<double> strain, force, strain_free, crimp_warp, crimp_weft;
  // Shear tests: the test's own angle (frame or ideal), the measured one, force, travel.
  std::vector<double> test_angle, measured, displacement, normalised;
};

const char* direction_name(const Model& model) {
  return model.biaxial->uniaxial == FabricDirection::Weft ? "weft" : "warp";
}

RunCurves run_curves(StudyTest test, const Model& model, const CsvTable& t) {
  RunCurves c;
  c.time = t.numbers("time [s]");
  if (test == StudyTest::Uniaxial) {
    const bool weft = model.biaxial->uniaxial == FabricDirection::Weft;
    c.strain = t.numbers(weft ? "strain_weft [-]" : "strain_warp [-]");
    c.force = t.numbers(weft ? "force_weft [N]" : "force_warp [N]");
    c.strain_free = t.numbers(weft ? "strain_warp [-]" : "strain_weft [-]");
    c.crimp_warp = t.numbers("crimp_warp [-]");
    c.crimp_weft = t.numbers("crimp_weft [-]");
  } else {
    c.test_angle =
        t.numbers(test == StudyTest::PictureFrame ? "frame_angle [deg]" : "ideal_angle [deg]");
    c.measured = t.numbers("measured_angle [deg]");
    c.displacement = t.numbers("displacement [m]");
    c.force = t.numbers("force [N]");
    c.normalised = t.numbers("normalised_shear_force [N/m]");
  }
  return c;
}

/// The largest |measured - test angle| over the rows whose test angle is at most
/// kDeviationRange degrees, NaN when there is none.
double largest_deviation(const RunCurves& c) {
  double out = kNaN;
  for (std::size_t i = 0; i < c.test_angle.size(); ++i)
    if (std::isfinite(c.test_angle[i]) && std::isfinite(c.measured[i]) &&
        c.test_angle[i] <= kDeviationRange * (1 + 1e-12))
      out = std::isfinite(out) ? std::max(out, std::abs(c.measured[i] - c.test_angle[i]))
                               : std::abs(c.measured[i] - c.test_angle[i]);
  return out;
}

/// The legend of a run: its label with its cost, or how far a stopped run got.
std::string legend(StudyTest test, const TestRun& r, const RunCurves& c) {
  if (r.stopped.empty())
    return fmt::format("{} ({:.1f} s, {} increments)", r.label, r.summary.wall_seconds,
                       r.summary.increments);
  if (test == StudyTest::Uniaxial)
    return fmt::format("{} (stopped at {:.2f} % strain)", r.label, 100 * last_finite(c.strain));
  return fmt::format("{} (stopped at {:.1f} deg)", r.label, last_finite(c.test_angle));
}

/// The file name's part for a run: the case, and its path for a case with `paths`.
std::string run_name(const TestRun& r) {
  return r.folder == r.case_name ? r.case_name : fmt::format("{}-{}", r.case_name, r.path);
}

} // namespace

std::vector<std::string> test_curve_columns(StudyTest test) {
  switch (test) {
  case StudyTest::Uniaxial:
    return {"strain_warp [-]", "strain_weft [-]", "force_warp [N]",
            "force_weft [N]",  "crimp_warp [-]",  "crimp_weft [-]"};
  case StudyTest::PictureFrame:
    return {"displacement [m]",
            "force [N]",
            "frame_angle [deg]",
            "measured_angle [deg]",
            "angle_spread [deg]",
            "shear_force [N]",
            "normalised_shear_force [N/m]",
            "strain_energy [J]",
            "contact_energy [J]",
            "kinetic_energy [J]",
            "parallel_contacts [-]",
            "friction_dissipation [J]",
            "damping_dissipation [J]"};
  case StudyTest::BiasExtension:
    return {"displacement [m]",       "force [N]",
            "ideal_angle [deg]",      "measured_angle [deg]",
            "angle_spread [deg]",     "normalised_shear_force [N/m]",
            "strain_energy [J]",      "contact_energy [J]",
            "kinetic_energy [J]",     "friction_dissipation [J]",
            "damping_dissipation [J]"};
  case StudyTest::Biaxial:
    break;
  }
  throw std::invalid_argument(
      "test_curve_columns: the biaxial test's study curves are curves.csv's (study.cpp)");
}

TestOutputs write_test_outputs(StudyTest test, const std::vector<const TestRun*>& runs,
                               const std::string& title, const std::filesystem::path& dir) {
  const std::vector<std::string> columns = test_curve_columns(test); // throws for Biaxial
  const std::string name = test_name(test);
  const bool uniaxial = test == StudyTest::Uniaxial;
  TestOutputs outputs;

  // All curves in one file, long format, the cells as each run wrote them.
  std::vector<RunCurves> curves(runs.size());
  outputs.curves = dir / fmt::format("curves-{}.csv", name);
  {
    std::ofstream out(outputs.curves);
    out << "case,label,path," << (uniaxial ? "direction," : "") << "time [s]";
    for (const std::string& c : columns)
      out << ',' << c;
    out << '\n';
    for (std::size_t r = 0; r < runs.size(); ++r) {
      const TestRun& run = *runs[r];
      const CsvTable table = output::read_csv_table(dir / run.folder / "curves.csv");
      std::vector<std::ptrdiff_t> index{table.column("time [s]")};
      for (const std::string& c : columns)
        index.push_back(table.column(c));
      for (const auto& row : table.rows) {
        out << cell(run.case_name) << ',' << cell(run.case_label) << ',' << run.path << ','
            << (uniaxial ? fmt::format("{},", direction_name(run.model)) : std::string());
        for (std::size_t k = 0; k < index.size(); ++k)
          out << (k ? "," : "")
              << (index[k] >= 0 ? row[static_cast<std::size_t>(index[k])] : std::string());
        out << '\n';
      }
      curves[r] = run_curves(test, run.model, table);
    }
    if (!out)
      throw std::runtime_error(fmt::format("cannot write {}", outputs.curves.string()));
  }

  // A row per completed run: its cost and the end of its curve.
  outputs.summary = dir / fmt::format("summary-{}.csv", name);
  {
    std::ofstream out(outputs.summary);
    const std::string angle = test == StudyTest::PictureFrame ? "frame_angle" : "ideal_angle";
    if (uniaxial)
      out << "case,label,path,direction,wall_time [s],increments [-],newton_iterations [-],"
             "strain_end [-],force_end [N],strain_free_end [-],crimp_warp_end [-],"
             "crimp_weft_end [-]\n";
    else
      out << "case,label,path,wall_time [s],increments [-],newton_iterations [-]," << angle
          << "_end [deg],measured_angle_end [deg],force_end [N],normalised_shear_force_end "
             "[N/m],max_angle_deviation_to_30deg [deg]\n";
    for (std::size_t r = 0; r < runs.size(); ++r) {
      const TestRun& run = *runs[r];
      if (!run.stopped.empty())
        continue;
      const RunCurves& c = curves[r];
      out << cell(run.case_name) << ',' << cell(run.case_label) << ',' << run.path << ','
          << (uniaxial ? fmt::format("{},", direction_name(run.model)) : std::string())
          << fmt::format("{:.3f}", run.summary.wall_seconds) << ',' << run.summary.increments << ','
          << run.summary.iterations << ',';
      const std::string what = run.label;
      if (uniaxial) {
        out << optional(last_finite(c.strain)) << ',' << optional(last_finite(c.force)) << ','
            << optional(last_finite(c.strain_free)) << ',' << optional(last_finite(c.crimp_warp))
            << ',' << optional(last_finite(c.crimp_weft)) << '\n';
        fmt::print(stderr,
                   "{}: {:.1f} s, {} increments; {} pulled to {:.3g} % strain, {:.4g} N; crimp "
                   "warp {:.3g} %, weft {:.3g} %\n",
                   what, run.summary.wall_seconds, run.summary.increments,
                   direction_name(run.model), 100 * last_finite(c.strain), last_finite(c.force),
                   100 * last_finite(c.crimp_warp), 100 * last_finite(c.crimp_weft));
      } else {
        const double deviation = largest_deviation(c);
        out << optional(last_finite(c.test_angle)) << ',' << optional(last_finite(c.measured))
            << ',' << optional(last_finite(c.force)) << ',' << optional(last_finite(c.normalised))
            << ',' << optional(deviation) << '\n';
        fmt::print(stderr,
                   "{}: {:.1f} s, {} increments; {} angle {:.2f} deg, measured {:.2f} deg, force "
                   "{:.4g} N{}\n",
                   what, run.summary.wall_seconds, run.summary.increments,
                   test == StudyTest::PictureFrame ? "frame" : "ideal", last_finite(c.test_angle),
                   last_finite(c.measured), last_finite(c.force),
                   std::isfinite(deviation)
                       ? fmt::format("; measured within {:.2f} deg of it up to {:g} deg", deviation,
                                     kDeviationRange)
                       : std::string());
      }
    }
    if (!out)
      throw std::runtime_error(fmt::format("cannot write {}", outputs.summary.string()));
  }

  // The plots: one colour per run, each drawn wider than the next (coinciding curves stay
  // visible), as force_strain does.
  std::vector<plots::Curve> main, second, third;
  for (std::size_t r = 0; r < runs.size(); ++r) {
    const RunCurves& c = curves[r];
    const std::string label = legend(test, *runs[r], c);
    const int colour = static_cast<int>(r);
    const double width = 2.5 + 1.5 * static_cast<double>(runs.size() - 1 - r);
    if (uniaxial) {
      const std::vector<double> strain = scaled(c.strain, 100);
      main.push_back({fmt::format("{}, {} pulled", label, direction_name(runs[r]->model)), strain,
                      c.force, colour, false, width});
      second.push_back({label + ": warp", strain, scaled(c.crimp_warp, 100), colour, false, width});
      second.push_back({label + ": weft", strain, scaled(c.crimp_weft, 100), colour, true, width});
    } else {
      main.push_back({label, scaled(c.displacement, 1e3), c.force, colour, false, width});
      const std::string against = test == StudyTest::PictureFrame ? "frame" : "ideal";
      second.push_back({fmt::format("{}, against the {} angle", label, against), c.test_angle,
                        c.normalised, colour, false, width});
      second.push_back(
          {label + ", against the measured angle", c.measured, c.normalised, colour, true, width});
      third.push_back({label, c.test_angle, c.measured, colour, false, width});
    }
  }
  auto drawable = [](const std::vector<plots::Curve>& set) {
    for (const plots::Curve& c : set)
      for (std::size_t i = 0; i < c.x.size(); ++i)
        if (std::isfinite(c.x[i]) && std::isfinite(c.y[i]))
          return true;
    return false;
  };
  auto draw = [&](const std::vector<plots::Graph>& graphs, const std::string& heading,
                  const std::string& file) {
    for (const plots::Graph& g : graphs)
      if (!drawable(g.curves)) {
        fmt::print(stderr, "note: {} not drawn: no run of the {} test has a point of '{}'\n", file,
                   name, g.y_label);
        return;
      }
    const std::filesystem::path png = dir / file;
    plots::line_graphs(graphs, heading, png);
    outputs.plots.push_back(png);
  };
  if (uniaxial) {
    draw({{"the pulled direction",
           "strain of the pulled direction [%]",
           "force of the pulled direction [N]",
           main,
           {}},
          {"crimp: warp solid, weft dashed",
           "strain of the pulled direction [%]",
           "crimp [%]",
           second,
           {}}},
         fmt::format("{}: uniaxial tension", title), "uniaxial.png");
    return outputs;
  }
  const bool frame = test == StudyTest::PictureFrame;
  const std::string test_title = frame ? "picture frame" : "bias extension";
  const std::string angle = frame ? "frame angle" : "ideal angle";
  draw({{"",
         frame ? "crosshead displacement [mm]" : "displacement of the top clamp [mm]",
         frame ? "crosshead force [N]" : "force [N]",
         main,
         {}}},
       fmt::format("{}: {}, force against displacement", title, test_title),
       fmt::format("force-displacement-{}.png", name));
  draw({{fmt::format("against the {} (solid) and the measured angle (dashed)", angle),
         "shear angle [deg]",
         "normalised shear force [N/m]",
         second,
         {}}},
       fmt::format("{}: {}, normalised shear force", title, test_title),
       fmt::format("shear-{}.png", name));
  draw({{"", fmt::format("{} [deg]", angle), "measured angle (central crossings) [deg]", third,
         fmt::format("measured = {} (the test's kinematics)", angle)}},
       fmt::format("{}: {}, the yarns' angle against the {}", title, test_title, angle),
       fmt::format("angle-{}.png", name));

  // Each run's deformed specimen at kStages of its output steps.
  for (const TestRun* run : runs) {
    const std::vector<ShearStage> stages =
        read_shear_stages(run->model, dir / run->folder / "results.h5", kStages);
    if (stages.empty()) {
      fmt::print(stderr, "note: deformed-{}.png not drawn: the run wrote no output step\n",
                 run_name(*run));
      continue;
    }
    std::vector<plots::SpecimenView> views;
    // Angles within rounding of 0 (the ideal angle's -1e-14 at rest) shown as 0.00, not -0.00.
    auto shown = [](double degrees) { return std::abs(degrees) < 5e-3 ? 0.0 : degrees; };
    for (const ShearStage& s : stages)
      views.push_back(
          {fmt::format("{:g} % of the output steps\\nincrement {}, t = {:.4g} s\\n{} {:.2f} deg, "
                       "measured {:.2f} deg",
                       100 * s.fraction, s.increment, s.time, angle, shown(s.test_angle),
                       shown(s.measured)),
           centre_lines(run->model, s.positions), s.crossings, s.shear});
    const std::filesystem::path png = dir / fmt::format("deformed-{}.png", run_name(*run));
    plots::coloured_specimens(views, "local shear angle [deg]",
                              fmt::format("{}: {}{}, local shear angle at every crossing", title,
                                          run->label,
                                          run->stopped.empty() ? "" : " (stopped early)"),
                              png);
    outputs.plots.push_back(png);
  }
  return outputs;
}

} // namespace yarnsim
