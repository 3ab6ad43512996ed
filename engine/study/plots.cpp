#include "engine/study/plots.hpp"

#include <cstdlib>
#include <fmt/format.h>
#include <fstream>
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

} // namespace yarnsim::plots
