#include "engine/textile/shear_tests.hpp"

#include "engine/textile/shear_kinematics.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <numbers>
#include <optional>
#include <stdexcept>

namespace yarnsim::textile {

namespace {

constexpr double kDegree = std::numbers::pi / 180;
/// Tabulation of a test's nonlinear motions in time.
constexpr int kIntervals = 400;

Eigen::Vector2d in_plane(const Eigen::Vector3d& v) {
  return v.head<2>();
}

/// The node triple (prev, at, next) of position k along a yarn's nodes (one-sided at an end).
std::array<int, 3> around(const std::vector<int>& nodes, std::size_t k) {
  return {nodes[k == 0 ? 0 : k - 1], nodes[k], nodes[std::min(k + 1, nodes.size() - 1)]};
}

} // namespace

std::vector<CrossingNodes>
find_crossings(const Fabric& fabric, const std::function<bool(const Eigen::Vector2d&)>& inside) {
  const Model& model = fabric.model;
  if (model.nodes.empty())
    return {};
  Eigen::AlignedBox2d box;
  for (const Eigen::Vector3d& x : model.nodes)
    box.extend(in_plane(x));
  const double tol = 1e-9 * std::max(box.diagonal().norm(), 1e-300);
  // Weft nodes by x: (x, yarn, position along it).
  struct Entry {
    double x;
    std::size_t yarn, k;
  };
  std::vector<Entry> weft;
  for (std::size_t y = 0; y < fabric.yarns.size(); ++y)
    if (!fabric.yarns[y].warp)
      for (std::size_t k = 0; k < fabric.yarns[y].nodes.size(); ++k)
        weft.push_back({model.nodes[fabric.yarns[y].nodes[k]].x(), y, k});
  std::sort(weft.begin(), weft.end(), [](const Entry& a, const Entry& b) {
    return a.x < b.x || (a.x == b.x && (a.yarn < b.yarn || (a.yarn == b.yarn && a.k < b.k)));
  });
  std::vector<CrossingNodes> out;
  for (const Yarn& warp : fabric.yarns) {
    if (!warp.warp)
      continue;
    for (std::size_t k = 0; k < warp.nodes.size(); ++k) {
      const Eigen::Vector2d p = in_plane(model.nodes[warp.nodes[k]]);
      if (!inside(p))
        continue;
      auto it = std::lower_bound(weft.begin(), weft.end(), p.x() - tol,
                                 [](const Entry& e, double v) { return e.x < v; });
      for (; it != weft.end() && it->x <= p.x() + tol; ++it) {
        const Yarn& w = fabric.yarns[it->yarn];
        if (std::abs(model.nodes[w.nodes[it->k]].y() - p.y()) <= tol)
          out.push_back({around(warp.nodes, k), around(w.nodes, it->k)});
      }
    }
  }
  return out;
}

namespace {

/// The shear angle at one crossing, degrees: 90 less the in-plane angle from the warp's tangent
/// to the weft's (in (-180, 180], 90 in the reference).
double crossing_shear(const CrossingNodes& c, const Eigen::Matrix3Xd& x) {
  const Eigen::Vector2d a = (x.col(c.warp[2]) - x.col(c.warp[0])).head<2>();
  const Eigen::Vector2d b = (x.col(c.weft[2]) - x.col(c.weft[0])).head<2>();
  return 90 - std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b)) / kDegree;
}

} // namespace

MeasuredShear measure_shear(const std::vector<CrossingNodes>& crossings,
                            const Eigen::Matrix3Xd& x) {
  MeasuredShear out;
  if (crossings.empty())
    return out;
  double sum = 0, sum2 = 0;
  out.min = std::numeric_limits<double>::infinity();
  out.max = -out.min;
  for (const CrossingNodes& c : crossings) {
    const double gamma = crossing_shear(c, x);
    sum += gamma;
    sum2 += gamma * gamma;
    out.min = std::min(out.min, gamma);
    out.max = std::max(out.max, gamma);
  }
  const double n = static_cast<double>(crossings.size());
  out.mean = sum / n;
  out.spread = std::sqrt(std::max(0.0, sum2 / n - out.mean * out.mean));
  return out;
}

