#include "engine/textile/texgen.hpp"

#include "engine/model/deck.hpp"
#include "engine/textile/xml.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fmt/format.h>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace yarnsim::textile {

namespace {

enum class Interpolation { Bezier, Cubic };

/// A yarn section as written: type and full sizes in file units.
struct SectionSpec {
  std::string type = "CSectionEllipse";
  double width = 0;
  double height = 0;
  double power = 1; ///< CSectionPowerEllipse
  int line = 0;
};

/// A yarn path as TexGen stores it, in file units.
struct YarnSpec {
  std::vector<Eigen::Vector3d> nodes;
  std::vector<Eigen::Vector3d> tangents; ///< zero: computed
  std::vector<Eigen::Vector3d> ups;      ///< zero: z
  std::vector<Eigen::Vector3d> repeats;
  Interpolation interpolation = Interpolation::Bezier;
  bool periodic = true;
  bool force_master_tangent_in_plane = false;
  SectionSpec section;
  int line = 0;
  std::string what; ///< "Yarn index=3" for messages
};

class Reader {
public:
  Reader(std::string source, const TexGenOptions& options)
      : source_(std::move(source)), options_(options) {}

  Fabric read(std::string_view text) {
    const XmlElement root = parse_xml(text, source_);
    if (root.name != "TexGenModel")
      fail(root, fmt::format("expected the root element <TexGenModel>, found <{}>", root.name));
    const XmlElement* textile = nullptr;
    std::vector<std::string> names;
    for (const XmlElement* t : root.children_named("Textile")) {
      const std::string* name = t->attribute("name");
      names.push_back(name != nullptr ? *name : "");
      if (textile == nullptr && (options_.textile.empty() || (name && *name == options_.textile)))
        textile = t;
    }
    if (textile == nullptr)
      fail(root, options_.textile.empty() ? std::string("expected a <Textile>, found none")
                                          : fmt::format("no <Textile> named '{}' (found: {})",
                                                        options_.textile, fmt::join(names, ", ")));
    scale_ = length_scale(*textile);
    std::vector<YarnSpec> yarns;
    const bool has_pattern = textile->child("PatternCell") != nullptr;
    const bool has_yarns = textile->child("Yarn") != nullptr;
    const std::string* needs_building = textile->attribute("NeedsBuilding");
    const bool stale = needs_building != nullptr && *needs_building != "0";
    if (has_pattern && (!has_yarns || stale || options_.rebuild_weaves))
      yarns = weave_yarns(*textile);
    else if (has_yarns)
      for (const XmlElement* y : textile->children_named("Yarn"))
        yarns.push_back(explicit_yarn(*y));
    else
      fail(*textile, "expected <Yarn> elements or a weave pattern (<PatternCell>), found neither");
    return build(*textile, yarns);
  }

private:
  [[noreturn]] void fail(const XmlElement& e, const std::string& message) const {
    throw InputError({fmt::format("{}:{}: {}", source_, e.line, message)});
  }
  [[noreturn]] void fail(int line, const std::string& message) const {
    throw InputError({fmt::format("{}:{}: {}", source_, line, message)});
  }

  const std::string& attribute(const XmlElement& e, std::string_view key) const {
    const std::string* v = e.attribute(key);
    if (v == nullptr)
      fail(e, fmt::format("<{}> has no '{}' attribute", e.name, key));
    return *v;
  }

  std::vector<double> numbers(const XmlElement& e, std::string_view key,
                              const std::string& text) const {
    std::vector<double> out;
    std::string item;
    std::stringstream stream(text);
    while (std::getline(stream, item, ',')) {
      const char* begin = item.c_str();
      char* end = nullptr;
      errno = 0;
      const double v = std::strtod(begin, &end);
      bool rest_blank = true;
      for (const char* c = end; *c != '\0'; ++c)
        rest_blank = rest_blank && std::isspace(static_cast<unsigned char>(*c));
      if (end == begin || !rest_blank || !std::isfinite(v) || errno == ERANGE)
        fail(e, fmt::format("<{}> attribute '{}': expected numbers separated by commas, found "
                            "\"{}\"",
                            e.name, key, text));
      out.push_back(v);
    }
    return out;
  }

