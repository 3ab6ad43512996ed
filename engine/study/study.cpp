#include "engine/study/study.hpp"

#include "engine/input/read_deck.hpp"
#include "engine/model/deck_schema.hpp"
#include "engine/output/csv_reader.hpp"
#include "engine/run/run.hpp"
#include "engine/solver/simulation.hpp"
#include "engine/study/plots.hpp"
#include "engine/study/test_outputs.hpp"
#include "engine/textile/fabric_deck.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

namespace yarnsim {

namespace {

using deck::CheckedTable;
using deck::KeySpec;
using deck::TableSpec;
using deck::Type;

constexpr KeySpec kCaseKeys[] = {
    {"name", Type::String, deck::kRequired},
    {"label", Type::String},
    {"deck", Type::String, deck::kRequired},
    {"paths", Type::Words},
};
constexpr TableSpec kCaseSpec{"[[cases]]", kCaseKeys};
constexpr KeySpec kStudyKeys[] = {
    {"title", Type::String},
    {"contact_maps", Type::Words},
    {"cases", Type::Tables, deck::kRequired, deck::kAnyValue, &kCaseSpec},
};
constexpr TableSpec kStudySpec{"study", kStudyKeys};

std::string read_text(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Numeric columns of a CSV written by CsvWriter (header line, then numbers), in file order.
std::vector<std::vector<double>> read_csv(const std::filesystem::path& file) {
  const output::CsvTable table = output::read_csv_table(file);
  std::vector<std::vector<double>> cols;
  for (const std::string& name : table.header)
    cols.push_back(table.numbers(name));
  return cols;
}

std::string format_k(double k) {
  return fmt::format("{:g}", k);
}

const char* path_name(StudyPath p) {
  return p == StudyPath::Explicit ? "explicit" : p == StudyPath::Implicit ? "implicit" : "deck";
}

/// The test blocks of a fabric deck, in StudyTest's order.
constexpr StudyTest kTests[] = {StudyTest::Biaxial, StudyTest::Uniaxial, StudyTest::PictureFrame,
                                StudyTest::BiasExtension};

/// The test blocks a deck's top level holds (a fabric deck holds exactly one).
std::vector<StudyTest> test_blocks(const toml::table& table) {
  std::vector<StudyTest> out;
  for (StudyTest t : kTests)
    if (table.contains(test_name(t)))
      out.push_back(t);
  return out;
}

/// The test a model runs, as its deck's test block gave it. Throws InputError naming the case
/// when the model has none (a model deck).
StudyTest test_of(const Model& model, const StudyCase& c) {
  if (model.biaxial)
    return model.biaxial->uniaxial ? StudyTest::Uniaxial : StudyTest::Biaxial;
  if (model.picture_frame)
    return StudyTest::PictureFrame;
  if (model.bias_extension)
    return StudyTest::BiasExtension;
  throw InputError({fmt::format("{}: case '{}': expected a fabric deck with a test block "
                                "([biaxial], [uniaxial], [picture_frame] or [bias_extension]), "
                                "found a model without a fabric test",
                                c.deck.string(), c.name)});
}

/// The case's deck, for a fabric deck with its test block's type set for `path` (as the deck
/// says for Deck). A fabric deck is parsed here rather than by read_deck so the type can be
/// changed before the model is built; its problems are reported as read_deck does. Throws
/// InputError.
Model read_case_deck(const std::filesystem::path& file, StudyPath path) {
  if (path == StudyPath::Deck)
    return read_deck(file);
  toml::table table = parse_deck_file(file);
  deck::Diagnostics diagnostics(file.string());
  const std::vector<StudyTest> tests = test_blocks(table);
  toml::table* block = tests.empty() ? nullptr : table[test_name(tests.front())].as_table();
  if (!table.contains("fabric") || block == nullptr)
    throw InputError({fmt::format("{}: a case with 'paths' needs a fabric deck with [fabric] and "
                                  "a test block ([biaxial], [uniaxial], [picture_frame] or "
                                  "[bias_extension]), found {}",
                                  file.string(),
                                  table.contains("fabric") ? "no test block"
                                  : block                  ? "no [fabric]"
                                                           : "neither")});
  const toml::node* type = block->get("type");
  const std::string given =
      type && type->as_string() ? type->as_string()->get() : std::string("dynamic");
  if (path == StudyPath::Explicit)
    block->insert_or_assign("type", "explicit");
  else if (given != "static" && given != "dynamic")
    block->insert_or_assign("type", "dynamic");
  std::optional<Model> model = textile::read_fabric_deck(table, diagnostics, file.parent_path());
  if (!diagnostics.empty() || !model)
    throw InputError(diagnostics.messages());
  return std::move(*model);
}

const char* type_name(StepType t) {
  return t == StepType::Explicit ? "explicit" : t == StepType::Static ? "static" : "dynamic";
}

/// Linear interpolation of y(x) at x0 on increasing x; NaN outside the range of x.
double interpolate(const std::vector<double>& x, const std::vector<double>& y, double x0) {
  for (std::size_t i = 1; i < x.size(); ++i)
    if (x[i] >= x0 && x[i - 1] <= x0) {
      const double span = x[i] - x[i - 1];
      const double w = span > 0 ? (x0 - x[i - 1]) / span : 1.0;
      return (1 - w) * y[i - 1] + w * y[i];
    }
  return std::numeric_limits<double>::quiet_NaN();
}

} // namespace

const char* test_name(StudyTest test) {
  switch (test) {
  case StudyTest::Biaxial:
    return "biaxial";
  case StudyTest::Uniaxial:
    return "uniaxial";
  case StudyTest::PictureFrame:
    return "picture_frame";
  case StudyTest::BiasExtension:
    return "bias_extension";
  }
  return "unknown";
}

Study read_study(const std::filesystem::path& file) {
  const std::string source = file.string();
  deck::Diagnostics diagnostics(source);
  toml::table table;
  try {
    table = toml::parse_file(source);
  } catch (const toml::parse_error& e) {
    diagnostics.error(e.source(), "", e.description());
    throw InputError(diagnostics.messages());
  }
  const CheckedTable root(table, kStudySpec, "", diagnostics);
  Study study;
  const std::optional<std::string> title = root.string("title");
  study.contact_maps = root.words("contact_maps").value_or(std::vector<std::string>{});
  const std::filesystem::path dir = file.parent_path();
  for (const CheckedTable& c : root.tables("cases")) {
    StudyCase sc;
    sc.name = c.string("name").value_or("");
    sc.label = c.string("label").value_or(sc.name);
    const std::string deck_path = c.string("deck").value_or("");
    sc.deck = dir / deck_path;
    if (auto paths = c.words("paths")) {
      sc.paths.clear();
      for (std::size_t i = 0; i < paths->size(); ++i) {
        const std::string& p = (*paths)[i];
        const StudyPath path = p == "implicit"   ? StudyPath::Implicit
                               : p == "explicit" ? StudyPath::Explicit
                                                 : StudyPath::Deck;
        if (path == StudyPath::Deck)
          c.error("paths", i,
                  fmt::format("expected \"implicit\" or \"explicit\", found \"{}\"", p));
        else if (std::find(sc.paths.begin(), sc.paths.end(), path) != sc.paths.end())
          c.error("paths", i, fmt::format("\"{}\" is listed twice", p));
        else
          sc.paths.push_back(path);
      }
    }
    if (!deck_path.empty() && !std::filesystem::exists(sc.deck))
      c.error("deck", fmt::format("no such deck: {}", sc.deck.string()));
    else if (!deck_path.empty()) {
      // The deck's test decides the case's outputs; the deck is read whole when the case runs.
      try {
        const std::vector<StudyTest> tests = test_blocks(parse_deck_file(sc.deck));
        if (tests.size() == 1)
          sc.test = tests.front();
        else if (tests.empty())
          c.error("deck", fmt::format("expected a fabric deck with a test block ([biaxial], "
                                      "[uniaxial], [picture_frame] or [bias_extension]), found "
                                      "none in {}",
                                      sc.deck.string()));
        else
          c.error("deck", fmt::format("expected a fabric deck with one test block, found [{}] "
                                      "and [{}] in {}",
                                      test_name(tests[0]), test_name(tests[1]), sc.deck.string()));
      } catch (const InputError& e) {
        for (const std::string& m : e.messages())
          c.error("deck", fmt::format("cannot read the case's deck: {}", m));
      }
    }
    for (const StudyCase& other : study.cases)
      if (!sc.name.empty() && other.name == sc.name)
        c.error("name", fmt::format("a case named '{}' exists already", sc.name));
    study.cases.push_back(sc);
  }
  for (std::size_t i = 0; i < study.contact_maps.size(); ++i) {
    bool found = false;
    for (const StudyCase& c : study.cases)
      found = found || c.name == study.contact_maps[i];
    if (!found)
      root.error("contact_maps", i, fmt::format("no case named '{}'", study.contact_maps[i]));
  }
  if (!diagnostics.empty())
    throw InputError(diagnostics.messages());
  // The default title names the test when every case runs the paper's biaxial test.
  const bool biaxial_only = std::all_of(study.cases.begin(), study.cases.end(),
                                        [](const auto& c) { return c.test == StudyTest::Biaxial; });
  study.title = title.value_or(biaxial_only ? "Biaxial tension study" : "Fabric study");
  return study;
}

namespace {

/// One completed run of a biaxial case on one path.
struct Done {
  const StudyCase* c;
  std::string path;   ///< "implicit" or "explicit": the step the run took
  std::string folder; ///< under output_dir
  std::string label;  ///< legend
  double k;
  RunSummary summary;
  Model model;
  ExplicitStatus scaling; ///< explicit runs: stable step and mass scaling at the start
  /// A run that stopped early (no convergence) and left a curve: plotted as far as it got,
  /// left out of the summary and the contact maps. Empty for a completed run.
  std::string stopped;
};

/// The biaxial runs' files: curves.csv, summary.csv and force-strain-k<k>.png per strain ratio.
void write_biaxial_outputs(const Study& study, const StudyOptions& options,
                           const std::vector<Done>& done, StudyOutcome& outcome) {
  // All curves in one file, long format; the curves of each run for the plots and the summary.
  std::ofstream all(options.output_dir / "curves.csv");
  all << "case,label,path,k,time [s],strain_warp [-],strain_weft [-],force_warp [N],force_weft "
         "[N]\n";
  std::vector<plots::CurveSet> sets(done.size());
  std::vector<std::vector<double>> times(done.size());
  for (std::size_t r = 0; r < done.size(); ++r) {
    const Done& d = done[r];
    const auto cols = read_csv(options.output_dir / d.folder / "curves.csv");
    plots::CurveSet& set = sets[r];
    set.label = fmt::format("{} ({:.1f} s, {} increments)", d.label, d.summary.wall_seconds,
                            d.summary.increments);
    if (!d.stopped.empty() && cols.size() >= 5 && !cols[1].empty())
      set.label = fmt::format("{} (stopped at {:.2f} % strain)", d.label,
                              100 * std::max(cols[1].back(), cols[2].back()));
    // The curves start at the undeformed state: the run's first row is t = 0.
    if (cols.size() < 5)
      continue;
    for (std::size_t i = 0; i < cols[0].size(); ++i) {
      all << d.c->name << ',' << d.c->label << ',' << d.path << ',' << format_k(d.k) << ','
          << cols[0][i] << ',' << cols[1][i] << ',' << cols[2][i] << ',' << cols[3][i] << ','
          << cols[4][i] << '\n';
      times[r].push_back(cols[0][i]);
      set.strain_warp.push_back(cols[1][i]);
      set.strain_weft.push_back(cols[2][i]);
      set.force_warp.push_back(cols[3][i]);
      set.force_weft.push_back(cols[4][i]);
    }
  }
  all.close();

  // Per run: cost, mass scaling, and past the toe (strain >= kToe x its final nominal value in
  // each direction) the largest kinetic/internal energy ratio and the largest difference of the
  // force to the implicit run of the same case at equal strain.
  constexpr double kToe = 0.2;
  std::ofstream summary(options.output_dir / "summary.csv");
  summary << "case,label,path,k,wall_time [s],increments [-],newton_iterations [-],dt [s],"
             "mass_scaling_dt [s],added_mass [%],max_kinetic/internal_past_toe [-],"
             "max_difference_to_implicit_past_toe [%],force_warp_end [N],force_weft_end [N]\n";
  auto optional = [](double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : ""; };
  for (std::size_t r = 0; r < done.size(); ++r) {
    if (!done[r].stopped.empty())
      continue;
    const Done& d = done[r];
    const plots::CurveSet& set = sets[r];
    const auto [eps_warp, eps_weft] = [&] {
      const double m = d.model.biaxial->max_strain;
      return d.k >= 1 ? std::pair{m, m / d.k} : std::pair{d.k * m, m};
    }();
    const bool is_explicit = d.path == "explicit";
    double ratio = std::numeric_limits<double>::quiet_NaN();
    if (is_explicit && std::filesystem::exists(options.output_dir / d.folder / "energy.csv")) {
      // The toe ends when the more strained direction passes kToe of its final strain.
      const std::vector<double>& main = d.k >= 1 ? set.strain_warp : set.strain_weft;
      const double toe = kToe * std::max(eps_warp, eps_weft);
      double t_toe = std::numeric_limits<double>::infinity();
      for (std::size_t i = 0; i < main.size(); ++i)
        if (main[i] >= toe) {
          t_toe = times[r][i];
          break;
        }
      const auto energy = read_csv(options.output_dir / d.folder / "energy.csv");
      if (energy.size() >= 9) {
        ratio = 0;
        for (std::size_t i = 0; i < energy[0].size(); ++i)
          if (energy[0][i] >= t_toe * (1 - 1e-12))
            ratio = std::max(ratio, energy[8][i]);
      }
    }
    double difference = std::numeric_limits<double>::quiet_NaN();
    const Done* implicit = nullptr;
    for (const Done& o : done)
      if (o.c == d.c && o.path == "implicit")
        implicit = &o;
    if (is_explicit && implicit) {
      const plots::CurveSet& ref = sets[implicit - done.data()];
      difference = 0;
      for (int dir = 0; dir < 2; ++dir) {
        const auto& s = dir == 0 ? set.strain_warp : set.strain_weft;
        const auto& f = dir == 0 ? set.force_warp : set.force_weft;
        const auto& s_ref = dir == 0 ? ref.strain_warp : ref.strain_weft;
        const auto& f_ref = dir == 0 ? ref.force_warp : ref.force_weft;
        const double toe = kToe * (dir == 0 ? eps_warp : eps_weft);
        for (std::size_t i = 0; i < s.size(); ++i) {
          if (s[i] < toe)
            continue;
          const double f0 = interpolate(s_ref, f_ref, s[i]);
          if (std::isfinite(f0) && f0 != 0)
            difference = std::max(difference, 100 * std::abs(f[i] - f0) / std::abs(f0));
        }
      }
    }
    const SolutionStep& step = d.model.steps.back();
    summary << d.c->name << ',' << d.c->label << ',' << d.path << ',' << format_k(d.k) << ','
            << fmt::format("{:.3f}", d.summary.wall_seconds) << ',' << d.summary.increments << ','
            << d.summary.iterations << ','
            << (is_explicit ? optional(step.dt_initial) : std::string()) << ','
            << (is_explicit && step.mass_scaling_dt > 0 ? optional(step.mass_scaling_dt) : "")
            << ',' << (is_explicit ? optional(d.scaling.added_mass_percent) : "") << ','
            << optional(ratio) << ',' << optional(difference) << ','
            << optional(set.force_warp.back()) << ',' << optional(set.force_weft.back()) << '\n';
    fmt::print(
        stderr, "{}: {:.1f} s, {} increments{}{}{}\n", set.label.substr(0, set.label.rfind(" (")),
        d.summary.wall_seconds, d.summary.increments,
        is_explicit ? fmt::format(", mass scaling added {:.3g} %", d.scaling.added_mass_percent)
                    : std::string(),
        std::isfinite(ratio)
            ? fmt::format(", kinetic/internal energy past the toe at most {:.3g}", ratio)
            : std::string(),
        std::isfinite(difference)
            ? fmt::format(", force within {:.2f} % of the implicit run past the toe", difference)
            : std::string());
  }
  summary.close();

  std::map<double, std::vector<plots::CurveSet>> by_k;
  for (std::size_t r = 0; r < done.size(); ++r)
    by_k[done[r].k].push_back(sets[r]);
  for (const auto& [k, k_sets] : by_k) {
    const auto png = options.output_dir / fmt::format("force-strain-k{}.png", format_k(k));
    plots::force_strain(k_sets,
                        fmt::format("{}: biaxial tension, k = {}", study.title, format_k(k)), png);
    outcome.plots.push_back(png);
  }
}

} // namespace

StudyOutcome run_study(const Study& study, const StudyOptions& options) {
  StudyOutcome outcome;
  std::vector<Done> done;      // biaxial runs
  std::vector<TestRun> others; // runs of the uniaxial and shear tests
  for (const StudyCase& c : study.cases) {
    const bool by_path = c.paths.size() > 1 || c.paths.front() != StudyPath::Deck;
    for (StudyPath path : c.paths) {
      Model model = read_case_deck(c.deck, path);
      const StudyTest test = test_of(model, c);
      const bool is_explicit = model.steps.back().type == StepType::Explicit;
      const std::string taken = is_explicit ? "explicit" : "implicit";
      const std::string folder = by_path ? fmt::format("{}/{}", c.name, path_name(path)) : c.name;
      RunOptions run;
      run.output_dir = options.output_dir / folder;
      run.deck_text = read_text(c.deck);
      if (path != StudyPath::Deck)
        run.deck_text =
            fmt::format("# run by a study on the {} path: [{}] type = \"{}\"\n{}", taken,
                        test_name(test), type_name(model.steps.back().type), run.deck_text);
      run.deck_path = c.deck.string();
      run.threads = options.threads;
      run.linear_solver = options.linear_solver;
      run.progress = options.progress;
      run.stop_requested = options.stop_requested;
      fmt::print(stderr, "case {} ({}){}, deck {}\n", c.name, c.label,
                 by_path ? fmt::format(" on the {} path", taken) : std::string(), c.deck.string());
      // Kept outside the try: a stopped run's entry carries it too.
      ExplicitStatus scaling;
      try {
        if (is_explicit)
          scaling = Simulation(model).explicit_stability(model.steps.back());
        RunSummary s = run_model(model, run);
        const std::string label = by_path ? fmt::format("{}, {}", c.label, taken) : c.label;
        if (test == StudyTest::Biaxial) {
          const double k = model.biaxial->strain_ratio;
          done.push_back(
              {&c, taken, folder, label, k, std::move(s), std::move(model), scaling, {}});
        } else {
          others.push_back(
              {c.name, c.label, taken, folder, label, test, std::move(model), std::move(s), {}});
        }
        ++outcome.completed;
      } catch (const Interrupted&) {
        throw;
      } catch (const std::exception& e) {
        const std::string what = by_path ? fmt::format("{} ({})", c.name, taken) : c.name;
        outcome.failures.push_back(fmt::format("{}: {}", what, e.what()));
        fmt::print(stderr, "case {} stopped: {}\n", what, e.what());
        if (std::filesystem::exists(run.output_dir / "curves.csv")) {
          const std::string label = by_path ? fmt::format("{}, {}", c.label, taken) : c.label;
          if (test == StudyTest::Biaxial) {
            const double k = model.biaxial->strain_ratio;
            Done entry{&c, taken, folder, label, k, RunSummary{}, std::move(model), scaling, what};
            done.push_back(std::move(entry));
          } else {
            others.push_back({c.name, c.label, taken, folder, label, test, std::move(model),
                              RunSummary{}, what});
          }
        }
      }
    }
  }

  // The biaxial runs' files, unless no case is biaxial (a study of other tests only), then per
  // other test among the cases its own (test_outputs.hpp).
  const bool biaxial = std::any_of(study.cases.begin(), study.cases.end(),
                                   [](const auto& c) { return c.test == StudyTest::Biaxial; });
  if (biaxial || study.cases.empty()) {
    write_biaxial_outputs(study, options, done, outcome);
    outcome.curves.push_back(options.output_dir / "curves.csv");
  }
  std::vector<StudyTest> tests; // the other tests, in the order of their first case
  auto add = [&tests](StudyTest t) {
    if (t != StudyTest::Biaxial && std::find(tests.begin(), tests.end(), t) == tests.end())
      tests.push_back(t);
  };
  for (const StudyCase& c : study.cases)
    add(c.test);
  for (const TestRun& r : others) // the same unless a deck changed while the study ran
    add(r.test);
  for (const StudyTest test : tests) {
    std::vector<const TestRun*> runs;
    for (const TestRun& r : others)
      if (r.test == test)
        runs.push_back(&r);
    const TestOutputs files = write_test_outputs(test, runs, study.title, options.output_dir);
    outcome.curves.push_back(files.curves);
    outcome.plots.insert(outcome.plots.end(), files.plots.begin(), files.plots.end());
  }

  // The contact maps: a completed run's final normal contact forces over the fabric, whatever
  // its test.
  struct MapRun {
    const std::string& name; ///< of the case
    const std::string& path;
    const std::string& folder;
    const std::string& label;
    const Model& model;
    const RunSummary& summary;
  };
  std::vector<MapRun> map_runs;
  for (const std::string& name : study.contact_maps) {
    for (const Done& d : done)
      if (d.c->name == name && d.stopped.empty())
        map_runs.push_back({name, d.path, d.folder, d.label, d.model, d.summary});
    for (const TestRun& r : others)
      if (r.case_name == name && r.stopped.empty())
        map_runs.push_back({name, r.path, r.folder, r.label, r.model, r.summary});
  }
  for (const MapRun& d : map_runs) {
    const std::string& name = d.name;
    std::vector<Eigen::Matrix3Xd> yarns;
    for (const Spline& s : d.model.splines) {
      Eigen::Matrix3Xd y(3, s.nodes.size());
      for (std::size_t i = 0; i < s.nodes.size(); ++i)
        y.col(i) = d.summary.final_positions.col(s.nodes[i]);
      yarns.push_back(y);
    }
    const auto& pts = d.summary.final_contacts;
    Eigen::Matrix3Xd xyz(3, pts.size());
    Eigen::VectorXd f(pts.size());
    double total = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      xyz.col(i) = pts[i].position;
      f(i) = pts[i].force;
      total += f(i);
    }
    const bool by_path = d.folder != name;
    const auto png =
        options.output_dir / (by_path ? fmt::format("contact-forces-{}-{}.png", name, d.path)
                                      : fmt::format("contact-forces-{}.png", name));
    plots::contact_map(yarns, xyz, f,
                       // Two lines ("\\n": gnuplot's escape in a double-quoted string).
                       fmt::format("{}: normal contact forces at the end\\n({} points, largest "
                                   "{:.2f} N, total {:.1f} N)",
                                   d.label, pts.size(), f.size() ? f.maxCoeff() : 0.0, total),
                       png);
    outcome.plots.push_back(png);
  }
  return outcome;
}

} // namespace yarnsim
