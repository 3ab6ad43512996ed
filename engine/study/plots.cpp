#include "engine/study/plots.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fmt/format.h>
#include <fstream>
#include <limits>
#include <stdexcept>

namespace yarnsim::plots {

namespace {

/// Runs gnuplot on a script file; throws with the script's path on failure.
void run_gnuplot(const std::filesystem::path& script) {
  const std::string cmd = fmt::format("gnuplot '{}' 2>'{}.log'", script.string(), script.string());
  const int status = std::system(cmd.c_str());
  if (status != 0)
    throw std::runtime_error(
        fmt::format("gnuplot failed on {} (exit status {}; is gnuplot-nox installed? see {}.log)",
                    script.string(), status, script.string()));
}

std::string quoted(const std::string& s) {
  std::string out;
  for (char c : s)
    out += (c == '"' ? '\'' : c);
  return "\"" + out + "\"";
}

const char* kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf"};

} // namespace

void force_strain(const std::vector<CurveSet>& sets, const std::string& title,
                  const std::filesystem::path& png) {
  const std::filesystem::path base = std::filesystem::path(png).replace_extension();
  const std::filesystem::path data = base.string() + ".dat";
  {
    std::ofstream out(data);
    out << "# strain_warp [%]  force_warp [N]  strain_weft [%]  force_weft [N]; one block per "
           "set\n";
    for (const CurveSet& s : sets) {
      out << "# " << s.label << "\n";
      for (std::size_t i = 0; i < s.force_warp.size(); ++i)
        out << 100 * s.strain_warp[i] << ' ' << s.force_warp[i] << ' ' << 100 * s.strain_weft[i]
            << ' ' << s.force_weft[i] << '\n';
      out << "\n\n";
    }
  }
  const std::filesystem::path script = base.string() + ".gp";
  {
    std::ofstream gp(script);
    gp << "set terminal pngcairo size 1000,700 enhanced font 'Sans,13'\n"
       << "set output " << quoted(png.string()) << "\n"
       << "set title " << quoted(title) << "\n"
       << "set xlabel 'strain [%]'\nset ylabel 'force [N]'\n"
       << "set key top left box opaque\nset grid\nset xrange [0:*]\nset yrange [0:*]\n"
       << "plot ";
    for (std::size_t i = 0; i < sets.size(); ++i) {
      const char* colour = kColours[i % 6];
      // Each set drawn 1.5 points wider than the next, so curves that coincide (the two paths of
      // a case, warp and weft at k = 1) stay visible as a coloured rim.
      const std::string lw =
          fmt::format("{:g}", 2.5 + 1.5 * static_cast<double>(sets.size() - 1 - i));
      gp << (i ? ", \\\n     " : "") << quoted(data.string()) << " index " << i
         << " using 1:2 with lines lw " << lw << " lc rgb '" << colour << "' title "
         << quoted(sets[i].label + " warp") << ", \\\n     " << quoted(data.string()) << " index "
         << i << " using 3:4 with lines lw " << lw << " dt 2 lc rgb '" << colour << "' title "
         << quoted(sets[i].label + " weft");
    }
    gp << "\n";
  }
  run_gnuplot(script);
}

void contact_map(const std::vector<Eigen::Matrix3Xd>& yarns, const Eigen::Matrix3Xd& points,
                 const Eigen::VectorXd& forces, const std::string& title,
                 const std::filesystem::path& png) {
  const std::filesystem::path base = std::filesystem::path(png).replace_extension();
  const std::filesystem::path yarn_data = base.string() + "-yarns.dat";
  const std::filesystem::path point_data = base.string() + "-points.dat";
  {
    std::ofstream out(yarn_data);
    out << "# x [mm] y [mm]: yarn centre lines, one block per yarn\n";
    for (const Eigen::Matrix3Xd& y : yarns) {
      for (Eigen::Index i = 0; i < y.cols(); ++i)
        out << 1e3 * y(0, i) << ' ' << 1e3 * y(1, i) << '\n';
      out << '\n';
    }
  }
  double fmax = 0;
  {
    std::ofstream out(point_data);
    out << "# x [mm] y [mm] force [N]\n";
    for (Eigen::Index i = 0; i < points.cols(); ++i) {
      out << 1e3 * points(0, i) << ' ' << 1e3 * points(1, i) << ' ' << forces(i) << '\n';
      fmax = std::max(fmax, forces(i));
    }
  }
  const std::filesystem::path script = base.string() + ".gp";
  {
    std::ofstream gp(script);
    gp << "set terminal pngcairo size 900,820 enhanced font 'Sans,13'\n"
       << "set output " << quoted(png.string()) << "\n"
       << "set title " << quoted(title) << "\n"
       << "set xlabel 'x (warp direction) [mm]'\nset ylabel 'y (weft direction) [mm]'\n"
       << "set size ratio -1\nset key off\n"
       << "set cblabel 'normal contact force [N]'\nset palette rgb 33,13,10\n"
       << "set cbrange [0:" << (fmax > 0 ? fmax : 1) << "]\n"
       << "plot " << quoted(yarn_data.string())
       << " using 1:2 with lines lw 1 lc rgb '#b0b0b0', \\\n"
       << "     " << quoted(point_data.string()) << " using 1:2:(0.6 + 2.4 * $3 / "
       << (fmax > 0 ? fmax : 1) << "):3 with points pt 7 ps variable lc palette\n";
  }
  run_gnuplot(script);
}

namespace {

/// Whether a curve has a point to draw.
bool drawable(const Curve& c) {
  for (std::size_t i = 0; i < std::min(c.x.size(), c.y.size()); ++i)
    if (std::isfinite(c.x[i]) && std::isfinite(c.y[i]))
      return true;
  return false;
}

} // namespace

void line_graphs(const std::vector<Graph>& graphs, const std::string& title,
                 const std::filesystem::path& png) {
  if (graphs.empty())
    throw std::invalid_argument(fmt::format("line_graphs: no graph to draw in {}", png.string()));
  for (const Graph& g : graphs) {
    if (!std::any_of(g.curves.begin(), g.curves.end(), drawable))
      throw std::invalid_argument(fmt::format("line_graphs: graph '{}' of {} has no point to draw",
                                              g.y_label, png.string()));
    for (const Curve& c : g.curves)
      if (c.x.size() != c.y.size())
        throw std::invalid_argument(
            fmt::format("line_graphs: curve '{}' of {} has {} x values and {} y values", c.label,
                        png.string(), c.x.size(), c.y.size()));
  }
  const std::filesystem::path base = std::filesystem::path(png).replace_extension();
  const std::filesystem::path data = base.string() + ".dat";
  // The data blocks: per graph its drawable curves, then its y = x segment (if asked for).
  struct Block {
    std::size_t graph;
    const Curve* curve; ///< null: the y = x segment
  };
  std::vector<Block> blocks;
  {
    std::ofstream out(data);
    out.precision(10);
    out << "# x y: one block per curve (graph by graph; the line y = x last in its graph)\n";
    for (std::size_t g = 0; g < graphs.size(); ++g) {
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      for (const Curve& c : graphs[g].curves) {
        if (!drawable(c))
          continue;
        out << "# " << graphs[g].y_label << ": " << c.label << '\n';
        for (std::size_t i = 0; i < c.x.size(); ++i)
          if (std::isfinite(c.x[i]) && std::isfinite(c.y[i])) {
            out << c.x[i] << ' ' << c.y[i] << '\n';
            lo = std::min(lo, c.x[i]);
            hi = std::max(hi, c.x[i]);
          }
        out << "\n\n";
        blocks.push_back({g, &c});
      }
      if (!graphs[g].identity.empty()) {
        out << "# " << graphs[g].identity << '\n'
            << lo << ' ' << lo << '\n'
            << hi << ' ' << hi << "\n\n\n";
        blocks.push_back({g, nullptr});
      }
    }
  }
  const std::filesystem::path script = base.string() + ".gp";
  {
    std::ofstream gp(script);
    const std::size_t n = graphs.size();
    gp << "set terminal pngcairo size " << (n == 1 ? 1000 : 850 * n) << ",700 noenhanced font "
       << "'Sans,13'\n"
       << "set output " << quoted(png.string()) << "\n";
    if (n == 1)
      gp << "set title "
         << quoted(graphs[0].title.empty() ? title : title + "\\n" + graphs[0].title) << "\n";
    else
      gp << "set multiplot layout 1," << n << " title " << quoted(title) << "\n";
    for (std::size_t g = 0; g < n; ++g) {
      const Graph& graph = graphs[g];
      if (n > 1)
        gp << "set title " << quoted(graph.title) << "\n";
      gp << "set xlabel " << quoted(graph.x_label) << "\nset ylabel " << quoted(graph.y_label)
         << "\nset key top left box opaque\nset grid\nplot ";
      bool first = true;
      for (std::size_t b = 0; b < blocks.size(); ++b) {
        if (blocks[b].graph != g)
          continue;
        gp << (first ? "" : ", \\\n     ") << quoted(data.string()) << " index " << b
           << " using 1:2 with lines ";
        first = false;
        if (const Curve* c = blocks[b].curve)
          gp << "lw " << fmt::format("{:g}", c->line_width) << (c->dashed ? " dt 2" : "")
             << " lc rgb '" << kColours[static_cast<std::size_t>(std::max(0, c->colour)) % 6]
             << "' title " << quoted(c->label);
        else
          gp << "lw 1.5 dt 3 lc rgb '#606060' title " << quoted(graph.identity);
      }
      gp << "\n";
    }
    if (n > 1)
      gp << "unset multiplot\n";
  }
  run_gnuplot(script);
}

void coloured_specimens(const std::vector<SpecimenView>& views, const std::string& colour_label,
                        const std::string& title, const std::filesystem::path& png) {
  if (views.empty())
    throw std::invalid_argument(
        fmt::format("coloured_specimens: no view to draw in {}", png.string()));
  const std::filesystem::path base = std::filesystem::path(png).replace_extension();
  const std::filesystem::path yarn_data = base.string() + "-yarns.dat";
  const std::filesystem::path point_data = base.string() + "-points.dat";
  // One range for every view (mm) and one for the colour bar.
  Eigen::AlignedBox2d box;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  {
    std::ofstream out(yarn_data);
    out.precision(10);
    out << "# x [mm] y [mm]: yarn centre lines, one line per yarn, one block per view\n";
    for (const SpecimenView& v : views) {
      out << "# " << v.title << '\n';
      for (const Eigen::Matrix3Xd& y : v.yarns) {
        for (Eigen::Index i = 0; i < y.cols(); ++i) {
          out << 1e3 * y(0, i) << ' ' << 1e3 * y(1, i) << '\n';
          box.extend(Eigen::Vector2d(1e3 * y(0, i), 1e3 * y(1, i)));
        }
        out << '\n';
      }
      if (v.yarns.empty()) // the view's block still counts for gnuplot's index
        out << "NaN NaN\n\n";
      out << '\n'; // the second blank line: the end of the view's block
    }
  }
  {
    std::ofstream out(point_data);
    out.precision(10);
    out << "# x [mm] y [mm] value (" << colour_label << "): one block per view\n";
    for (const SpecimenView& v : views) {
      if (static_cast<std::size_t>(v.points.cols()) != v.values.size())
        throw std::invalid_argument(
            fmt::format("coloured_specimens: view '{}' has {} points and {} values", v.title,
                        v.points.cols(), v.values.size()));
      out << "# " << v.title << '\n';
      for (Eigen::Index i = 0; i < v.points.cols(); ++i) {
        out << 1e3 * v.points(0, i) << ' ' << 1e3 * v.points(1, i) << ' ' << v.values[i] << '\n';
        box.extend(1e3 * v.points.col(i));
        if (std::isfinite(v.values[i])) {
          lo = std::min(lo, v.values[i]);
          hi = std::max(hi, v.values[i]);
        }
      }
      // A view without points still needs its block (gnuplot's index counts them).
      if (v.points.cols() == 0)
        out << "NaN NaN NaN\n";
      out << "\n\n";
    }
  }
  if (box.isEmpty())
    throw std::invalid_argument(
        fmt::format("coloured_specimens: nothing to draw in {}", png.string()));
  if (!(lo <= hi))
    lo = hi = 0;
  if (hi - lo < 1e-9 * std::max(1.0, std::abs(hi))) { // one value: a bar around it
    lo -= 0.5;
    hi += 0.5;
  }
  const Eigen::Vector2d pad = 0.04 * box.sizes().cwiseMax(1e-6);
  const Eigen::Vector2d low = box.min() - pad, high = box.max() + pad;
  // The grid: two columns (one for a single view; a row of up to four for a specimen more than
  // half as tall again as it is wide, a bias extension's), the colour bar in a strip on the right.
  const bool tall = box.sizes().y() > 1.5 * box.sizes().x();
  const std::size_t columns = views.size() == 1 ? 1
                              : tall            ? std::min<std::size_t>(views.size(), 4)
                                                : 2;
  const std::size_t rows = (views.size() + columns - 1) / columns;
  const double strip = 0.12, top = 0.06;
  const double width = (1 - strip) / static_cast<double>(columns);
  const double height = (1 - top) / static_cast<double>(rows);
  const std::filesystem::path script = base.string() + ".gp";
  {
    std::ofstream gp(script);
    gp << "set terminal pngcairo size "
       << (columns == 1   ? 900
           : columns == 2 ? 1400
                          : 1800)
       << ','
       << (columns > 2 ? 1000
           : rows == 1 ? 820
                       : 620 * rows + 60)
       << " noenhanced font 'Sans,12'\n"
       << "set output " << quoted(png.string()) << "\n"
       << "set multiplot title " << quoted(title) << "\n"
       << "set xlabel 'x [mm]'\nset ylabel 'y [mm]'\nset key off\nset grid\n"
       << "set xrange [" << low.x() << ':' << high.x() << "]\nset yrange [" << low.y() << ':'
       << high.y()
       << "]\n"
       // Blue for the smallest value to red for the largest (ColorBrewer's RdYlBu, reversed).
       << "set palette defined (0 '#313695', 1 '#4575b4', 2 '#74add1', 3 '#abd9e9', "
          "4 '#fee090', 5 '#fdae61', 6 '#f46d43', 7 '#d73027', 8 '#a50026')\n"
       << "set cbrange [" << lo << ':' << hi << "]\nset cblabel " << quoted(colour_label) << "\n";
    for (std::size_t k = 0; k < views.size(); ++k) {
      const std::size_t row = k / columns, column = k % columns;
      gp << "set origin " << width * static_cast<double>(column) << ','
         << height * static_cast<double>(rows - 1 - row) << "\nset size ratio -1 " << width << ','
         << height << "\nset title " << quoted(views[k].title) << "\n";
      // The shared colour bar: drawn once, in screen coordinates of the whole picture.
      if (k == 0)
        gp << "set colorbox user origin " << 1 - strip + 0.02 << ",0.2 size 0.025,0.6\n";
      else
        gp << "unset colorbox\n";
      gp << "plot " << quoted(yarn_data.string()) << " index " << k
         << " using 1:2 with lines lw 1.5 lc rgb '#9a9a9a', \\\n     "
         << quoted(point_data.string()) << " index " << k
         << " using 1:2:3 with points pt 7 ps 2.2 lc palette, \\\n     "
         << quoted(point_data.string()) << " index " << k
         << " using 1:2 with points pt 6 ps 2.2 lw 0.8 lc rgb '#303030'\n";
    }
    gp << "unset multiplot\n";
  }
  run_gnuplot(script);
}

} // namespace yarnsim::plots