  double number(const XmlElement& e, std::string_view key) const {
    const std::vector<double> v = numbers(e, key, attribute(e, key));
    if (v.size() != 1)
      fail(e, fmt::format("<{}> attribute '{}': expected a number, found \"{}\"", e.name, key,
                          attribute(e, key)));
    return v[0];
  }
  double number_or(const XmlElement& e, std::string_view key, double fallback) const {
    return e.attribute(key) != nullptr ? number(e, key) : fallback;
  }
  int integer(const XmlElement& e, std::string_view key) const {
    const double v = number(e, key);
    if (v != std::floor(v) || std::abs(v) > 1e9)
      fail(e, fmt::format("<{}> attribute '{}': expected an integer, found \"{}\"", e.name, key,
                          attribute(e, key)));
    return static_cast<int>(v);
  }
  Eigen::Vector3d vector(const XmlElement& e, std::string_view key) const {
    const std::vector<double> v = numbers(e, key, attribute(e, key));
    if (v.size() != 3)
      fail(e, fmt::format("<{}> attribute '{}': expected 3 numbers \"x, y, z\", found \"{}\"",
                          e.name, key, attribute(e, key)));
    return {v[0], v[1], v[2]};
  }
  Eigen::Vector3d vector_or_zero(const XmlElement& e, std::string_view key) const {
    return e.attribute(key) != nullptr ? vector(e, key) : Eigen::Vector3d::Zero();
  }
  bool flag(const XmlElement& e, std::string_view key, bool fallback) const {
    const std::string* v = e.attribute(key);
    if (v == nullptr)
      return fallback;
    if (*v == "1" || *v == "true")
      return true;
    if (*v == "0" || *v == "false")
      return false;
    fail(e, fmt::format("<{}> attribute '{}': expected 0 or 1, found \"{}\"", e.name, key, *v));
  }

  double length_scale(const XmlElement& textile) const {
    if (options_.length_scale > 0)
      return options_.length_scale;
    const std::string* unit = textile.attribute("GeometryScale");
    if (unit == nullptr || *unit == "mm")
      return 1e-3;
    static const std::map<std::string, double> kUnits{
        {"m", 1.0}, {"cm", 1e-2}, {"um", 1e-6}, {"micron", 1e-6}, {"in", 0.0254}, {"inch", 0.0254}};
    const auto it = kUnits.find(*unit);
    if (it == kUnits.end())
      fail(textile, fmt::format("GeometryScale: expected \"mm\", \"cm\", \"m\", \"um\" or \"in\", "
                                "found \"{}\"",
                                *unit));
    return it->second;
  }

  SectionSpec section(const XmlElement& yarn) const {
    const XmlElement* ys = yarn.child("YarnSection");
    if (ys == nullptr)
      fail(yarn, "<Yarn> has no <YarnSection>");
    // Constant: one <Section>; interpolated: the first <Section> found stands for all.
    const XmlElement* s = nullptr;
    std::vector<const XmlElement*> stack{ys};
    while (!stack.empty() && s == nullptr) {
      const XmlElement* e = stack.back();
      stack.pop_back();
      for (auto it = e->children.rbegin(); it != e->children.rend(); ++it) {
        if (it->name == "Section") {
          s = &*it;
        }
        stack.push_back(&*it);
      }
    }
    if (s == nullptr)
      fail(*ys, "<YarnSection> holds no <Section>");
    SectionSpec spec;
    spec.line = s->line;
    spec.type = attribute(*s, "type");
    static constexpr std::string_view kTypes[] = {"CSectionEllipse", "CSectionLenticular",
                                                  "CSectionPowerEllipse", "CSectionRectangle"};
    if (std::find(std::begin(kTypes), std::end(kTypes), spec.type) == std::end(kTypes))
      fail(*s, fmt::format("section type \"{}\" is not supported (supported: {})", spec.type,
                           fmt::join(kTypes, ", ")));
    spec.width = number(*s, "Width");
    spec.height = number(*s, "Height");
    if (!(spec.width > 0 && spec.height > 0))
      fail(*s, fmt::format("expected a section Width and Height > 0, found {} and {}", spec.width,
                           spec.height));
    if (spec.type == "CSectionLenticular" && number_or(*s, "Distortion", 0) != 0)
      fail(*s, "lenticular sections with a Distortion are not supported");
    if (spec.type == "CSectionPowerEllipse") {
      spec.power = number(*s, "Power");
      if (!(spec.power > 0))
        fail(*s, fmt::format("expected a Power > 0, found {}", spec.power));
    }
    return spec;
  }

