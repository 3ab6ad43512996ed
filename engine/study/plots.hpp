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

} // namespace yarnsim::plots