namespace {

/// The frame's arms at shear angle gamma (rad): e1 (the arm along x turned by +gamma/2) and e2
/// (the arm along y turned by -gamma/2), and their derivatives in gamma.
struct FrameArms {
  Eigen::Vector2d e1, e2, de1, de2;
  explicit FrameArms(double gamma) {
    const double c = std::cos(gamma / 2), s = std::sin(gamma / 2);
    e1 = {c, s};
    e2 = {s, c};
    de1 = 0.5 * Eigen::Vector2d(-s, c);
    de2 = 0.5 * Eigen::Vector2d(c, -s);
  }
};

} // namespace

void add_picture_frame_test(Fabric& fabric, const PictureFrameParameters& p) {
  auto fail = [](const std::string& message) {
    throw std::invalid_argument("picture frame: " + message);
  };
  if (!(p.max_angle > 0 && p.max_angle < 90))
    fail(fmt::format("expected a maximum shear angle in (0, 90) degrees, found {}", p.max_angle));
  if (!(p.central_region > 0 && p.central_region <= 1))
    fail(fmt::format("expected a central region in (0, 1] of the frame's side, found {}",
                     p.central_region));
  if (!(p.pretension >= 0 && p.pretension < 0.1))
    fail(fmt::format("expected a pretension strain in [0, 0.1), found {}", p.pretension));
  if (!(p.pretension_time >= 0) || !std::isfinite(p.pretension_time))
    fail(fmt::format("expected a pretension time >= 0, found {}", p.pretension_time));
  Model& model = fabric.model;
  const double t0 = model.steps.empty() ? 0.0 : model.steps.back().end_time;
  // The pretension's step: the test's settings over its own duration, default increments.
  std::optional<SolutionStep> pretension_step;
  double t_shear = t0;
  const double T_pre = p.pretension_time > 0 ? p.pretension_time : p.loading_time / 5;
  if (p.pretension > 0) {
    pretension_step = preliminary_step(p, T_pre, t0, "picture frame (pretension)");
    t_shear = t0 + T_pre;
  }
  const SolutionStep step = loading_step(p, t_shear, "picture frame");

  // The square of the yarn ends: warp yarns from x min to x max, weft from y min to y max.
  Eigen::AlignedBox2d box;
  int n_warp = 0, n_weft = 0;
  for (const Yarn& y : fabric.yarns) {
    box.extend(in_plane(model.nodes[y.nodes.front()]));
    box.extend(in_plane(model.nodes[y.nodes.back()]));
    (y.warp ? n_warp : n_weft) += 1;
  }
  if (n_warp == 0 || n_weft == 0)
    fail("expected warp and weft yarns, found only one direction");
  const double L = box.sizes().x();
  const double tol = 1e-9 * L;
  if (!(L > 0) || std::abs(box.sizes().y() - L) > tol)
    fail(fmt::format("expected the yarn ends on the sides of a square (length_warp = "
                     "length_weft), found {} x {} m",
                     box.sizes().x(), box.sizes().y()));
  const Eigen::Vector2d A = box.min();
  for (const Yarn& y : fabric.yarns) {
    const Eigen::Vector2d a = in_plane(model.nodes[y.nodes.front()]);
    const Eigen::Vector2d b = in_plane(model.nodes[y.nodes.back()]);
    const int along = y.warp ? 0 : 1;
    if (std::abs(a(along) - box.min()(along)) > tol || std::abs(b(along) - box.max()(along)) > tol)
      fail(fmt::format("yarn {} does not run from one arm of the frame to the opposite one (its "
                       "ends at ({}, {}) and ({}, {}) m; the frame's corners at ({}, {}) and "
                       "({}, {}) m)",
                       yarn_name(y), a.x(), a.y(), b.x(), b.y(), box.min().x(), box.min().y(),
                       box.max().x(), box.max().y()));
  }

  PictureFrameTest test;
  test.side = L;
  test.corner = A;
  test.max_angle = p.max_angle * kDegree;
  test.clamped = p.clamped;
  test.central_region = p.central_region;
  test.shear_start = t_shear;
  const double T = p.loading_time;
  // s(t) and gamma(t): the pretension at gamma = 0, then the shear at its full stretch.
  test.stretch = TimeTable{};
  test.angle = TimeTable{};
  if (p.pretension > 0)
    for (int i = 0; i < kIntervals; ++i) {
      const double tau = static_cast<double>(i) / kIntervals;
      test.stretch.time.push_back(t0 + tau * T_pre);
      test.stretch.value.push_back(1 + p.pretension * ramp_fraction(p.ramp, tau));
      test.angle.time.push_back(t0 + tau * T_pre);
      test.angle.value.push_back(0.0);
    }
  for (int i = 0; i <= kIntervals; ++i) {
    const double tau = static_cast<double>(i) / kIntervals;
    const double t = i == kIntervals ? t_shear + T : t_shear + tau * T;
    test.stretch.time.push_back(t);
    test.stretch.value.push_back(1 + p.pretension);
    test.angle.time.push_back(t);
    test.angle.value.push_back(test.max_angle * ramp_fraction(p.ramp, tau));
  }
  const Eigen::Vector2d centre = A + Eigen::Vector2d(L / 2, L / 2);
  for (const Yarn& y : fabric.yarns) {
    for (const bool start : {true, false}) {
      const int node = start ? y.nodes.front() : y.nodes.back();
      const int set = model.find_node_set(yarn_name(y) + (start ? ".start" : ".end"));
      if (set < 0)
        fail(fmt::format("the fabric has no node set '{}{}'", yarn_name(y),
                         start ? ".start" : ".end"));
      const Eigen::Vector2d X = in_plane(model.nodes[node]) - A;
      PrescribedMotion motion;
      motion.node_set = set;
      TimeTable ux, uy, phi;
      for (std::size_t i = 0; i < test.angle.time.size(); ++i) {
        const FrameArms arms(test.angle.value[i]);
        const double stretch = test.stretch.value[i];
        // x = A' + s F(gamma) (X - A) with A' = c + s (A - c); u = x - X, X taken from A.
        const Eigen::Vector2d corner = centre + stretch * (A - centre);
        const Eigen::Vector2d u = corner - A + stretch * (X.x() * arms.e1 + X.y() * arms.e2) - X;
        for (TimeTable* t : {&ux, &uy, &phi})
          t->time.push_back(test.angle.time[i]);
        ux.value.push_back(u.x());
        uy.value.push_back(u.y());
        // A weft end sits on an arm along x (turning by +gamma/2), a warp end on one along y.
        phi.value.push_back((y.warp ? -0.5 : 0.5) * test.angle.value[i]);
      }
      motion.displacement = {ux, uy, TimeTable::constant(0.0)};
      if (p.clamped)
        motion.rotation =
            std::array<TimeTable, 3>{TimeTable::constant(0.0), TimeTable::constant(0.0), phi};
      model.prescribed.push_back(std::move(motion));
      test.ends.push_back(node);
      test.end_on_x_arm.push_back(!y.warp);
    }
  }
  const double half = p.central_region * L / 2 * (1 + 1e-12);
  test.central = find_crossings(fabric, [&](const Eigen::Vector2d& q) {
    return std::abs(q.x() - centre.x()) <= half && std::abs(q.y() - centre.y()) <= half;
  });
  if (test.central.empty())
    fail(fmt::format("no crossing lies in the central region ({} of the side {} m)",
                     p.central_region, L));
  test.all = find_crossings(fabric, [](const Eigen::Vector2d&) { return true; });
  // Locking: the first direction whose neighbouring yarns touch, acos(w / p).
  test.locking_angle = std::numbers::pi / 2;
  for (const bool warp : {true, false}) {
    std::vector<double> across;
    double width = 0;
    for (const Yarn& y : fabric.yarns)
      if (y.warp == warp) {
        across.push_back(model.nodes[y.nodes.front()](warp ? 1 : 0));
        // The yarn's in-plane width (Spline::width; finish_fabric names the spline as the yarn).
        for (const Spline& spline : model.splines)
          if (spline.name == yarn_name(y))
            width = std::max(width, spline.width);
      }
    if (across.size() < 2)
      continue;
    std::sort(across.begin(), across.end());
    const double spacing = (across.back() - across.front()) / (across.size() - 1);
    test.locking_angle =
        std::min(test.locking_angle, width < spacing ? locking_angle(width, spacing) : 0.0);
  }
  if (pretension_step)
    model.steps.push_back(*pretension_step);
  model.steps.push_back(step);
  model.picture_frame = std::move(test);
}