  YarnSpec explicit_yarn(const XmlElement& y) const {
    YarnSpec spec;
    spec.line = y.line;
    const std::string* index = y.attribute("index");
    spec.what = fmt::format("yarn {}", index != nullptr ? *index : "?");
    if (const XmlElement* interp = y.child("Interpolation")) {
      const std::string& type = attribute(*interp, "type");
      if (type == "CInterpolationBezier")
        spec.interpolation = Interpolation::Bezier;
      else if (type == "CInterpolationCubic")
        spec.interpolation = Interpolation::Cubic;
      else
        fail(*interp, fmt::format("interpolation \"{}\" is not supported (supported: "
                                  "CInterpolationBezier, CInterpolationCubic)",
                                  type));
      spec.periodic = flag(*interp, "Periodic", true);
      spec.force_master_tangent_in_plane = flag(*interp, "ForceMasterNodeTangent", false);
    }
    for (const XmlElement* r : y.children_named("Repeat"))
      spec.repeats.push_back(vector(*r, "value"));
    for (const XmlElement* n : y.children_named("MasterNode")) {
      spec.nodes.push_back(vector(*n, "Position"));
      spec.tangents.push_back(vector_or_zero(*n, "Tangent"));
      spec.ups.push_back(vector_or_zero(*n, "Up"));
    }
    if (spec.nodes.size() < 2)
      fail(y, fmt::format("{}: expected at least 2 <MasterNode>, found {}", spec.what,
                          spec.nodes.size()));
    for (std::size_t k = 0; k + 1 < spec.nodes.size(); ++k)
      if ((spec.nodes[k + 1] - spec.nodes[k]).norm() == 0)
        fail(*y.children_named("MasterNode")[k + 1],
             fmt::format("{}: master nodes {} and {} are at the same position", spec.what, k,
                         k + 1));
    spec.section = section(y);
    return spec;
  }

