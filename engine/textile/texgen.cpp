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
#include <optional>
#include <set>
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
  XmlPosition at;   ///< of its <Yarn>, or of the weave's <Textile>
  std::string what; ///< "yarn 3" for messages
};

class Reader {
public:
  Reader(std::string source, const TexGenOptions& options)
      : source_(std::move(source)), options_(options) {}

  Fabric read(std::string_view text) {
    const XmlElement root = parse_xml(text, source_); // a syntax error stops the reading
    if (root.name != "TexGenModel") {
      report(root.position(),
             fmt::format("expected the root element <TexGenModel>, found <{}>", root.name));
      stop();
    }
    const XmlElement* textile = nullptr;
    std::vector<std::string> names;
    for (const XmlElement* t : root.children_named("Textile")) {
      const std::string* name = t->attribute("name");
      names.push_back(name != nullptr ? *name : "");
      if (textile == nullptr && (options_.textile.empty() || (name && *name == options_.textile)))
        textile = t;
    }
    if (textile == nullptr) {
      report(root.position(),
             options_.textile.empty()
                 ? std::string("expected a <Textile>, found none")
                 : fmt::format("expected a <Textile> named '{}', found {}", options_.textile,
                               names.empty() ? std::string("none")
                                             : fmt::format("'{}'", fmt::join(names, "', '"))));
      stop();
    }
    scale_ = length_scale(*textile);
    std::vector<YarnSpec> yarns;
    const bool has_pattern = textile->child("PatternCell") != nullptr;
    const bool has_yarns = textile->child("Yarn") != nullptr;
    const std::string* needs_building = textile->attribute("NeedsBuilding");
    const bool stale = needs_building != nullptr && *needs_building != "0";
    if (has_pattern && (!has_yarns || stale || options_.rebuild_weaves)) {
      yarns = weave_yarns(*textile);
    } else if (has_yarns) {
      // Each yarn is read whatever the others hold.
      for (const XmlElement* y : textile->children_named("Yarn"))
        if (std::optional<YarnSpec> spec = explicit_yarn(*y))
          yarns.push_back(std::move(*spec));
    } else {
      report(textile->position(), "expected <Yarn> elements or a weave pattern (<PatternCell>), "
                                  "found neither");
    }
    return build(*textile, yarns);
  }

private:
  /// A problem of the file: where, and what was expected and found.
  struct Problem {
    XmlPosition at;
    std::string message;
  };

  /// Records a problem; the reader goes on where the rest of the file can still be read.
  void report(XmlPosition at, std::string message) {
    problems_.push_back({at, std::move(message)});
  }

