#pragma once
// Pictures drawn by gnuplot (Debian's gnuplot-nox, pngcairo terminal), driven by the program:
// data and script are written next to the image, so a user can restyle and redraw them.

#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

namespace yarnsim::plots {

/// One force-strain curve pair (warp and weft) of a run.
struct CurveSet {
  std::string label;               ///< legend, e.g. "Spline (12 s)"
  std::vector<double> strain_warp; ///< -
  std::vector<double> strain_weft; ///< -
  std::vector<double> force_warp;  ///< N
  std::vector<double> force_weft;  ///< N
};

/// Force against strain, warp solid and weft dashed, one colour per curve set, each set wider
/// than the next so that coinciding curves stay visible. Throws
/// std::runtime_error when gnuplot is missing or fails.
void force_strain(const std::vector<CurveSet>& sets, const std::string& title,
                  const std::filesystem::path& png);

/// Normal contact forces as discs over the fabric (x, y in mm), size and colour by force, with
/// the yarns' centre lines (polylines of final positions) in grey.
void contact_map(const std::vector<Eigen::Matrix3Xd>& yarns, const Eigen::Matrix3Xd& points,
                 const Eigen::VectorXd& forces, const std::string& title,
                 const std::filesystem::path& png);

/// One curve of a line graph: y against x. Points where either is NaN or infinite are left out
/// (the line joins its neighbours).
struct Curve {
  std::string label;     ///< legend entry
  std::vector<double> x; ///< in the graph's x unit
  std::vector<double> y; ///< in the graph's y unit
  int colour = 0;        ///< index into the palette (repeats after 6)
  bool dashed = false;   ///< dashed, else solid
  double line_width = 2.5;
};

/// One graph of a picture: its curves, axis labels with units, and optionally the line y = x.
struct Graph {
  std::string title;   ///< above the graph; empty: none
  std::string x_label; ///< e.g. "frame angle [deg]"
  std::string y_label;
  std::vector<Curve> curves;
  /// Also draw y = x over the curves' x range, grey and dotted, with this legend entry (empty:
  /// no such line): where a measured value equals the one it is plotted against.
  std::string identity;
};

/// The graphs side by side in one picture under `title`, each axis scaled to its data, a legend
/// per graph. Data (one block per curve) and script are written next to the image, as for
/// force_strain. Throws std::runtime_error when gnuplot is missing or fails.
void line_graphs(const std::vector<Graph>& graphs, const std::string& title,
                 const std::filesystem::path& png);

/// One view of a specimen: yarn centre lines and points coloured by a value.
struct SpecimenView {
  std::string title;                   ///< above the view
  std::vector<Eigen::Matrix3Xd> yarns; ///< centre lines, polylines of positions, m
  Eigen::Matrix2Xd points;             ///< in-plane positions of the coloured points, m
  std::vector<double> values;          ///< one per point (the colour bar's unit)
};

/// The views of a specimen (x, y in mm, all at one scale over the same ranges) in a grid of two
/// columns: yarn centre lines in grey, each point a disc coloured by its value on one colour bar
/// shared by every view (its range spans the values of all of them), labelled `colour_label`.
/// Data and script next to the image. Throws std::runtime_error when gnuplot fails.
void coloured_specimens(const std::vector<SpecimenView>& views, const std::string& colour_label,
                        const std::string& title, const std::filesystem::path& png);

} // namespace yarnsim::plots