  /// Yarns of a weave textile from its pattern (see texgen.hpp).
  std::vector<YarnSpec> weave_yarns(const XmlElement& t) const {
    const int nx = integer(t, "NumXYarns"); // X yarns: along x, one per row y
    const int ny = integer(t, "NumYYarns"); // Y yarns: along y, one per column x
    if (nx < 1 || ny < 1)
      fail(t, fmt::format("expected NumXYarns and NumYYarns >= 1, found {} and {}", nx, ny));
    const double gap = number_or(t, "GapSize", 0);
    struct Data {
      double width = 0, height = 0, spacing = 0;
      bool given = false;
    };
    auto yarn_data = [&](std::string_view name, int count) {
      std::vector<Data> data(static_cast<std::size_t>(count));
      for (const XmlElement* d : t.children_named(name)) {
        const int i = integer(*d, "index");
        if (i < 0 || i >= count)
          fail(*d, fmt::format("<{}> index {} out of range [0, {})", name, i, count));
        data[static_cast<std::size_t>(i)] = {number(*d, "Width"), number(*d, "Height"),
                                             number(*d, "Spacing"), true};
        const Data& v = data[static_cast<std::size_t>(i)];
        if (!(v.width > 0 && v.height > 0 && v.spacing > 0))
          fail(*d, fmt::format("expected Width, Height and Spacing > 0, found {}, {}, {}", v.width,
                               v.height, v.spacing));
      }
      for (int i = 0; i < count; ++i)
        if (!data[static_cast<std::size_t>(i)].given)
          fail(t, fmt::format("no <{} index=\"{}\">", name, i));
      return data;
    };
    const std::vector<Data> xdata = yarn_data("XYarnData", nx);
    const std::vector<Data> ydata = yarn_data("YYarnData", ny);

    // cells[x][y]: entries from the bottom up.
    std::vector<std::vector<std::vector<int>>> cells(
        static_cast<std::size_t>(ny), std::vector<std::vector<int>>(static_cast<std::size_t>(nx)));
    std::vector<std::vector<int>> cell_line(static_cast<std::size_t>(ny),
                                            std::vector<int>(static_cast<std::size_t>(nx), 0));
    for (const XmlElement* c : t.children_named("PatternCell")) {
      const int x = integer(*c, "x");
      const int y = integer(*c, "y");
      if (x < 0 || x >= ny || y < 0 || y >= nx)
        fail(*c, fmt::format("<PatternCell x=\"{}\" y=\"{}\"> outside the {} x {} pattern", x, y,
                             ny, nx));
      auto& cell = cells[static_cast<std::size_t>(x)][static_cast<std::size_t>(y)];
      if (cell_line[static_cast<std::size_t>(x)][static_cast<std::size_t>(y)] != 0)
        fail(*c, fmt::format("<PatternCell x=\"{}\" y=\"{}\"> given twice", x, y));
      cell_line[static_cast<std::size_t>(x)][static_cast<std::size_t>(y)] = c->line;
      for (const XmlElement* e : c->children_named("PatternElement")) {
        const int v = integer(*e, "value");
        if (v < 0 || v > 2)
          fail(*e, fmt::format("expected a pattern value 0 (Y yarn), 1 (X yarn) or 2 (none), "
                               "found {}",
                               v));
        cell.push_back(v);
      }
    }
    for (int x = 0; x < ny; ++x)
      for (int y = 0; y < nx; ++y)
        if (cell_line[static_cast<std::size_t>(x)][static_cast<std::size_t>(y)] == 0)
          fail(t, fmt::format("no <PatternCell x=\"{}\" y=\"{}\">", x, y));

    // In-plane positions: yarn 0 at 0, neighbours half their spacings apart.
    std::vector<double> xs(static_cast<std::size_t>(ny)), ys(static_cast<std::size_t>(nx));
    for (int j = 1; j < ny; ++j)
      xs[static_cast<std::size_t>(j)] =
          xs[static_cast<std::size_t>(j - 1)] + (ydata[static_cast<std::size_t>(j - 1)].spacing +
                                                 ydata[static_cast<std::size_t>(j)].spacing) /
                                                    2;
    for (int i = 1; i < nx; ++i)
      ys[static_cast<std::size_t>(i)] =
          ys[static_cast<std::size_t>(i - 1)] + (xdata[static_cast<std::size_t>(i - 1)].spacing +
                                                 xdata[static_cast<std::size_t>(i)].spacing) /
                                                    2;
    double width = 0, height = 0;
    for (const Data& d : ydata)
      width += d.spacing;
    for (const Data& d : xdata)
      height += d.spacing;

    // Heights of the yarns of one cell, bottom up: (value, z of the centre).
    auto stack = [&](int x, int y) {
      std::vector<std::pair<int, double>> out;
      double z = 0;
      for (int v : cells[static_cast<std::size_t>(x)][static_cast<std::size_t>(y)]) {
        if (v == 2)
          continue;
        const double h = v == 1 ? xdata[static_cast<std::size_t>(y)].height
                                : ydata[static_cast<std::size_t>(x)].height;
        out.emplace_back(v, z + h / 2);
        z += h + gap;
      }
      return out;
    };
    auto layer_heights = [&](int x, int y, int value) {
      std::vector<double> out;
      for (auto [v, z] : stack(x, y))
        if (v == value)
          out.push_back(z);
      return out;
    };

    std::vector<YarnSpec> yarns;
    auto make = [&](const Data& d) {
      YarnSpec spec;
      spec.line = t.line;
      spec.interpolation = Interpolation::Bezier;
      spec.periodic = true;
      spec.repeats = {Eigen::Vector3d(width, 0, 0), Eigen::Vector3d(0, height, 0)};
      spec.section.type = "CSectionEllipse";
      spec.section.width = d.width;
      spec.section.height = d.height;
      spec.section.line = t.line;
      return spec;
    };
    for (int y = 0; y < nx; ++y) {
      const std::size_t layers = layer_heights(0, y, 1).size();
      std::vector<YarnSpec> row(layers, make(xdata[static_cast<std::size_t>(y)]));
      for (int x = 0; x <= ny; ++x) {
        const int cx = x % ny;
        const std::vector<double> z = layer_heights(cx, y, 1);
        if (z.size() != layers)
          fail(cell_line[static_cast<std::size_t>(cx)][static_cast<std::size_t>(y)],
               fmt::format("<PatternCell x=\"{}\" y=\"{}\"> holds {} X yarns, the row's first cell "
                           "{}: every cell of a row needs the same number",
                           cx, y, z.size(), layers));
        const double px = x < ny ? xs[static_cast<std::size_t>(x)] : width + xs[0];
        for (std::size_t l = 0; l < layers; ++l) {
          row[l].nodes.emplace_back(px, ys[static_cast<std::size_t>(y)], z[l]);
          row[l].tangents.emplace_back(1, 0, 0);
          row[l].ups.emplace_back(0, 0, 1);
        }
      }
      for (std::size_t l = 0; l < layers; ++l) {
        row[l].what = fmt::format("X yarn {} layer {}", y, l);
        yarns.push_back(std::move(row[l]));
      }
    }
    for (int x = 0; x < ny; ++x) {
      const std::size_t layers = layer_heights(x, 0, 0).size();
      std::vector<YarnSpec> column(layers, make(ydata[static_cast<std::size_t>(x)]));
      for (int y = 0; y <= nx; ++y) {
        const int cy = y % nx;
        const std::vector<double> z = layer_heights(x, cy, 0);
        if (z.size() != layers)
          fail(cell_line[static_cast<std::size_t>(x)][static_cast<std::size_t>(cy)],
               fmt::format("<PatternCell x=\"{}\" y=\"{}\"> holds {} Y yarns, the column's first "
                           "cell {}: every cell of a column needs the same number",
                           x, cy, z.size(), layers));
        const double py = y < nx ? ys[static_cast<std::size_t>(y)] : height + ys[0];
        for (std::size_t l = 0; l < layers; ++l) {
          column[l].nodes.emplace_back(xs[static_cast<std::size_t>(x)], py, z[l]);
          column[l].tangents.emplace_back(0, 1, 0);
          column[l].ups.emplace_back(0, 0, 1);
        }
      }
      for (std::size_t l = 0; l < layers; ++l) {
        column[l].what = fmt::format("Y yarn {} layer {}", x, l);
        yarns.push_back(std::move(column[l]));
      }
    }
    return yarns;
  }