PictureFrameReading read_picture_frame(const Model& model, double time, const Eigen::Matrix3Xd& x,
                                       const Eigen::Matrix<double, 6, Eigen::Dynamic>& reactions) {
  const PictureFrameTest& test = *model.picture_frame;
  const double stretch = test.stretch.at(time);
  const double L = test.side * stretch;
  const double gamma = test.angle.at(time);
  const FrameArms arms(gamma);
  // The power of the reactions per unit rate of gamma, then per unit rate of d.
  double power = 0;
  for (std::size_t k = 0; k < test.ends.size(); ++k) {
    const int n = test.ends[k];
    const Eigen::Vector2d X = in_plane(model.nodes[n]) - test.corner;
    const Eigen::Vector2d dx = stretch * (X.x() * arms.de1 + X.y() * arms.de2);
    power += reactions.col(n).head<2>().dot(dx);
    if (test.clamped)
      power += reactions(5, n) * (test.end_on_x_arm[k] ? 0.5 : -0.5);
  }
  PictureFrameReading out;
  out.frame_angle = gamma / kDegree;
  out.displacement = picture_frame_displacement(gamma, L);
  const double dd_dgamma = L * std::sin(std::numbers::pi / 4 - gamma / 2);
  out.force = power / dd_dgamma;
  out.shear_force = picture_frame_shear_force(out.force, gamma);
  out.normalised_shear_force = picture_frame_normalised_force(out.force, gamma, L, L);
  out.measured = measure_shear(test.central, x);
  out.side = L;
  return out;
}

