#include "engine/study/study.hpp"

#include "engine/model/deck.hpp"
#include "engine/model/deck_schema.hpp"
#include "engine/run/run.hpp"
#include "engine/solver/simulation.hpp"
#include "engine/study/plots.hpp"

#include <cmath>
#include <fmt/format.h>
#include <fstream>
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

/// Numeric columns of a CSV written by CsvWriter (header line, then numbers).
std::vector<std::vector<double>> read_csv(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in)
    throw std::runtime_error(fmt::format("cannot read {}", file.string()));
  std::string line;
  std::getline(in, line);
  std::vector<std::vector<double>> cols;
  while (std::getline(in, line)) {
    std::stringstream row(line);
    std::string cell;
    std::size_t c = 0;
    while (std::getline(row, cell, ',')) {
      if (cols.size() <= c)
        cols.resize(c + 1);
      cols[c++].push_back(std::stod(cell));
    }
  }
  return cols;
}

std::string format_k(double k) {
  return fmt::format("{:g}", k);
}

} // namespace

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
  study.title = root.string("title").value_or("Biaxial tension study");
  study.contact_maps = root.words("contact_maps").value_or(std::vector<std::string>{});
  const std::filesystem::path dir = file.parent_path();
  for (const CheckedTable& c : root.tables("cases")) {
    StudyCase sc;
    sc.name = c.string("name").value_or("");
    sc.label = c.string("label").value_or(sc.name);
    const std::string deck_path = c.string("deck").value_or("");
    sc.deck = dir / deck_path;
    if (!deck_path.empty() && !std::filesystem::exists(sc.deck))
      c.error("deck", fmt::format("no such deck: {}", sc.deck.string()));
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
  return study;
}

StudyOutcome run_study(const Study& study, const StudyOptions& options) {
  StudyOutcome outcome;
  struct Done {
    const StudyCase* c;
    double k;
    double seconds;
    RunSummary summary;
    Model model;
  };
  std::vector<Done> done;
  for (const StudyCase& c : study.cases) {
    Model model = read_deck(c.deck);
    if (!model.biaxial)
      throw InputError({fmt::format("{}: case '{}' is not a biaxial test (no [biaxial] block)",
                                    c.deck.string(), c.name)});
    RunOptions run;
    run.output_dir = options.output_dir / c.name;
    run.deck_text = read_text(c.deck);
    run.deck_path = c.deck.string();
    run.threads = options.threads;
    run.linear_solver = options.linear_solver;
    run.progress = options.progress;
    run.stop_requested = options.stop_requested;
    fmt::print(stderr, "case {} ({}), deck {}\n", c.name, c.label, c.deck.string());
    try {
      RunSummary s = run_model(model, run);
      const double k = model.biaxial->strain_ratio;
      done.push_back({&c, k, s.wall_seconds, std::move(s), std::move(model)});
      ++outcome.completed;
    } catch (const Interrupted&) {
      throw;
    } catch (const std::exception& e) {
      outcome.failures.push_back(fmt::format("{}: {}", c.name, e.what()));
      fmt::print(stderr, "case {} stopped: {}\n", c.name, e.what());
    }
  }

  // All curves in one file, long format.
  std::ofstream all(options.output_dir / "curves.csv");
  all << "case,label,k,time [s],strain_warp [-],strain_weft [-],force_warp [N],force_weft [N]\n";
  std::map<double, std::vector<plots::CurveSet>> by_k;
  for (const Done& d : done) {
    const auto cols = read_csv(options.output_dir / d.c->name / "curves.csv");
    if (cols.size() < 5)
      continue;
    plots::CurveSet set{fmt::format("{} ({:.1f} s)", d.c->label, d.seconds), {}, {}, {}, {}};
    // The curves start at the undeformed state.
    set.strain_warp.push_back(0);
    set.strain_weft.push_back(0);
    set.force_warp.push_back(0);
    set.force_weft.push_back(0);
    for (std::size_t i = 0; i < cols[0].size(); ++i) {
      all << d.c->name << ',' << d.c->label << ',' << format_k(d.k) << ',' << cols[0][i] << ','
          << cols[1][i] << ',' << cols[2][i] << ',' << cols[3][i] << ',' << cols[4][i] << '\n';
      set.strain_warp.push_back(cols[1][i]);
      set.strain_weft.push_back(cols[2][i]);
      set.force_warp.push_back(cols[3][i]);
      set.force_weft.push_back(cols[4][i]);
    }
    by_k[d.k].push_back(std::move(set));
  }
  all.close();

  for (const auto& [k, sets] : by_k) {
    const auto png = options.output_dir / fmt::format("force-strain-k{}.png", format_k(k));
    plots::force_strain(sets, fmt::format("{}: biaxial tension, k = {}", study.title, format_k(k)),
                        png);
    outcome.plots.push_back(png);
  }
  for (const std::string& name : study.contact_maps)
    for (const Done& d : done) {
      if (d.c->name != name)
        continue;
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
      const auto png = options.output_dir / fmt::format("contact-forces-{}.png", name);
      plots::contact_map(yarns, xyz, f,
                         fmt::format("{}: normal contact forces at the end ({} points, largest "
                                     "{:.2f} N, total {:.1f} N)",
                                     d.c->label, pts.size(), f.size() ? f.maxCoeff() : 0.0, total),
                         png);
      outcome.plots.push_back(png);
    }
  return outcome;
}

} // namespace yarnsim