  /// Master-node tangents as TexGen's CInterpolation::CalculateNodeCoordinateSystem.
  static std::vector<Eigen::Vector3d> node_tangents(const YarnSpec& y) {
    const std::size_t n = y.nodes.size();
    const Eigen::Vector3d period = y.nodes.back() - y.nodes.front();
    std::vector<Eigen::Vector3d> out(n);
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d prev =
          i > 0 ? y.nodes[i - 1]
                : (y.periodic ? Eigen::Vector3d(y.nodes[n - 2] - period) : y.nodes[0]);
      const Eigen::Vector3d next =
          i + 1 < n ? y.nodes[i + 1]
                    : (y.periodic ? Eigen::Vector3d(y.nodes[1] + period) : y.nodes[n - 1]);
      Eigen::Vector3d t = y.tangents[i].norm() > 0 ? y.tangents[i] : (next - prev).normalized();
      if (y.force_master_tangent_in_plane)
        t.z() = 0;
      out[i] = t;
    }
    return out;
  }

  /// Coefficients of a uniform-parameter cubic spline through values v (TexGen's
  /// CInterpolationCubic): derivatives D at the knots, periodic or natural.
  static std::vector<double> spline_slopes(const std::vector<double>& v, bool periodic) {
    const int n = static_cast<int>(v.size()) - 1; // segments
    if (periodic) {
      // Knot n is knot 0 shifted by a period: n unknowns, cyclic 1-4-1 system.
      Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
      Eigen::VectorXd rhs(n);
      const double shift = v[static_cast<std::size_t>(n)] - v[0];
      for (int i = 0; i < n; ++i) {
        A(i, i) += 4;
        A(i, (i + 1) % n) += 1;
        A(i, (i + n - 1) % n) += 1;
        const double next = v[static_cast<std::size_t>(i + 1)];
        const double prev =
            i > 0 ? v[static_cast<std::size_t>(i - 1)] : v[static_cast<std::size_t>(n - 1)] - shift;
        rhs(i) = 3 * (next - prev);
      }
      const Eigen::VectorXd D = A.partialPivLu().solve(rhs);
      std::vector<double> out(D.data(), D.data() + n);
      out.push_back(out.front());
      return out;
    }
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n + 1, n + 1);
    Eigen::VectorXd rhs(n + 1);
    for (int i = 0; i <= n; ++i) {
      const bool first = i == 0, last = i == n;
      A(i, i) = first || last ? 2 : 4;
      if (!first)
        A(i, i - 1) = 1;
      if (!last)
        A(i, i + 1) = 1;
      const double next = v[static_cast<std::size_t>(last ? i : i + 1)];
      const double prev = v[static_cast<std::size_t>(first ? i : i - 1)];
      rhs(i) = 3 * (next - prev);
    }
    const Eigen::VectorXd D = A.partialPivLu().solve(rhs);
    return std::vector<double>(D.data(), D.data() + n + 1);
  }

  /// Centre-line points: 2 m + 1 per master-node interval (m elements), at uniform parameter.
  std::vector<Eigen::Vector3d> sample(const YarnSpec& y, std::vector<Eigen::Vector3d>& ups) const {
    const int m = options_.elements_per_interval;
    const std::size_t n = y.nodes.size();
    std::vector<Eigen::Vector3d> out;
    ups.clear();
    std::vector<Eigen::Vector3d> tangents;
    std::array<std::vector<double>, 3> slopes;
    if (y.interpolation == Interpolation::Bezier) {
      tangents = node_tangents(y);
    } else {
      for (int c = 0; c < 3; ++c) {
        std::vector<double> v;
        for (const auto& p : y.nodes)
          v.push_back(p(c));
        slopes[static_cast<std::size_t>(c)] = spline_slopes(v, y.periodic);
      }
    }
    for (std::size_t i = 0; i + 1 < n; ++i) {
      const Eigen::Vector3d& p0 = y.nodes[i];
      const Eigen::Vector3d& p1 = y.nodes[i + 1];
      Eigen::Vector3d b1, b2;
      if (y.interpolation == Interpolation::Bezier) {
        const double third = (p1 - p0).norm() / 3;
        b1 = p0 + tangents[i] * third;
        b2 = p1 - tangents[i + 1] * third;
      } else {
        // Hermite with slopes D in the uniform parameter as a Bezier: control points D/3 away.
        for (int c = 0; c < 3; ++c) {
          b1(c) = p0(c) + slopes[static_cast<std::size_t>(c)][i] / 3;
          b2(c) = p1(c) - slopes[static_cast<std::size_t>(c)][i + 1] / 3;
        }
      }
      for (int k = i == 0 ? 0 : 1; k <= 2 * m; ++k) {
        const double t = static_cast<double>(k) / (2 * m);
        const double s = 1 - t;
        out.push_back(k == 0       ? p0
                      : k == 2 * m ? p1
                                   : Eigen::Vector3d(s * s * s * p0 + 3 * s * s * t * b1 +
                                                     3 * s * t * t * b2 + t * t * t * p1));
      }
      for (int e = 0; e < m; ++e) {
        const double t = (e + 0.5) / m;
        Eigen::Vector3d u0 = y.ups[i].norm() > 0 ? y.ups[i] : Eigen::Vector3d::UnitZ();
        Eigen::Vector3d u1 = y.ups[i + 1].norm() > 0 ? y.ups[i + 1] : Eigen::Vector3d::UnitZ();
        ups.push_back(((1 - t) * u0.normalized() + t * u1.normalized()).normalized());
      }
    }
    return out;
  }

  /// The yarn tiled `count` periods along `period` (a periodic yarn whose end-to-end vector is
  /// the period).
  static YarnSpec extend(const YarnSpec& y, const Eigen::Vector3d& period, int count) {
    YarnSpec out = y;
    out.nodes.clear();
    out.tangents.clear();
    out.ups.clear();
    const std::size_t n = y.nodes.size();
    for (int c = 0; c < count; ++c)
      for (std::size_t i = 0; i < (c + 1 == count ? n : n - 1); ++i) {
        out.nodes.push_back(y.nodes[i] + c * period);
        out.tangents.push_back(y.tangents[i]);
        out.ups.push_back(y.ups[i]);
      }
    return out;
  }

  SectionOutline outline(const SectionSpec& s) const {
    const double a = s.width * scale_ / 2;
    const double b = s.height * scale_ / 2;
    SectionOutline o;
    constexpr int kPoints = 720;
    if (s.type == "CSectionRectangle") {
      o.points = {{-a, -b}, {a, -b}, {a, b}, {-a, b}};
    } else if (s.type == "CSectionPowerEllipse") {
      for (int k = 0; k < kPoints; ++k) {
        const double t = 2 * std::numbers::pi * k / kPoints;
        const double sn = std::sin(t);
        o.points.emplace_back(a * std::cos(t),
                              b * std::copysign(std::pow(std::abs(sn), s.power), sn));
      }
    } else { // lenticular: two circular arcs through (+-a, 0) and (0, +-b)
      const double R = (a * a + b * b) / (2 * b);
      const double c = b - R; // centre of the upper arc at (0, c)
      const double phi0 = std::atan2(-c, a);
      const int half = kPoints / 2;
      for (int k = 0; k < half; ++k) {
        const double phi = phi0 + (std::numbers::pi - 2 * phi0) * k / half;
        o.points.emplace_back(R * std::cos(phi), c + R * std::sin(phi));
      }
      for (int k = 0; k < half; ++k) {
        const double phi = phi0 + (std::numbers::pi - 2 * phi0) * k / half;
        o.points.emplace_back(-R * std::cos(phi), -(c + R * std::sin(phi)));
      }
    }
    return o;
  }

  Fabric build(const XmlElement& textile, const std::vector<YarnSpec>& specs) {
    if (options_.elements_per_interval < 1)
      throw std::invalid_argument(fmt::format(
          "texgen: expected elements_per_interval >= 1, found {}", options_.elements_per_interval));
    for (int r : options_.repeats)
      if (r < 1)
        throw std::invalid_argument(fmt::format("texgen: expected repeats >= 1, found {}", r));
    options_.material.resolve(1.0, "yarn"); // a bad material is the caller's error, not the file's
    Fabric fabric;
    Model& model = fabric.model;
    const std::string* name = textile.attribute("name");
    model.title = fmt::format("TexGen textile {}", name != nullptr ? *name : source_);
    std::vector<double> radii;
    for (const YarnSpec& spec : specs) {
      try {
        add(fabric, spec, radii);
      } catch (const std::invalid_argument& e) {
        fail(spec.line, fmt::format("{}: {}", spec.what, e.what()));
      }
    }
    if (fabric.yarns.empty())
      fail(textile, "the textile has no yarns");
    finish_fabric(fabric, radii, options_.contact_law);
    return fabric;
  }

  void add(Fabric& fabric, const YarnSpec& spec, std::vector<double>& radii) {
    Model& model = fabric.model;
    // Section, in metres.
    const int section = static_cast<int>(model.sections.size());
    const std::string section_name = fmt::format("section{}", section);
    if (spec.section.type == "CSectionEllipse" ||
        (spec.section.type == "CSectionPowerEllipse" && spec.section.power == 1))
      model.sections.push_back(ellipse_yarn_section(
          section_name, spec.section.width * scale_ / 2, spec.section.height * scale_ / 2,
          options_.material, options_.reduce_lower_inertia, options_.shear_factor));
    else
      model.sections.push_back(
          outline_yarn_section(section_name, outline(spec.section), options_.material,
                               options_.reduce_lower_inertia, options_.shear_factor));
    const double radius =
        options_.contact_radius > 0 ? options_.contact_radius : spec.section.height * scale_ / 2;

    // Which repeat extends the yarn, which ones copy it.
    YarnSpec base = spec;
    for (auto& p : base.nodes)
      p *= scale_;
    std::vector<std::pair<Eigen::Vector3d, int>> copies;
    bool extended = false;
    for (std::size_t k = 0; k < spec.repeats.size(); ++k) {
      const Eigen::Vector3d r = spec.repeats[k] * scale_;
      const int count = k < options_.repeats.size() ? options_.repeats[k] : 1;
      const Eigen::Vector3d span = base.nodes.back() - base.nodes.front();
      if (!extended && spec.periodic && r.norm() > 0 && (span - r).norm() <= 1e-6 * r.norm()) {
        extended = true;
        if (count > 1)
          base = extend(base, r, count);
      } else if (count > 1) {
        copies.emplace_back(r, count);
      }
    }
    // Orientation: warp along x, weft along y, each from its smaller to its larger coordinate.
    const Eigen::Vector3d span = base.nodes.back() - base.nodes.front();
    if (span.head<2>().norm() == 0)
      throw std::invalid_argument("the yarn's ends are at the same in-plane point (closed or "
                                  "through-thickness yarns are not supported)");
    const bool warp = std::abs(span.x()) >= std::abs(span.y());
    if ((warp ? span.x() : span.y()) < 0) {
      std::reverse(base.nodes.begin(), base.nodes.end());
      std::reverse(base.tangents.begin(), base.tangents.end());
      std::reverse(base.ups.begin(), base.ups.end());
      for (auto& t : base.tangents)
        t = -t;
    }
    std::vector<Eigen::Vector3d> ups;
    const std::vector<Eigen::Vector3d> points = sample(base, ups);
    for (const auto& p : points)
      if (!p.allFinite())
        throw std::invalid_argument("the interpolated centre line has a non-finite point");

    // Every combination of copies.
    std::vector<int> index(copies.size(), 0);
    for (;;) {
      Eigen::Vector3d shift = Eigen::Vector3d::Zero();
      for (std::size_t k = 0; k < copies.size(); ++k)
        shift += index[k] * copies[k].first;
      std::vector<Eigen::Vector3d> shifted = points;
      for (auto& p : shifted)
        p += shift;
      append_yarn(fabric, warp, shifted, section, ups);
      radii.push_back(radius);
      std::size_t k = 0;
      while (k < copies.size() && ++index[k] == copies[k].second)
        index[k++] = 0;
      if (k == copies.size())
        break;
    }
  }

  std::string source_;
  const TexGenOptions& options_;
  double scale_ = 1e-3;
};

} // namespace

Fabric read_texgen_string(std::string_view text, std::string_view source_name,
                          const TexGenOptions& options) {
  return Reader(std::string(source_name), options).read(text);
}

Fabric read_texgen(const std::filesystem::path& file, const TexGenOptions& options) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec))
    throw InputError(
        {fmt::format("{}: cannot read the TexGen file: {}", file.string(),
                     std::filesystem::exists(file, ec) ? "not a regular file" : "no such file")});
  std::ifstream in(file, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  if (!in)
    throw InputError({fmt::format("{}: cannot read the TexGen file", file.string())});
  return read_texgen_string(buffer.str(), file.string(), options);
}

} // namespace yarnsim::textile