void add_bias_extension_test(Fabric& fabric, const BiasSpecimenParameters& specimen,
                             const BiasExtensionParameters& p) {
  auto fail = [](const std::string& message) {
    throw std::invalid_argument("bias extension: " + message);
  };
  if (!(p.max_angle > 0 && p.max_angle < 90))
    fail(fmt::format("expected a maximum shear angle in (0, 90) degrees, found {}", p.max_angle));
  if (!(p.central_region > 0 && p.central_region <= 1))
    fail(fmt::format("expected a central region in (0, 1] of zone C, found {}", p.central_region));
  if (specimen.angle != 45)
    fail(fmt::format("expected the yarns at 45 degrees to the pull, found {} degrees",
                     specimen.angle));
  const double H = specimen.height - 2 * specimen.clamp_length;
  const double W = specimen.width;
  if (!textile::bias_extension_zones_fit(H, W))
    fail(fmt::format("expected a free length H - 2 clamp_length >= 2 W = {} m (the three zones "
                     "of the test and the benchmark's energy method need it), found {} m",
                     2 * W, H));
  if (!(p.compaction >= 0) || !std::isfinite(p.compaction))
    fail(fmt::format("expected a compaction >= 0 m, found {}", p.compaction));
  if (!(p.compaction_time >= 0) || !std::isfinite(p.compaction_time))
    fail(fmt::format("expected a compaction time >= 0 s, found {}", p.compaction_time));
  Model& model = fabric.model;
  const double t0 = model.steps.empty() ? 0.0 : model.steps.back().end_time;
  // The compaction's step: the test's settings over its own duration, default increments.
  std::optional<SolutionStep> compaction_step;
  double t_pull = t0;
  if (p.compaction > 0) {
    auto crossing =
        std::find_if(model.spline_contacts.begin(), model.spline_contacts.end(),
                     [](const SplineContactDefinition& c) { return c.name == "warp-weft"; });
    if (crossing == model.spline_contacts.end())
      fail("a compaction needs the spline contact 'warp-weft' between the crossing yarns (the "
           "surface contact has no compaction in this version)");
    const double T_c = p.compaction_time > 0 ? p.compaction_time : p.loading_time / 5;
    compaction_step = preliminary_step(p, T_c, t0, "bias extension (compaction)");
    t_pull = t0 + T_c;
    crossing->compaction = ramp_table(t0, t_pull, p.compaction, p.ramp);
  }
  const SolutionStep step = loading_step(p, t_pull, "bias extension");

  BiasExtensionTest test;
  test.pull_start = t_pull;
  test.compaction = p.compaction;
  test.height = H;
  test.width = W;
  test.clamp_length = specimen.clamp_length;
  test.max_angle = p.max_angle * kDegree;
  test.central_region = p.central_region;
  test.bottom_clamp = model.find_node_set("clamp.bottom");
  test.top_clamp = model.find_node_set("clamp.top");
  if (test.bottom_clamp < 0 || test.top_clamp < 0)
    fail("the fabric has no node sets 'clamp.bottom' and 'clamp.top' (build_bias_specimen adds "
         "them)");
  test.displacement = ramp_table(t_pull, t_pull + p.loading_time,
                                 bias_extension_displacement(test.max_angle, H, W), p.ramp);
  for (const auto& [set, moves] : {std::pair{test.bottom_clamp, false}, {test.top_clamp, true}}) {
    PrescribedMotion clamp;
    clamp.node_set = set;
    clamp.displacement = {TimeTable::constant(0.0),
                          moves ? test.displacement : TimeTable::constant(0.0),
                          TimeTable::constant(0.0)};
    clamp.rotation = std::array<TimeTable, 3>{TimeTable::constant(0.0), TimeTable::constant(0.0),
                                              TimeTable::constant(0.0)};
    model.prescribed.push_back(std::move(clamp));
  }
  const double half_diagonal = p.central_region * (H - W) / 2 * (1 + 1e-12);
  test.central = find_crossings(fabric, [&](const Eigen::Vector2d& q) {
    return std::abs(q.x()) + std::abs(q.y()) <= half_diagonal;
  });
  if (test.central.empty())
    fail(fmt::format("no crossing lies in the central region (|x| + |y| <= {} m)", half_diagonal));
  test.all = find_crossings(fabric, [](const Eigen::Vector2d&) { return true; });
  const WeaveParameters& w = specimen.weave;
  const double spacing = std::min(w.spacing_warp, w.spacing_weft);
  test.locking_angle = 2 * w.a < spacing ? locking_angle(2 * w.a, spacing) : 0.0;
  if (compaction_step)
    model.steps.push_back(*compaction_step);
  model.steps.push_back(step);
  model.bias_extension = std::move(test);
}

BiasExtensionReading
read_bias_extension(const Model& model, double time, const Eigen::Matrix3Xd& x,
                    const Eigen::Matrix<double, 6, Eigen::Dynamic>& reactions) {
  const BiasExtensionTest& test = *model.bias_extension;
  BiasExtensionReading out;
  out.displacement = test.displacement.at(time);
  for (const int n : model.node_sets[static_cast<std::size_t>(test.top_clamp)].nodes)
    out.force += reactions(1, n);
  out.ideal_angle =
      bias_extension_angle(std::max(0.0, out.displacement), test.height, test.width) / kDegree;
  out.measured = measure_shear(test.central, x);
  return out;
}

std::vector<double> local_shear(const std::vector<CrossingNodes>& crossings,
                                const Eigen::Matrix3Xd& x) {
  std::vector<double> out;
  out.reserve(crossings.size());
  for (const CrossingNodes& c : crossings)
    out.push_back(crossing_shear(c, x)); // measure_shear's values, the same doubles
  return out;
}

} // namespace yarnsim::textile