  /// Throws InputError with every problem recorded, in file order (line, then column, then
  /// order of discovery), each once, as "file:line:col: message".
  [[noreturn]] void stop() const {
    std::vector<std::size_t> order(problems_.size());
    for (std::size_t i = 0; i < order.size(); ++i)
      order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](std::size_t i, std::size_t j) {
      const XmlPosition& a = problems_[i].at;
      const XmlPosition& b = problems_[j].at;
      return a.line != b.line ? a.line < b.line : a.column < b.column;
    });
    std::vector<std::string> messages;
    std::set<std::string> seen;
    for (std::size_t i : order) {
      const Problem& p = problems_[i];
      std::string text = fmt::format("{}:{}:{}: {}", source_, p.at.line, p.at.column, p.message);
      if (seen.insert(text).second)
        messages.push_back(std::move(text));
    }
    throw InputError(std::move(messages));
  }

  // Attribute readers: each returns the value, or records the problem at the value (at the
  // element for a missing attribute) and returns nothing.

  /// The attribute's value; `what` describes the value expected, for a missing attribute.
  const std::string* required(const XmlElement& e, std::string_view key, std::string_view what) {
    const std::string* v = e.attribute(key);
    if (v == nullptr)
      report(e.position(), fmt::format("<{}>: missing attribute '{}' ({})", e.name, key, what));
    return v;
  }

  /// `expected`: what the value must be ("a number > 0"); `found`: the value as written.
  void report_value(const XmlElement& e, std::string_view key, std::string_view expected,
                    std::string_view found) {
    report(e.position_of(key), fmt::format("<{}> attribute '{}': expected {}, found \"{}\"", e.name,
                                           key, expected, found));
  }

  /// The comma-separated numbers of a value, or nothing (no problem recorded) when malformed.
  static std::optional<std::vector<double>> parse_numbers(const std::string& text) {
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
        return std::nullopt;
      out.push_back(v);
    }
    return out;
  }

  /// `count` numbers separated by commas.
  std::optional<std::vector<double>> numbers(const XmlElement& e, std::string_view key,
                                             std::size_t count, std::string_view expected) {
    const std::string* text = required(e, key, expected);
    if (text == nullptr)
      return std::nullopt;
    std::optional<std::vector<double>> v = parse_numbers(*text);
    if (!v || v->size() != count) {
      report_value(e, key, expected, *text);
      return std::nullopt;
    }
    return v;
  }

  /// A finite number; > 0 when `positive`.
  std::optional<double> number(const XmlElement& e, std::string_view key, bool positive = false) {
    const std::string_view expected = positive ? "a number > 0" : "a number";
    const std::optional<std::vector<double>> v = numbers(e, key, 1, expected);
    if (!v)
      return std::nullopt;
    if (positive && !((*v)[0] > 0)) {
      report_value(e, key, expected, *e.attribute(key));
      return std::nullopt;
    }
    return (*v)[0];
  }
  std::optional<double> number_or(const XmlElement& e, std::string_view key, double fallback,
                                  bool positive = false) {
    return e.attribute(key) != nullptr ? number(e, key, positive) : fallback;
  }
  /// An integer in [lo, hi]; `expected` describes it.
  std::optional<int> integer(const XmlElement& e, std::string_view key, int lo, int hi,
                             std::string_view expected) {
    const std::string* text = required(e, key, expected);
    if (text == nullptr)
      return std::nullopt;
    const std::optional<std::vector<double>> v = parse_numbers(*text);
    if (!v || v->size() != 1 || (*v)[0] != std::floor((*v)[0]) || (*v)[0] < lo || (*v)[0] > hi) {
      report_value(e, key, expected, *text);
      return std::nullopt;
    }
    return static_cast<int>((*v)[0]);
  }
  std::optional<Eigen::Vector3d> vector(const XmlElement& e, std::string_view key) {
    const std::optional<std::vector<double>> v =
        numbers(e, key, 3, "3 numbers \"x, y, z\" separated by commas");
    if (!v)
      return std::nullopt;
    return Eigen::Vector3d((*v)[0], (*v)[1], (*v)[2]);
  }
  std::optional<Eigen::Vector3d> vector_or_zero(const XmlElement& e, std::string_view key) {
    return e.attribute(key) != nullptr ? vector(e, key) : Eigen::Vector3d::Zero();
  }
  std::optional<bool> flag(const XmlElement& e, std::string_view key, bool fallback) {
    const std::string* v = e.attribute(key);
    if (v == nullptr)
      return fallback;
    if (*v == "1" || *v == "true")
      return true;
    if (*v == "0" || *v == "false")
      return false;
    report_value(e, key, "0 or 1", *v);
    return std::nullopt;
  }

  /// m per file unit; a bad GeometryScale is recorded and read as "mm".
  double length_scale(const XmlElement& textile) {
    if (options_.length_scale > 0)
      return options_.length_scale;
    const std::string* unit = textile.attribute("GeometryScale");
    if (unit == nullptr || *unit == "mm")
      return 1e-3;
    static const std::map<std::string, double> kUnits{
        {"m", 1.0}, {"cm", 1e-2}, {"um", 1e-6}, {"micron", 1e-6}, {"in", 0.0254}, {"inch", 0.0254}};
    const auto it = kUnits.find(*unit);
    if (it == kUnits.end()) {
      report_value(textile, "GeometryScale", "\"mm\", \"cm\", \"m\", \"um\" or \"in\"", *unit);
      return 1e-3;
    }
    return it->second;
  }

  std::optional<SectionSpec> section(const XmlElement& yarn) {
    const XmlElement* ys = yarn.child("YarnSection");
    if (ys == nullptr) {
      report(yarn.position(), "<Yarn>: expected a <YarnSection>, found none");
      return std::nullopt;
    }
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
    if (s == nullptr) {
      report(ys->position(), "<YarnSection>: expected a <Section>, found none");
      return std::nullopt;
    }
    static constexpr std::string_view kTypes[] = {"CSectionEllipse", "CSectionLenticular",
                                                  "CSectionPowerEllipse", "CSectionRectangle"};
    const std::string supported = fmt::format("{}", fmt::join(kTypes, ", "));
    SectionSpec spec;
    bool ok = true;
    if (const std::string* type = required(*s, "type", supported)) {
      spec.type = *type;
      if (std::find(std::begin(kTypes), std::end(kTypes), spec.type) == std::end(kTypes)) {
        report(s->position_of("type"),
               fmt::format("<Section> attribute 'type': expected a supported section type ({}), "
                           "found \"{}\"",
                           supported, spec.type));
        // Its other attributes depend on the type: nothing more to check.
        return std::nullopt;
      }
    } else {
      return std::nullopt;
    }
    const std::optional<double> width = number(*s, "Width", true);
    const std::optional<double> height = number(*s, "Height", true);
    ok = width && height;
    if (spec.type == "CSectionLenticular") {
      const std::optional<double> distortion = number_or(*s, "Distortion", 0);
      if (distortion && *distortion != 0) {
        report_value(*s, "Distortion",
                     "0 (lenticular sections with a distortion are not supported)",
                     *s->attribute("Distortion"));
        ok = false;
      }
      ok = ok && distortion;
    }
    if (spec.type == "CSectionPowerEllipse") {
      const std::optional<double> power = number(*s, "Power", true);
      ok = ok && power;
      if (power)
        spec.power = *power;
    }
    if (!ok)
      return std::nullopt;
    spec.width = *width;
    spec.height = *height;
    return spec;
  }

  /// A <Yarn> as written; nothing when it has problems (all of them recorded).
  std::optional<YarnSpec> explicit_yarn(const XmlElement& y) {
    YarnSpec spec;
    spec.at = y.position();
    const std::string* index = y.attribute("index");
    spec.what = fmt::format("yarn {}", index != nullptr ? *index : "?");
    bool ok = true;
    if (const XmlElement* interp = y.child("Interpolation")) {
      if (const std::string* type =
              required(*interp, "type", "CInterpolationBezier or CInterpolationCubic")) {
        if (*type == "CInterpolationBezier")
          spec.interpolation = Interpolation::Bezier;
        else if (*type == "CInterpolationCubic")
          spec.interpolation = Interpolation::Cubic;
        else {
          report_value(*interp, "type",
                       "a supported interpolation (CInterpolationBezier, CInterpolationCubic)",
                       *type);
          ok = false;
        }
      } else {
        ok = false;
      }
      const std::optional<bool> periodic = flag(*interp, "Periodic", true);
      const std::optional<bool> in_plane = flag(*interp, "ForceMasterNodeTangent", false);
      ok = ok && periodic && in_plane;
      spec.periodic = periodic.value_or(true);
      spec.force_master_tangent_in_plane = in_plane.value_or(false);
    }
    for (const XmlElement* r : y.children_named("Repeat")) {
      const std::optional<Eigen::Vector3d> v = vector(*r, "value");
      ok = ok && v;
      if (v)
        spec.repeats.push_back(*v);
    }
    const std::vector<const XmlElement*> masters = y.children_named("MasterNode");
    bool nodes_ok = true;
    for (const XmlElement* n : masters) {
      const std::optional<Eigen::Vector3d> position = vector(*n, "Position");
      const std::optional<Eigen::Vector3d> tangent = vector_or_zero(*n, "Tangent");
      const std::optional<Eigen::Vector3d> up = vector_or_zero(*n, "Up");
      nodes_ok = nodes_ok && position && tangent && up;
      spec.nodes.push_back(position.value_or(Eigen::Vector3d::Zero()));
      spec.tangents.push_back(tangent.value_or(Eigen::Vector3d::Zero()));
      spec.ups.push_back(up.value_or(Eigen::Vector3d::Zero()));
    }
    if (masters.size() < 2) {
      report(y.position(), fmt::format("{}: expected at least 2 <MasterNode>, found {}", spec.what,
                                       masters.size()));
      nodes_ok = false;
    }
    if (nodes_ok)
      for (std::size_t k = 0; k + 1 < spec.nodes.size(); ++k)
        if ((spec.nodes[k + 1] - spec.nodes[k]).norm() == 0) {
          report(masters[k + 1]->position_of("Position"),
                 fmt::format("{}: expected master node {} apart from master node {}, found both "
                             "at the same position",
                             spec.what, k + 1, k));
          nodes_ok = false;
        }
    const std::optional<SectionSpec> section_spec = section(y);
    if (!ok || !nodes_ok || !section_spec)
      return std::nullopt;
    spec.section = *section_spec;
    return spec;
  }

  /// Yarns of a weave textile from its pattern (see texgen.hpp); none when the pattern has
  /// problems (all of them recorded).
  std::vector<YarnSpec> weave_yarns(const XmlElement& t) {
    // X yarns: along x, one per row y; Y yarns: along y, one per column x.
    const std::optional<int> nx_read =
        integer(t, "NumXYarns", 1, 10000, "an integer in [1, 10000]");
    const std::optional<int> ny_read =
        integer(t, "NumYYarns", 1, 10000, "an integer in [1, 10000]");
    const std::optional<double> gap_read = number_or(t, "GapSize", 0);
    bool ok = nx_read && ny_read && gap_read;
    // Without the counts the pattern's entries are still checked, but not their ranges.
    const int nx = nx_read.value_or(0);
    const int ny = ny_read.value_or(0);
    const double gap = gap_read.value_or(0);
    struct Data {
      double width = 0, height = 0, spacing = 0;
      bool given = false;
    };
    auto yarn_data = [&](std::string_view name, int count, bool count_known) {
      std::vector<Data> data(static_cast<std::size_t>(count));
      const std::string range = count_known ? fmt::format("an integer in [0, {})", count)
                                            : std::string("an integer >= 0");
      for (const XmlElement* d : t.children_named(name)) {
        const std::optional<int> i =
            integer(*d, "index", 0, count_known ? count - 1 : 1'000'000, range);
        const std::optional<double> width = number(*d, "Width", true);
        const std::optional<double> height = number(*d, "Height", true);
        const std::optional<double> spacing = number(*d, "Spacing", true);
        ok = ok && i && width && height && spacing;
        if (!i || !count_known)
          continue;
        // An entry with a good index counts as given, whatever its sizes.
        Data& v = data[static_cast<std::size_t>(*i)];
        if (v.given) {
          report(d->position_of("index"),
                 fmt::format("<{}> attribute 'index': expected each index once, found {} again",
                             name, *i));
          ok = false;
        }
        v = {width.value_or(0), height.value_or(0), spacing.value_or(0), true};
      }
      // A count beyond the file's entries is one problem, not one per missing index.
      const std::size_t given = t.children_named(name).size();
      if (count_known && given < static_cast<std::size_t>(count)) {
        report(t.position(),
               fmt::format("expected a <{}> for each of the {} {} yarns (Num{}Yarns), found {}",
                           name, count, name.substr(0, 1), name.substr(0, 1), given));
        ok = false;
      } else if (count_known) {
        for (int i = 0; i < count; ++i)
          if (!data[static_cast<std::size_t>(i)].given) {
            report(t.position(), fmt::format("expected a <{} index=\"{}\">, found none", name, i));
            ok = false;
          }
      }
      return data;
    };
    const std::vector<Data> xdata = yarn_data("XYarnData", nx, nx_read.has_value());
    const std::vector<Data> ydata = yarn_data("YYarnData", ny, ny_read.has_value());

    // cells[x][y]: entries from the bottom up; cell_at[x][y]: where the cell is (line 0: absent).
    // Cells are matched to the pattern only when there are enough of them: a count beyond the
    // file's cells is one problem, not one per missing cell.
    const std::vector<const XmlElement*> cell_elements = t.children_named("PatternCell");
    bool counts = nx_read && ny_read;
    if (counts &&
        static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny) > cell_elements.size()) {
      report(t.position(),
             fmt::format("expected a <PatternCell> for each of the {} x {} cells (NumYYarns x "
                         "NumXYarns), found {}",
                         ny, nx, cell_elements.size()));
      ok = false;
      counts = false;
    }
    std::vector<std::vector<std::vector<int>>> cells(
        static_cast<std::size_t>(counts ? ny : 0),
        std::vector<std::vector<int>>(static_cast<std::size_t>(nx)));
    std::vector<std::vector<XmlPosition>> cell_at(
        static_cast<std::size_t>(counts ? ny : 0),
        std::vector<XmlPosition>(static_cast<std::size_t>(nx)));
    for (const XmlElement* c : cell_elements) {
      const std::optional<int> x = integer(
          *c, "x", 0, ny_read ? ny - 1 : 1'000'000,
          ny_read ? fmt::format("an integer in [0, {}) (NumYYarns)", ny) : "an integer >= 0");
      const std::optional<int> y = integer(
          *c, "y", 0, nx_read ? nx - 1 : 1'000'000,
          nx_read ? fmt::format("an integer in [0, {}) (NumXYarns)", nx) : "an integer >= 0");
      std::vector<int> entries;
      for (const XmlElement* e : c->children_named("PatternElement")) {
        const std::optional<int> v =
            integer(*e, "value", 0, 2, "0 (Y yarn), 1 (X yarn) or 2 (none)");
        if (v)
          entries.push_back(*v);
        ok = ok && v;
      }
      if (!x || !y) {
        ok = false;
        continue;
      }
      if (!counts)
        continue;
      const auto ux = static_cast<std::size_t>(*x);
      const auto uy = static_cast<std::size_t>(*y);
      if (cell_at[ux][uy].line != 0) {
        report(c->position(),
               fmt::format("expected each <PatternCell> once, found x=\"{}\" y=\"{}\" again "
                           "(first at line {})",
                           *x, *y, cell_at[ux][uy].line));
        ok = false;
        continue;
      }
      cell_at[ux][uy] = c->position();
      cells[ux][uy] = std::move(entries);
    }
    if (counts)
      for (int x = 0; x < ny; ++x)
        for (int y = 0; y < nx; ++y)
          if (cell_at[static_cast<std::size_t>(x)][static_cast<std::size_t>(y)].line == 0) {
            report(t.position(),
                   fmt::format("expected a <PatternCell x=\"{}\" y=\"{}\">, found none", x, y));
            ok = false;
          }
    if (!ok)
      return {};

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
      spec.at = t.position();
      spec.interpolation = Interpolation::Bezier;
      spec.periodic = true;
      spec.repeats = {Eigen::Vector3d(width, 0, 0), Eigen::Vector3d(0, height, 0)};
      spec.section.type = "CSectionEllipse";
      spec.section.width = d.width;
      spec.section.height = d.height;
      return spec;
    };
    for (int y = 0; y < nx; ++y) {
      const std::size_t layers = layer_heights(0, y, 1).size();
      std::vector<YarnSpec> row(layers, make(xdata[static_cast<std::size_t>(y)]));
      for (int x = 0; x <= ny; ++x) {
        const int cx = x % ny;
        const std::vector<double> z = layer_heights(cx, y, 1);
        if (z.size() != layers) {
          report(cell_at[static_cast<std::size_t>(cx)][static_cast<std::size_t>(y)],
                 fmt::format("<PatternCell x=\"{}\" y=\"{}\">: expected {} X yarns as the row's "
                             "first cell holds (every cell of a row holds the same number), "
                             "found {}",
                             cx, y, layers, z.size()));
          ok = false;
          break;
        }
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
        if (z.size() != layers) {
          report(cell_at[static_cast<std::size_t>(x)][static_cast<std::size_t>(cy)],
                 fmt::format("<PatternCell x=\"{}\" y=\"{}\">: expected {} Y yarns as the "
                             "column's first cell holds (every cell of a column holds the same "
                             "number), found {}",
                             x, cy, layers, z.size()));
          ok = false;
          break;
        }
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
    if (!ok)
      return {};
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
    // The yarns read without problems are built even when others had some: their own problems
    // are reported with the rest.
    for (const YarnSpec& spec : specs) {
      try {
        add(fabric, spec, radii);
      } catch (const std::invalid_argument& e) {
        report(spec.at, fmt::format("{}: {}", spec.what, e.what()));
      }
    }
    if (problems_.empty() && fabric.yarns.empty())
      report(textile.position(), "expected yarns in the textile, found none");
    if (!problems_.empty())
      stop();
    finish_fabric(fabric, radii, options_.contact_law, options_.contact);
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
          options_.material, options_.reduce_lower_inertia, options_.shear_factor,
          options_.reduce_upper_inertia));
    else
      model.sections.push_back(outline_yarn_section(
          section_name, outline(spec.section), options_.material, options_.reduce_lower_inertia,
          options_.shear_factor, options_.reduce_upper_inertia));
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
      throw std::invalid_argument(
          fmt::format("expected the yarn's ends at different in-plane points, found both at ({}, "
                      "{}) m (closed or through-thickness yarns are not supported)",
                      base.nodes.front().x(), base.nodes.front().y()));
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
        throw std::invalid_argument(
            "expected a finite interpolated centre line, found a non-finite point");

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
  std::vector<Problem> problems_; ///< in order of discovery
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
