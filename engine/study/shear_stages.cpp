#include "engine/study/shear_stages.hpp"

#include "engine/output/hdf5.hpp"
#include "engine/textile/shear_tests.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <stdexcept>

namespace yarnsim {

const std::vector<CrossingNodes>& shear_crossings(const Model& model) {
  if (model.picture_frame)
    return model.picture_frame->all;
  if (model.bias_extension)
    return model.bias_extension->all;
  throw std::invalid_argument(fmt::format(
      "model '{}' has no shear test ([picture_frame] or [bias_extension])", model.title));
}

int stage_step(double fraction, int steps) {
  if (!(fraction > 0 && fraction <= 1))
    throw std::invalid_argument(
        fmt::format("expected a fraction of the run in (0, 1], found {}", fraction));
  if (steps < 1)
    throw std::invalid_argument(
        fmt::format("expected at least one output step to draw, found {}", steps));
  // The tolerance keeps a product such as 0.3 x 10 = 3.0000000000000004 at step 3.
  const int k = static_cast<int>(std::ceil(fraction * steps - 1e-9)) - 1;
  return std::clamp(k, 0, steps - 1);
}

std::vector<ShearStage> read_shear_stages(const Model& model, const std::filesystem::path& results,
                                          std::span<const double> fractions) {
  namespace h5 = output::h5;
  const std::vector<CrossingNodes>& crossings = shear_crossings(model);
  const std::vector<CrossingNodes>& central =
      model.picture_frame ? model.picture_frame->central : model.bias_extension->central;
  const char* angle = model.picture_frame ? "frame_angle" : "ideal_angle";
  const h5::Handle file = h5::open_file_read_only(results);
  std::vector<ShearStage> out;
  if (!h5::exists(file.id(), "steps"))
    return out;
  const h5::Handle steps = h5::open_group(file.id(), "steps");
  const std::vector<std::string> names = h5::link_names(steps.id());
  if (names.empty())
    return out;
  const Eigen::Index n_nodes = static_cast<Eigen::Index>(model.nodes.size());
  for (const double fraction : fractions) {
    ShearStage s;
    s.fraction = fraction;
    s.step = stage_step(fraction, static_cast<int>(names.size()));
    const h5::Handle group = h5::open_group(steps.id(), names[s.step]);
    s.increment = h5::read_int_attribute(group.id(), "increment");
    s.time = h5::read_double_attribute(group.id(), "time");
    s.test_angle = h5::read_double_attribute(group.id(), angle);
    std::vector<hsize_t> dims;
    const std::vector<double> x = h5::read_doubles(group.id(), "positions", &dims);
    if (dims.size() != 2 || dims[0] != static_cast<hsize_t>(n_nodes) || dims[1] != 3)
      throw std::runtime_error(fmt::format(
          "{}: /steps/{}/positions has shape ({}), expected ({}, 3): not a run of this model",
          results.string(), names[s.step], fmt::join(dims, ", "), n_nodes));
    // Node-major (n_nodes, 3) rows are the columns of a column-major 3 x n_nodes matrix.
    s.positions = Eigen::Map<const Eigen::Matrix3Xd>(x.data(), 3, n_nodes);
    s.measured = textile::measure_shear(central, s.positions).mean;
    s.shear = textile::local_shear(crossings, s.positions);
    s.crossings.resize(2, static_cast<Eigen::Index>(crossings.size()));
    for (std::size_t k = 0; k < crossings.size(); ++k)
      s.crossings.col(static_cast<Eigen::Index>(k)) =
          0.5 *
          (s.positions.col(crossings[k].warp[1]) + s.positions.col(crossings[k].weft[1])).head<2>();
    out.push_back(std::move(s));
  }
  return out;
}

std::vector<Eigen::Matrix3Xd> centre_lines(const Model& model, const Eigen::Matrix3Xd& x) {
  std::vector<Eigen::Matrix3Xd> lines;
  std::vector<int> nodes; // of the line being chained
  auto finish = [&] {
    if (nodes.empty())
      return;
    Eigen::Matrix3Xd line(3, static_cast<Eigen::Index>(nodes.size()));
    for (std::size_t i = 0; i < nodes.size(); ++i)
      line.col(static_cast<Eigen::Index>(i)) = x.col(nodes[i]);
    lines.push_back(std::move(line));
    nodes.clear();
  };
  for (const BeamElement& e : model.elements) {
    if (nodes.empty() || nodes.back() != e.nodes[0]) {
      finish();
      nodes.push_back(e.nodes[0]);
    }
    nodes.push_back(e.nodes[1]);
    nodes.push_back(e.nodes[2]);
  }
  finish();
  return lines;
}

} // namespace yarnsim
