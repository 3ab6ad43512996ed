#include "engine/model/deck.hpp"
#include "engine/model/contact_friction.hpp"

#include "engine/model/deck_schema.hpp"
#include "engine/model/model_deck.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <optional>
#include <unordered_map>
#include <unordered_set>

namespace yarnsim {

InputError::InputError(std::vector<std::string> messages)
    : std::runtime_error(fmt::format("{}", fmt::join(messages, "\n"))),
      messages_(std::move(messages)) {}

namespace {

using namespace deck;

// ---------------------------------------------------------------------------------------------
// Schema: the keys of every block. To add a block: declare its keys and TableSpec here, add a
// row to kDeckKeys, and a DeckBuilder method that turns its checked tables into the Model.

constexpr Range kShearFactor{0, 1, true, false};
constexpr Range kExponent{1, kInf, true, false};
constexpr Range kElementCount{1, 1e7, false, false};
constexpr Range kSafetyFactor{0, 1, true, false};

constexpr KeySpec kMaterialKeys[] = {
    {"name", Type::String, kRequired},
    {"E", Type::Number, kRequired, kPositive},
    {"nu", Type::Number, kOptional, kPoisson},
    {"G", Type::Number, kOptional, kPositive},
    {"density", Type::Number, kRequired, kPositive},
};
constexpr TableSpec kMaterial{"[[materials]]", kMaterialKeys};

constexpr std::string_view kStiffnessKeys[] = {"EA",  "GA",   "GA1", "GA2",  "EI",  "EI1",
                                               "EI2", "EI12", "GJ",  "rhoA", "rhoJ"};
constexpr std::string_view kShapeKeys[] = {
    "shape", "radius", "a", "b", "exponent", "material", "reduce_I1", "reduce_I2", "shear_factor"};
constexpr KeySpec kSectionKeys[] = {
    {"name", Type::String, kRequired},
    // Stiffness form.
    {"EA", Type::Number, kOptional, kPositive},
    {"GA", Type::Number, kOptional, kPositive},
    {"GA1", Type::Number, kOptional, kPositive},
    {"GA2", Type::Number, kOptional, kPositive},
    {"EI", Type::Number, kOptional, kPositive},
    {"EI1", Type::Number, kOptional, kPositive},
    {"EI2", Type::Number, kOptional, kPositive},
    {"EI12", Type::Number},
    {"GJ", Type::Number, kOptional, kPositive},
    {"rhoA", Type::Number, kOptional, kNonNegative},
    {"rhoJ", Type::Vector3, kOptional, kNonNegative},
    // Shape form.
    {"shape", Type::String},
    {"radius", Type::Number, kOptional, kPositive},
    {"a", Type::Number, kOptional, kPositive},
    {"b", Type::Number, kOptional, kPositive},
    {"exponent", Type::Number, kOptional, kExponent},
    {"material", Type::String},
    {"reduce_I1", Type::Number, kOptional, kPositive},
    {"reduce_I2", Type::Number, kOptional, kPositive},
    {"shear_factor", Type::Number, kOptional, kShearFactor},
};
constexpr TableSpec kSection{"[[sections]]", kSectionKeys};

constexpr KeySpec kNodeTableKeys[] = {{"coordinates", Type::Points, kRequired}};
constexpr TableSpec kNodeTable{"[nodes]", kNodeTableKeys};
constexpr KeySpec kNodeItemKeys[] = {
    {"id", Type::Integer, kRequired, kAtLeastOne},
    {"position", Type::Vector3, kRequired},
};
constexpr TableSpec kNodeItem{"[[nodes]]", kNodeItemKeys};

constexpr KeySpec kElementKeys[] = {
    {"connectivity", Type::Triples, kRequired, kAtLeastOne},
    {"section", Type::String, kRequired},
    {"reference_vector", Type::Vector3},
};
constexpr TableSpec kElement{"[[elements]]", kElementKeys};

constexpr KeySpec kLineKeys[] = {
    {"name", Type::String, kRequired},    {"from", Type::Vector3, kRequired},
    {"to", Type::Vector3, kRequired},     {"elements", Type::Integer, kRequired, kElementCount},
    {"section", Type::String, kRequired}, {"reference_vector", Type::Vector3},
};
constexpr TableSpec kLine{"[[lines]]", kLineKeys};

constexpr KeySpec kNodeSetKeys[] = {
    {"name", Type::String, kRequired},
    {"nodes", Type::Labels, kRequired, kAtLeastOne},
};
constexpr TableSpec kNodeSet{"[[node_sets]]", kNodeSetKeys};

constexpr KeySpec kConstraintKeys[] = {
    {"node_set", Type::String, kRequired},
    {"dofs", Type::Words, kRequired},
};
constexpr TableSpec kConstraint{"[[constraints]]", kConstraintKeys};

constexpr KeySpec kDisplacementKeys[] = {
    {"x", Type::TimeTable},
    {"y", Type::TimeTable},
    {"z", Type::TimeTable},
};
constexpr TableSpec kDisplacement{"displacement", kDisplacementKeys};
constexpr KeySpec kRotationKeys[] = {
    {"x", Type::TimeTable, kRequired},
    {"y", Type::TimeTable, kRequired},
    {"z", Type::TimeTable, kRequired},
};
constexpr TableSpec kRotation{"rotation", kRotationKeys};
constexpr KeySpec kPrescribedKeys[] = {
    {"node_set", Type::String, kRequired},
    {"displacement", Type::Table, kOptional, kAnyValue, &kDisplacement},
    {"rotation", Type::Table, kOptional, kAnyValue, &kRotation},
};
constexpr TableSpec kPrescribed{"[[prescribed]]", kPrescribedKeys};

constexpr KeySpec kLoadKeys[] = {
    {"node_set", Type::String, kRequired}, {"force", Type::Vector3}, {"moment", Type::Vector3},
    {"follower", Type::Boolean},           {"axes", Type::String},   {"table", Type::TimeTable},
};
constexpr TableSpec kLoad{"[[loads]]", kLoadKeys};

constexpr KeySpec kToleranceKeys[] = {
    {"force", Type::Number, kOptional, kPositive},
    {"increment", Type::Number, kOptional, kPositive},
};
constexpr TableSpec kTolerance{"tolerance", kToleranceKeys};
constexpr KeySpec kNewmarkKeys[] = {
    {"beta", Type::Number, kOptional, kNewmarkBeta},
    {"gamma", Type::Number, kOptional, kNewmarkGamma},
};
constexpr TableSpec kNewmark{"newmark", kNewmarkKeys};
constexpr KeySpec kRayleighKeys[] = {
    {"mass", Type::Number, kOptional, kNonNegative},
    {"stiffness", Type::Number, kOptional, kNonNegative},
    {"out_of_plane", Type::Number, kOptional, kNonNegative},
};
constexpr TableSpec kRayleigh{"rayleigh", kRayleighKeys};
constexpr KeySpec kStepKeys[] = {
    {"type", Type::String, kRequired},
    {"end_time", Type::Number, kRequired, kPositive},
    {"dt", Type::Number, kRequired, kPositive},
    {"dt_min", Type::Number, kOptional, kPositive},
    {"dt_max", Type::Number, kOptional, kPositive},
    {"max_iterations", Type::Integer, kOptional, kIterations},
    {"tolerance", Type::Table, kOptional, kAnyValue, &kTolerance},
    {"newmark", Type::Table, kOptional, kAnyValue, &kNewmark},
    {"rayleigh", Type::Table, kOptional, kAnyValue, &kRayleigh},
    {"output_every", Type::Integer, kOptional, kAtLeastOne},
    // Explicit steps only.
    {"safety_factor", Type::Number, kOptional, kSafetyFactor},
    {"mass_scaling_dt", Type::Number, kOptional, kPositive},
    {"stable_dt_every", Type::Integer, kOptional, kAtLeastOne},
    {"energy_monitor", Type::Boolean},
};
constexpr TableSpec kStep{"[[steps]]", kStepKeys};

constexpr KeySpec kMonitorKeys[] = {
    {"name", Type::String, kRequired},
    {"node", Type::Integer, kOptional, kAtLeastOne},
    {"node_set", Type::String},
    {"element", Type::Integer, kOptional, kAtLeastOne},
};
constexpr TableSpec kMonitor{"[[monitors]]", kMonitorKeys};

constexpr KeySpec kSplineKeys[] = {
    {"name", Type::String, kRequired},
    {"node_set", Type::String},
    {"nodes", Type::Labels, kOptional, kAtLeastOne},
    {"radius", Type::Number, kRequired, kPositive},
};
constexpr TableSpec kSpline{"[[splines]]", kSplineKeys};

constexpr KeySpec kSurfaceKeys[] = {
    {"name", Type::String, kRequired},
    {"node_set", Type::String, kRequired},
    {"a", Type::Number, kOptional, kPositive},
    {"b", Type::Number, kOptional, kPositive},
    {"exponent", Type::Number, kOptional, kExponent},
};
constexpr TableSpec kSurface{"[[surfaces]]", kSurfaceKeys};

/// Angles of the all-angle spline contact, degrees, and its Gauss points per segment.
constexpr Range kContactAngle{0, 90, true, false};
constexpr Range kGaussPoints{1, 10, false, false};

constexpr KeySpec kContactKeys[] = {
    {"name", Type::String, kRequired},
    {"type", Type::String, kRequired},
    {"between", Type::Any}, // one or two groups: DeckBuilder::contact_groups() checks it
    {"group_a", Type::Words},
    {"group_b", Type::Words},
    {"law", Type::String},
    {"penalty", Type::Number, kRequired, kPositive},
    {"exponent", Type::Number, kOptional, kAtLeastOne},
    {"regularisation", Type::Number, kOptional, kPositive},
    {"damping", Type::Number, kOptional, kNonNegative},
    {"self_contact", Type::Boolean},
    {"margin", Type::Number, kOptional, kNonNegative},
    {"line_contact", Type::Boolean},
    {"line_angle", Type::Number, kOptional, kContactAngle},
    {"point_angle", Type::Number, kOptional, kContactAngle},
    {"line_penalty", Type::Number, kOptional, kPositive},
    {"gauss_points", Type::Integer, kOptional, kGaussPoints},
    {"friction", Type::Number, kOptional, kNonNegative},
    {"static_friction", Type::Number, kOptional, kNonNegative},
    {"kinetic_friction", Type::Number, kOptional, kNonNegative},
    {"tangential_penalty", Type::Number, kOptional, kPositive},
    {"elastic_slip", Type::Number, kOptional, kPositive},
    {"tangential_damping", Type::Number, kOptional, kNonNegative},
    {"torsional_friction", Type::Boolean},
    {"torsional_radius", Type::Number, kOptional, kPositive},
    {"torsional_penalty", Type::Number, kOptional, kPositive},
};
constexpr TableSpec kContact{"[[contacts]]", kContactKeys};

constexpr KeySpec kDeckKeys[] = {
    {"title", Type::String},
    {"materials", Type::Tables, kOptional, kAnyValue, &kMaterial},
    {"sections", Type::Tables, kOptional, kAnyValue, &kSection},
    {"nodes", Type::Any}, // [nodes] or [[nodes]]: DeckBuilder::nodes() checks it
    {"elements", Type::Tables, kOptional, kAnyValue, &kElement},
    {"lines", Type::Tables, kOptional, kAnyValue, &kLine},
    {"node_sets", Type::Tables, kOptional, kAnyValue, &kNodeSet},
    {"constraints", Type::Tables, kOptional, kAnyValue, &kConstraint},
    {"prescribed", Type::Tables, kOptional, kAnyValue, &kPrescribed},
    {"loads", Type::Tables, kOptional, kAnyValue, &kLoad},
    {"steps", Type::Tables, kRequired, kAnyValue, &kStep},
    {"monitors", Type::Tables, kOptional, kAnyValue, &kMonitor},
    {"splines", Type::Tables, kOptional, kAnyValue, &kSpline},
    {"surfaces", Type::Tables, kOptional, kAnyValue, &kSurface},
    {"contacts", Type::Tables, kOptional, kAnyValue, &kContact},
};
constexpr TableSpec kDeck{"the top level of the deck", kDeckKeys};

// ---------------------------------------------------------------------------------------------

std::string vector_text(const Eigen::Vector3d& v) {
  return fmt::format("[{}, {}, {}]", v.x(), v.y(), v.z());
}

/// Turns checked tables into a Model, resolving names and labels to indices. Blocks are read in
/// dependency order, whatever their order in the file. A name whose block has errors is still
/// registered, so references to it do not add follow-on errors.
class DeckBuilder {
public:
  DeckBuilder(const toml::table& table, Diagnostics& diagnostics)
      : root_(table, kDeck, "", diagnostics), diagnostics_(diagnostics) {}

  Model build() {
    model_.title = root_.string("title").value_or("");
    materials();
    sections();
    nodes();
    lines();
    elements();
    node_sets();
    constraints();
    prescribed();
    loads();
    steps();
    monitors();
    splines();
    surfaces();
    contacts();
    check_free_nodes();
    check_mass();
    return std::move(model_);
  }

private:
  struct Origin {
    const CheckedTable* table;
    std::string key;
  };
  struct Line {
    int first_node = 0;
    int elements = 0;
    int section = -1;
    Eigen::Vector3d reference_vector = Eigen::Vector3d::UnitY();
  };

  /// Registers a unique name; reports a duplicate at the later definition.
  void add_name(std::vector<std::string>& names, std::vector<Origin>& origins,
                const std::string& name, const CheckedTable& t, std::string_view key,
                std::string_view what) {
    const auto it = std::find(names.begin(), names.end(), name);
    if (it != names.end()) {
      const Origin& first = origins[static_cast<std::size_t>(it - names.begin())];
      const auto& where = first.table->source(first.key).begin;
      t.error(key, fmt::format("expected a unique {} name, found '{}' again (first defined by {} "
                               "at line {})",
                               what, name, first.table->path(first.key), where.line));
    }
    names.push_back(name);
    origins.push_back({&t, std::string(key)});
  }

  /// Index of a named item, or nullopt after reporting what is missing.
  std::optional<int> lookup(const std::vector<std::string>& names, const CheckedTable& t,
                            std::string_view key, std::string_view what,
                            std::string_view block) const {
    const std::optional<std::string> name = t.string(key);
    if (!name)
      return std::nullopt;
    const auto it = std::find(names.begin(), names.end(), *name);
    if (it != names.end())
      return static_cast<int>(it - names.begin());
    t.error(key, unknown_name(names, *name, what, block));
    return std::nullopt;
  }

  /// "no <what> named 'x'" with a suggestion, or the names there are.
  static std::string unknown_name(const std::vector<std::string>& names, std::string_view name,
                                  std::string_view what, std::string_view block) {
    std::vector<std::string_view> candidates(names.begin(), names.end());
    const std::string_view suggestion = closest(name, candidates);
    std::string message = fmt::format("no {} named '{}'", what, name);
    if (!suggestion.empty())
      message += fmt::format("; did you mean '{}'?", suggestion);
    else if (names.empty())
      message += fmt::format(" (the deck has no {})", block);
    else if (names.size() <= 8)
      message += fmt::format(" (defined: {})", fmt::join(names, ", "));
    return message;
  }

  /// Node index of a label, or nullopt after reporting it (unless the nodes themselves are bad).
  std::optional<int> node_index(long long label, const CheckedTable& t, std::string_view key,
                                std::string_view item_path,
                                const toml::source_region& where) const {
    const auto it = label_to_node_.find(label);
    if (it != label_to_node_.end())
      return it->second;
    if (!nodes_broken_) {
      std::string message = fmt::format("no node labelled {}", label);
      if (model_.node_labels.empty())
        message += model_.nodes.empty()
                       ? " (the deck has no nodes)"
                       : fmt::format(" (nodes are labelled 1 to {})", model_.nodes.size());
      diagnostics_.error(where, item_path.empty() ? t.path(key) : std::string(item_path), message);
    }
    return std::nullopt;
  }

  int add_node(const Eigen::Vector3d& x, long long label, const toml::source_region& where,
               std::string path) {
    const int index = static_cast<int>(model_.nodes.size());
    model_.nodes.push_back(x);
    if (explicit_labels_)
      model_.node_labels.push_back(static_cast<long>(label));
    label_to_node_[label] = index;
    node_origin_.push_back({where, std::move(path)});
    return index;
  }

  void materials() {
    for (const CheckedTable& t : root_.tables("materials")) {
      Material mat;
      if (auto name = t.string("name")) {
        mat.name = *name;
        add_name(material_names_, material_origins_, *name, t, "name", "material");
      }
      mat.young = t.number("E").value_or(0);
      mat.density = t.number("density").value_or(0);
      if (t.present("nu") && t.present("G"))
        t.error("G", "give either nu or G, not both");
      else if (!t.present("nu") && !t.present("G") && !t.misspelt("nu") && !t.misspelt("G"))
        t.error("missing required key 'nu' or 'G' (give one)");
      else if (auto g = t.number("G"))
        mat.shear = *g;
      else if (auto nu = t.number("nu"))
        mat.shear = mat.young / (2 * (1 + *nu));
      model_.materials.push_back(mat);
    }
  }

  void sections() {
    for (const CheckedTable& t : root_.tables("sections")) {
      Section s;
      if (auto name = t.string("name")) {
        s.name = *name;
        add_name(section_names_, section_origins_, *name, t, "name", "section");
      }
      const auto first_of = [&](std::span<const std::string_view> keys) -> std::string_view {
        for (std::string_view k : keys)
          if (t.present(k))
            return k;
        return {};
      };
      const std::string_view stiffness = first_of(kStiffnessKeys);
      const std::string_view shape = first_of(kShapeKeys);
      if (!stiffness.empty() && !shape.empty())
        t.error(fmt::format("give either stiffnesses (EA, GA, EI, GJ, ...) or a shape with a "
                            "material, not both; found '{}' and '{}'",
                            stiffness, shape));
      else if (!shape.empty())
        s = shape_section(t, s.name);
      else if (!stiffness.empty())
        stiffness_section(t, s);
      else if (std::none_of(std::begin(kSectionKeys), std::end(kSectionKeys),
                            [&](const KeySpec& k) { return t.misspelt(k.name); }))
        t.error("missing the section's properties: give stiffnesses (EA, GA, EI, GJ) or shape "
                "and material");
      model_.sections.push_back(s);
      section_tables_.push_back(&t);
    }
  }

  /// A stiffness given either as one value or as a pair for axes 1 and 2.
  void stiffness_pair(const CheckedTable& t, std::string_view both, std::string_view one,
                      std::string_view two, double& v1, double& v2) {
    if (t.present(both)) {
      for (std::string_view k : {one, two})
        if (t.present(k))
          t.error(k, fmt::format("give either {} or {} and {}, not both", both, one, two));
      v1 = v2 = t.number(both).value_or(0);
      return;
    }
    if (!t.present(one) && !t.present(two)) {
      if (!t.misspelt(both) && !t.misspelt(one) && !t.misspelt(two))
        t.error(fmt::format("missing required key '{}' (a number > 0), or '{}' and '{}'", both, one,
                            two));
      return;
    }
    for (auto [k, other] : {std::pair{one, two}, std::pair{two, one}})
      if (!t.present(k) && !t.misspelt(k))
        t.error(other, fmt::format("'{}' needs '{}' as well (or give '{}' alone)", other, k, both));
    v1 = t.number(one).value_or(0);
    v2 = t.number(two).value_or(0);
  }

  void stiffness_section(const CheckedTable& t, Section& s) {
    for (std::string_view k : {"EA", "GJ"})
      if (!t.present(k))
        t.missing(k, "a number > 0");
    s.EA = t.number("EA").value_or(0);
    s.GJ = t.number("GJ").value_or(0);
    stiffness_pair(t, "GA", "GA1", "GA2", s.GA1, s.GA2);
    stiffness_pair(t, "EI", "EI1", "EI2", s.EI1, s.EI2);
    s.EI12 = t.number("EI12").value_or(0);
    if (s.EI1 > 0 && s.EI2 > 0 && s.EI12 * s.EI12 >= s.EI1 * s.EI2)
      t.error("EI12", fmt::format("expected |EI12| < sqrt(EI1 EI2) = {} (positive definite "
                                  "bending stiffness), found {}",
                                  std::sqrt(s.EI1 * s.EI2), s.EI12));
    s.rhoA = t.number("rhoA").value_or(0);
    s.rhoJ = t.vector3("rhoJ").value_or(Eigen::Vector3d::Zero());
  }

  Section shape_section(const CheckedTable& t, const std::string& name) {
    Section s;
    s.name = name;
    if (!t.present("shape")) {
      t.missing("shape", "\"circle\", \"ellipse\" or \"superellipse\"");
      return s;
    }
    if (!t.present("material"))
      t.missing("material", "a string, for a section given by its shape");
    const std::optional<int> material =
        lookup(material_names_, t, "material", "material", "[[materials]]");
    const std::optional<std::string> shape_name = t.string("shape");
    if (!shape_name)
      return s;
    static constexpr std::string_view kShapes[] = {"circle", "ellipse", "superellipse"};
    SectionShape shape{};
    std::vector<std::string_view> needed, unused;
    if (*shape_name == "circle") {
      shape = SectionShape::Circle;
      needed = {"radius"};
      unused = {"a", "b", "exponent"};
    } else if (*shape_name == "ellipse") {
      shape = SectionShape::Ellipse;
      needed = {"a", "b"};
      unused = {"radius", "exponent"};
    } else if (*shape_name == "superellipse") {
      shape = SectionShape::SuperEllipse;
      needed = {"a", "b", "exponent"};
      unused = {"radius"};
    } else {
      const std::string_view suggestion = closest(*shape_name, kShapes);
      t.error("shape",
              fmt::format("expected \"circle\", \"ellipse\" or \"superellipse\", found "
                          "\"{}\"{}",
                          *shape_name,
                          suggestion.empty() ? std::string()
                                             : fmt::format("; did you mean \"{}\"?", suggestion)));
      return s;
    }
    bool ok = true;
    for (std::string_view k : needed) {
      if (!t.present(k)) {
        t.missing(k, fmt::format("a number > 0, for shape = \"{}\"", *shape_name));
        ok = false;
      }
      ok = ok && t.valid(k);
    }
    for (std::string_view k : unused)
      if (t.present(k)) {
        t.error(k, fmt::format("'{}' does not apply to shape = \"{}\" (it needs {})", k,
                               *shape_name, fmt::join(needed, ", ")));
        ok = false;
      }
    for (std::string_view k : {"reduce_I1", "reduce_I2", "shear_factor"})
      ok = ok && (!t.present(k) || t.valid(k));
    if (!ok || !material)
      return s;
    const double a = shape == SectionShape::Circle ? *t.number("radius") : *t.number("a");
    const double b = shape == SectionShape::Circle ? a : *t.number("b");
    return section_from_shape(name, shape, a, b, t.number("exponent").value_or(2),
                              model_.materials[static_cast<std::size_t>(*material)],
                              t.number("reduce_I1").value_or(1), t.number("reduce_I2").value_or(1),
                              t.number("shear_factor").value_or(5.0 / 6.0));
  }

  void nodes() {
    const toml::node* n = root_.node("nodes");
    if (n == nullptr)
      return;
    const toml::source_region where = root_.source("nodes");
    if (const toml::table* table = n->as_table()) {
      const CheckedTable t(*table, kNodeTable, "nodes", diagnostics_, where);
      const auto points = t.points("coordinates");
      if (!points) {
        nodes_broken_ = true;
        return;
      }
      for (std::size_t i = 0; i < points->size(); ++i)
        add_node((*points)[i], static_cast<long long>(i + 1), t.source("coordinates", i),
                 fmt::format("nodes.coordinates[{}]", i));
      return;
    }
    const toml::array* array = n->as_array();
    if (array == nullptr || !array->is_array_of_tables()) {
      root_.error("nodes",
                  fmt::format("expected a table [nodes] with coordinates = [[x, y, z], ...] or an "
                              "array of tables [[nodes]] with id and position, found {}",
                              describe_found(*n)));
      nodes_broken_ = true;
      return;
    }
    explicit_labels_ = true;
    for (std::size_t i = 0; i < array->size(); ++i) {
      const CheckedTable t(*array->get(i)->as_table(), kNodeItem, fmt::format("nodes[{}]", i),
                           diagnostics_, root_.source("nodes", i));
      const auto id = t.integer("id");
      const auto position = t.vector3("position");
      if (!id || !position) {
        nodes_broken_ = true;
        continue;
      }
      if (const auto it = label_to_node_.find(*id); it != label_to_node_.end()) {
        t.error("id", fmt::format("expected a unique node id, found {} again (first at line {})",
                                  *id, node_origin_[it->second].where.begin.line));
        continue;
      }
      add_node(*position, *id, t.source(), t.path());
    }
  }

  /// Direction of section axis 1; reported when zero or parallel to `axis`.
  std::optional<Eigen::Vector3d> reference_vector(const CheckedTable& t,
                                                  const Eigen::Vector3d& axis,
                                                  std::string_view what) const {
    if (t.present("reference_vector") && !t.valid("reference_vector"))
      return std::nullopt;
    const Eigen::Vector3d r = t.vector3("reference_vector").value_or(Eigen::Vector3d::UnitY());
    if (r.norm() == 0) {
      t.error("reference_vector", "expected a non-zero vector, found [0, 0, 0]");
      return std::nullopt;
    }
    if (axis.norm() > 0 && axis.cross(r).norm() <= 1e-6 * axis.norm() * r.norm()) {
      t.error("reference_vector",
              fmt::format("expected a vector not parallel to the axis of {} {}, found {}{}", what,
                          vector_text(axis.normalized()), vector_text(r),
                          t.present("reference_vector") ? "" : " (the default)"));
      return std::nullopt;
    }
    return r.normalized();
  }

  void add_node_set(const std::string& name, std::vector<int> nodes, const CheckedTable& t,
                    std::string_view key) {
    // The sorted set loses the order of the deck, which tells a spline which end comes first.
    std::vector<int> written;
    std::unordered_set<int> seen;
    for (int n : nodes)
      if (seen.insert(n).second)
        written.push_back(n);
    node_set_order_.push_back(std::move(written));
    std::sort(nodes.begin(), nodes.end());
    nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
    add_name(node_set_names_, node_set_origins_, name, t, key, "node set");
    model_.node_sets.push_back({name, std::move(nodes)});
  }

  /// Nodes and node sets of [[lines]]; their elements are added after [[elements]].
  void lines() {
    long long next_label = 1;
    for (const auto& [label, index] : label_to_node_)
      next_label = std::max(next_label, label + 1);
    for (const CheckedTable& t : root_.tables("lines")) {
      Line line;
      const auto name = t.string("name");
      const auto from = t.vector3("from");
      const auto to = t.vector3("to");
      const auto count = t.integer("elements");
      std::vector<int> nodes;
      if (from && to && count) {
        if (*from == *to) {
          t.error("to", fmt::format("expected a point different from 'from', found {}",
                                    vector_text(*to)));
          nodes_broken_ = true;
        } else {
          line.elements = static_cast<int>(*count);
          line.first_node = static_cast<int>(model_.nodes.size());
          const int n = 2 * line.elements + 1;
          for (int k = 0; k < n; ++k) {
            const double s = static_cast<double>(k) / (n - 1);
            nodes.push_back(add_node((1 - s) * *from + s * *to, next_label++, t.source(),
                                     fmt::format("{} (node {} of the line)", t.path(), k + 1)));
          }
        }
      } else {
        nodes_broken_ = true; // labels after this line cannot be known
      }
      line.section = lookup(section_names_, t, "section", "section", "[[sections]]").value_or(-1);
      if (auto r = reference_vector(
              t, from && to ? Eigen::Vector3d(*to - *from) : Eigen::Vector3d::Zero(), "the line"))
        line.reference_vector = *r;
      else
        line.elements = 0;
      if (name) {
        // A repeated line name is reported once, for "<name>"; its other sets exist already.
        const bool repeated = std::find(node_set_names_.begin(), node_set_names_.end(), *name) !=
                              node_set_names_.end();
        add_node_set(*name, nodes, t, "name");
        if (repeated) {
          lines_.push_back(line);
          continue;
        }
        add_node_set(*name + ".start", nodes.empty() ? nodes : std::vector{nodes.front()}, t,
                     "name");
        add_node_set(*name + ".end", nodes.empty() ? nodes : std::vector{nodes.back()}, t, "name");
      }
      lines_.push_back(line);
    }
  }

  /// Element of nodes (first, middle, last), checked for distinct nodes and a valid frame.
  void elements() {
    for (const CheckedTable& t : root_.tables("elements")) {
      const auto section = lookup(section_names_, t, "section", "section", "[[sections]]");
      const auto conn = t.triples("connectivity");
      if (!conn) {
        elements_broken_ = true;
        continue;
      }
      if (t.present("reference_vector") && !t.valid("reference_vector")) {
        elements_broken_ = true;
        continue;
      }
      const toml::array& rows = *t.node("connectivity")->as_array();
      for (std::size_t e = 0; e < conn->size(); ++e) {
        const toml::array& row = *rows.get(e)->as_array();
        BeamElement element;
        bool ok = true;
        for (std::size_t j = 0; j < 3; ++j) {
          const auto index = node_index((*conn)[e][j], t, "connectivity",
                                        fmt::format("{}[{}][{}]", t.path("connectivity"), e, j),
                                        row.get(j)->source());
          ok = ok && index.has_value();
          element.nodes[j] = index.value_or(-1);
        }
        const std::string row_path = fmt::format("{}[{}]", t.path("connectivity"), e);
        if (!ok) {
          elements_broken_ = true;
          continue;
        }
        const auto& nd = element.nodes;
        if (nd[0] == nd[1] || nd[1] == nd[2] || nd[0] == nd[2]) {
          t.error("connectivity", e,
                  fmt::format("expected three different nodes, found [{}, {}, {}]", (*conn)[e][0],
                              (*conn)[e][1], (*conn)[e][2]));
          continue;
        }
        const Eigen::Vector3d axis = model_.nodes[nd[2]] - model_.nodes[nd[0]];
        if (axis.norm() == 0) {
          t.error("connectivity", e,
                  fmt::format("expected an element of non-zero length, found its first and last "
                              "nodes ({} and {}) at the same point {}",
                              (*conn)[e][0], (*conn)[e][2], vector_text(model_.nodes[nd[0]])));
          continue;
        }
        const auto r = reference_vector(
            t, axis,
            fmt::format("element [{}, {}, {}]", (*conn)[e][0], (*conn)[e][1], (*conn)[e][2]));
        if (!r) {
          elements_broken_ = true;
          break; // one report per block is enough
        }
        element.reference_vector = *r;
        element.section = section.value_or(0);
        model_.elements.push_back(element);
        used_sections_.push_back(section.value_or(-1));
      }
    }
    for (const Line& line : lines_) {
      for (int e = 0; e < line.elements; ++e) {
        BeamElement element;
        for (int j = 0; j < 3; ++j)
          element.nodes[static_cast<std::size_t>(j)] = line.first_node + 2 * e + j;
        element.section = std::max(line.section, 0);
        element.reference_vector = line.reference_vector;
        model_.elements.push_back(element);
        used_sections_.push_back(line.section);
      }
      if (line.elements == 0)
        elements_broken_ = true;
    }
    if (model_.elements.empty() && !elements_broken_ && !nodes_broken_)
      root_.error("the deck has no elements: add [[lines]] or [[elements]]");
  }

  /// Node indices of a Labels key, each missing label reported.
  std::vector<int> node_list(const CheckedTable& t, std::string_view key) const {
    std::vector<int> out;
    const auto labels = t.labels(key);
    if (!labels)
      return out;
    for (std::size_t i = 0; i < labels->size(); ++i)
      if (auto index = node_index((*labels)[i], t, key, fmt::format("{}[{}]", t.path(key), i),
                                  t.source(key, i)))
        out.push_back(*index);
    return out;
  }

  void node_sets() {
    for (const CheckedTable& t : root_.tables("node_sets")) {
      std::vector<int> nodes = node_list(t, "nodes");
      if (auto name = t.string("name"))
        add_node_set(*name, std::move(nodes), t, "name");
    }
  }

  std::optional<int> node_set(const CheckedTable& t) const {
    return lookup(node_set_names_, t, "node_set", "node set", "[[node_sets]] or [[lines]]");
  }

  void constraints() {
    static constexpr std::string_view kDofNames[] = {"ux", "uy", "uz", "rx", "ry", "rz"};
    static constexpr std::string_view kWords[] = {"all", "translations", "rotations", "ux", "uy",
                                                  "uz",  "rx",           "ry",        "rz"};
    for (const CheckedTable& t : root_.tables("constraints")) {
      Constraint c;
      c.node_set = node_set(t).value_or(-1);
      const auto words = t.words("dofs");
      if (!words)
        continue;
      for (std::size_t i = 0; i < words->size(); ++i) {
        const std::string& w = (*words)[i];
        if (w == "all" || w == "translations" || w == "rotations") {
          for (int d = 0; d < kDofsPerNode; ++d)
            if (w == "all" || (w == "translations") == (d < 3))
              c.fixed[static_cast<std::size_t>(d)] = true;
          continue;
        }
        const auto it = std::find(std::begin(kDofNames), std::end(kDofNames), w);
        if (it != std::end(kDofNames)) {
          c.fixed[static_cast<std::size_t>(it - std::begin(kDofNames))] = true;
          continue;
        }
        const std::string_view suggestion = closest(w, kWords);
        const std::string message = fmt::format(
            "expected \"all\", \"translations\", \"rotations\" or DOF names \"ux\", \"uy\", "
            "\"uz\", \"rx\", \"ry\", \"rz\", found \"{}\"{}",
            w,
            suggestion.empty() ? std::string() : fmt::format("; did you mean \"{}\"?", suggestion));
        if (t.node("dofs")->is_array())
          t.error("dofs", i, message);
        else
          t.error("dofs", message);
      }
      model_.constraints.push_back(c);
    }
  }

  void prescribed() {
    for (const CheckedTable& t : root_.tables("prescribed")) {
      PrescribedMotion p;
      p.node_set = node_set(t).value_or(-1);
      if (!t.present("displacement") && !t.present("rotation") && !t.misspelt("displacement") &&
          !t.misspelt("rotation"))
        t.error("missing required key 'displacement' or 'rotation' (give at least one)");
      if (const CheckedTable* d = t.table("displacement")) {
        if (!d->present("x") && !d->present("y") && !d->present("z"))
          d->error("expected at least one of x, y, z, found none");
        p.displacement = {d->time_table("x"), d->time_table("y"), d->time_table("z")};
      }
      if (const CheckedTable* r = t.table("rotation")) {
        auto x = r->time_table("x");
        auto y = r->time_table("y");
        auto z = r->time_table("z");
        if (x && y && z)
          p.rotation = std::array<TimeTable, 3>{*x, *y, *z};
      }
      model_.prescribed.push_back(std::move(p));
    }
  }

  void loads() {
    for (const CheckedTable& t : root_.tables("loads")) {
      NodalLoad load;
      load.node_set = node_set(t).value_or(-1);
      if (!t.present("force") && !t.present("moment") && !t.misspelt("force") &&
          !t.misspelt("moment"))
        t.error("missing required key 'force' or 'moment' (give at least one)");
      load.force = t.vector3("force").value_or(Eigen::Vector3d::Zero());
      load.moment = t.vector3("moment").value_or(Eigen::Vector3d::Zero());
      load.follower_moment = t.boolean("follower").value_or(false);
      if (load.follower_moment && !t.present("moment"))
        t.error("follower", "expected a 'moment' for follower = true (only moments follow the "
                            "node), found none");
      if (const auto axes = t.string("axes")) {
        if (*axes == "section") {
          load.axes = LoadAxes::Section;
        } else if (*axes != "global") {
          static constexpr std::string_view kAxes[] = {"global", "section"};
          const std::string_view suggestion = closest(*axes, kAxes);
          t.error("axes", fmt::format("expected \"global\" or \"section\", found \"{}\"{}", *axes,
                                      suggestion.empty()
                                          ? std::string()
                                          : fmt::format("; did you mean \"{}\"?", suggestion)));
        }
      }
      if (auto table = t.time_table("table"))
        load.factor = *table;
      model_.loads.push_back(std::move(load));
    }
  }

  void steps() {
    const auto all = root_.tables("steps");
    if (all.empty() && root_.valid("steps"))
      root_.error("steps", "expected at least one [[steps]], found none");
    std::optional<double> start = 0.0;
    std::string previous = "the start";
    for (const CheckedTable& t : all) {
      SolutionStep step;
      const auto type = t.string("type");
      bool known_type = type.has_value();
      if (type == "static") {
        step.type = StepType::Static;
      } else if (type == "dynamic") {
        step.type = StepType::Dynamic;
      } else if (type == "explicit") {
        step.type = StepType::Explicit;
      } else if (type) {
        known_type = false;
        static constexpr std::string_view kTypes[] = {"static", "dynamic", "explicit"};
        const std::string_view suggestion = closest(*type, kTypes);
        t.error("type", fmt::format("expected \"static\", \"dynamic\" or \"explicit\", found "
                                    "\"{}\"{}",
                                    *type,
                                    suggestion.empty()
                                        ? std::string()
                                        : fmt::format("; did you mean \"{}\"?", suggestion)));
      }
      if (known_type && step.type != StepType::Dynamic && t.present("newmark"))
        t.error("newmark", fmt::format("'newmark' applies only to type = \"dynamic\"; this step "
                                       "is \"{}\"",
                                       *type));
      if (known_type && step.type == StepType::Static && t.present("rayleigh"))
        t.error("rayleigh", "'rayleigh' damping applies only to dynamic and explicit steps; this "
                            "step is \"static\"");
      if (const CheckedTable* ray = t.table("rayleigh");
          ray && known_type && step.type == StepType::Explicit && ray->present("out_of_plane"))
        ray->error("out_of_plane", "'out_of_plane' damping applies only to dynamic (Newmark) "
                                   "steps; this step is \"explicit\"");
      if (known_type && step.type == StepType::Explicit)
        for (std::string_view k : {"max_iterations", "tolerance", "dt_max"})
          if (t.present(k))
            t.error(k, fmt::format("'{}' applies only to implicit (static, dynamic) steps; this "
                                   "step is \"explicit\"",
                                   k));
      if (known_type && step.type != StepType::Explicit)
        for (std::string_view k :
             {"safety_factor", "mass_scaling_dt", "stable_dt_every", "energy_monitor"})
          if (t.present(k))
            t.error(k, fmt::format("'{}' applies only to type = \"explicit\"; this step is "
                                   "\"{}\"",
                                   k, *type));
      if (known_type && step.type != StepType::Static)
        dynamic_step_ = dynamic_step_ ? dynamic_step_ : &t;
      if (known_type && step.type == StepType::Explicit)
        explicit_step_ = explicit_step_ ? explicit_step_ : &t;
      if (known_type && step.type == StepType::Dynamic)
        newmark_step_ = newmark_step_ ? newmark_step_ : &t;

      const auto end = t.number("end_time");
      if (end && start && *end <= *start)
        t.error("end_time", fmt::format("expected an end time > {} (the end of {}; times are "
                                        "absolute), found {}",
                                        *start, previous, *end));
      const auto dt = t.number("dt");
      const double duration = end && start ? *end - *start : 0;
      if (dt && duration > 0 && *dt > duration * (1 + 1e-12))
        t.error("dt", fmt::format("expected a time step <= the step's duration {}, found {}",
                                  duration, *dt));
      step.end_time = end.value_or(0);
      step.dt_initial = dt.value_or(0);
      // Without limits the step does not grow, and may shrink by three orders of magnitude.
      step.dt_max = t.number("dt_max").value_or(step.dt_initial);
      step.dt_min = t.number("dt_min").value_or(std::min(step.dt_initial, step.dt_max) * 1e-3);
      if (t.valid("dt_min") && t.valid("dt_max") && step.dt_min > step.dt_max)
        t.error("dt_min",
                fmt::format("expected dt_min <= dt_max ({}), found {}", step.dt_max, step.dt_min));
      else if (dt && t.valid("dt_max") && *dt > step.dt_max)
        t.error("dt", fmt::format("expected dt <= dt_max ({}), found {}", step.dt_max, *dt));
      else if (dt && t.valid("dt_min") && *dt < step.dt_min)
        t.error("dt", fmt::format("expected dt >= dt_min ({}), found {}", step.dt_min, *dt));

      step.max_iterations = static_cast<int>(t.integer("max_iterations").value_or(20));
      if (const CheckedTable* tol = t.table("tolerance")) {
        step.tol_force = tol->number("force").value_or(step.tol_force);
        step.tol_increment = tol->number("increment").value_or(step.tol_increment);
      }
      if (const CheckedTable* nm = t.table("newmark")) {
        step.newmark_beta = nm->number("beta").value_or(step.newmark_beta);
        step.newmark_gamma = nm->number("gamma").value_or(step.newmark_gamma);
      }
      if (const CheckedTable* ray = t.table("rayleigh")) {
        step.rayleigh_mass = ray->number("mass").value_or(0);
        step.rayleigh_stiffness = ray->number("stiffness").value_or(0);
        step.rayleigh_out_of_plane = ray->number("out_of_plane").value_or(0);
      }
      step.output_every = static_cast<int>(
          std::min<long long>(t.integer("output_every").value_or(1), 1'000'000'000));
      step.safety_factor = t.number("safety_factor").value_or(step.safety_factor);
      step.mass_scaling_dt = t.number("mass_scaling_dt").value_or(0);
      step.stable_dt_every = static_cast<int>(std::min<long long>(
          t.integer("stable_dt_every").value_or(step.stable_dt_every), 1'000'000'000));
      step.energy_monitor = t.boolean("energy_monitor").value_or(true);
      model_.steps.push_back(step);
      start = end;
      previous = t.path();
    }
  }

  void monitors() {
    std::vector<std::string> names;
    std::vector<Origin> origins;
    for (const CheckedTable& t : root_.tables("monitors")) {
      Monitor m;
      if (auto name = t.string("name")) {
        m.name = *name;
        const bool safe = !name->empty() && std::all_of(name->begin(), name->end(), [](char c) {
          return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
        });
        if (!safe)
          t.error("name", fmt::format("expected a name made of letters, digits, '_', '-' and "
                                      "'.' (it names the output file), found \"{}\"",
                                      *name));
        add_name(names, origins, *name, t, "name", "monitor");
      }
      std::vector<std::string_view> given;
      for (std::string_view k : {"node", "node_set", "element"})
        if (t.present(k))
          given.push_back(k);
      if (given.size() != 1) {
        t.error(fmt::format("expected exactly one of 'node', 'node_set', 'element', found {}",
                            given.empty() ? std::string("none")
                                          : fmt::format("{}", fmt::join(given, ", "))));
      } else if (given[0] == "node") {
        m.type = MonitorType::Node;
        if (auto label = t.integer("node"))
          m.target = node_index(*label, t, "node", "", t.source("node")).value_or(-1);
      } else if (given[0] == "node_set") {
        m.type = MonitorType::NodeSet;
        m.target = node_set(t).value_or(-1);
      } else {
        m.type = MonitorType::Element;
        const auto e = t.integer("element");
        const auto n = static_cast<long long>(model_.elements.size());
        if (e && !elements_broken_ && *e > n)
          t.error("element", fmt::format("expected an element number in [1, {}] (elements are "
                                         "numbered from 1: [[elements]] rows, then [[lines]]), "
                                         "found {}",
                                         n, *e));
        m.target = static_cast<int>(std::clamp(e.value_or(1), 1LL, std::max(n, 1LL)) - 1);
      }
      model_.monitors.push_back(m);
    }
  }

  // -------------------------------------------------------------------------------------------
  // Beam-to-beam spline contact (formulation.md §5): contact curves and the pairs of groups that
  // may touch.

  /// Whether the chain checks of splines can trust the nodes and elements.
  bool chain_checkable() const { return !nodes_broken_ && !elements_broken_; }

  /// The element in which nodes a and b are neighbours (first and middle, or middle and last);
  /// -1 when there is none.
  int element_joining(int a, int b) const {
    for (const auto& [e, j] : incident_[static_cast<std::size_t>(a)]) {
      const auto& nd = model_.elements[static_cast<std::size_t>(e)].nodes;
      if ((j > 0 && nd[static_cast<std::size_t>(j - 1)] == b) ||
          (j < 2 && nd[static_cast<std::size_t>(j + 1)] == b))
        return e;
    }
    return -1;
  }

  /// Labels of the nodes next to node a along its elements.
  std::vector<long> neighbour_labels(int a) const {
    std::vector<long> out;
    for (const auto& [e, j] : incident_[static_cast<std::size_t>(a)]) {
      const auto& nd = model_.elements[static_cast<std::size_t>(e)].nodes;
      for (int k : {j - 1, j + 1}) {
        if (k < 0 || k > 2)
          continue;
        const long label = model_.node_label(nd[static_cast<std::size_t>(k)]);
        if (std::find(out.begin(), out.end(), label) == out.end())
          out.push_back(label);
      }
    }
    return out;
  }

  /// Why node b cannot follow node a along a spline (they are not neighbours in an element).
  std::string chain_break(int a, int b) const {
    const long la = model_.node_label(a);
    const long lb = model_.node_label(b);
    for (const auto& [e, j] : incident_[static_cast<std::size_t>(a)]) {
      const auto& nd = model_.elements[static_cast<std::size_t>(e)].nodes;
      if (j != 1 && nd[static_cast<std::size_t>(2 - j)] == b)
        return fmt::format("nodes {} and {} are the end nodes of element {}, so its middle node {} "
                           "must come between them (every node is a control point)",
                           la, lb, e + 1, model_.node_label(nd[1]));
    }
    const std::vector<long> next = neighbour_labels(a);
    if (next.empty())
      return fmt::format("node {} belongs to no element", la);
    return fmt::format("node {} shares no element with node {} (the nodes next to node {} are {})",
                       lb, la, la, fmt::join(next, ", "));
  }

  /// Spline nodes given as `nodes = [labels]`: in the order written, each next to the one before
  /// it in some element.
  std::vector<int> spline_nodes_of_list(const CheckedTable& t) const {
    const auto labels = t.labels("nodes");
    if (!labels)
      return {};
    std::vector<int> nodes = node_list(t, "nodes");
    if (nodes.size() != labels->size())
      return nodes; // a missing label is reported
    if (nodes.size() < 3) {
      t.error("nodes", fmt::format("expected at least 3 nodes (the control points of a quadratic "
                                   "B-spline), found {}",
                                   nodes.size()));
      return nodes;
    }
    std::unordered_set<int> seen{nodes[0]};
    for (std::size_t i = 1; i < nodes.size(); ++i) {
      if (!seen.insert(nodes[i]).second) {
        t.error("nodes", i,
                fmt::format("expected each node once (a spline is an open chain), found node {} "
                            "again",
                            (*labels)[i]));
        return nodes;
      }
      if (chain_checkable() && element_joining(nodes[i - 1], nodes[i]) < 0) {
        t.error("nodes", i,
                fmt::format("expected a node next to node {} along an element, found node {}: {}",
                            (*labels)[i - 1], (*labels)[i], chain_break(nodes[i - 1], nodes[i])));
        return nodes; // one report per spline is enough
      }
    }
    return nodes;
  }

  /// The nodes of a set ordered along the elements that join them, or why they are not one open
  /// chain. The walk starts from whichever end comes first in `written` (the deck's order).
  struct Chain {
    std::vector<int> nodes;
    std::string problem; ///< empty when the nodes form one open chain
  };
  Chain walk_chain(const std::vector<int>& written) const {
    std::unordered_map<int, std::size_t> position;
    for (std::size_t i = 0; i < written.size(); ++i)
      position.emplace(written[i], i);
    const auto in_set = [&](int n) { return position.count(n) != 0; };
    const auto label = [&](int n) { return model_.node_label(n); };
    std::vector<std::vector<int>> next(written.size());
    for (std::size_t i = 0; i < written.size(); ++i) {
      for (const auto& [e, j] : incident_[static_cast<std::size_t>(written[i])]) {
        const auto& nd = model_.elements[static_cast<std::size_t>(e)].nodes;
        if (j != 1 && in_set(nd[static_cast<std::size_t>(2 - j)]) && !in_set(nd[1]))
          return {{},
                  fmt::format("holds nodes {} and {}, the end nodes of element {}, without its "
                              "middle node {} (every node is a control point)",
                              label(nd[0]), label(nd[2]), e + 1, label(nd[1]))};
        for (int k : {j - 1, j + 1}) {
          if (k < 0 || k > 2)
            continue;
          const int b = nd[static_cast<std::size_t>(k)];
          if (in_set(b) && std::find(next[i].begin(), next[i].end(), b) == next[i].end())
            next[i].push_back(b);
        }
      }
    }
    for (std::size_t i = 0; i < written.size(); ++i) {
      if (next[i].empty())
        return {{},
                fmt::format("holds node {}, which is next to no other node of the set along an "
                            "element",
                            label(written[i]))};
      if (next[i].size() > 2) {
        std::vector<long> labels;
        for (int b : next[i])
          labels.push_back(label(b));
        return {{},
                fmt::format("branches at node {}, which is next to nodes {} of the set",
                            label(written[i]), fmt::join(labels, ", "))};
      }
    }
    const auto start = std::find_if(next.begin(), next.end(),
                                    [](const std::vector<int>& n) { return n.size() == 1; });
    if (start == next.end())
      return {{}, "forms a closed loop (a spline needs an open chain with two ends)"};
    // Every node has at most two neighbours, so from an end the walk follows a path to the
    // other end and cannot come back.
    std::vector<int> order{written[static_cast<std::size_t>(start - next.begin())]};
    int previous = -1;
    for (;;) {
      const std::vector<int>& n = next[position.at(order.back())];
      const auto step = std::find_if(n.begin(), n.end(), [&](int b) { return b != previous; });
      if (step == n.end())
        break;
      previous = order.back();
      order.push_back(*step);
    }
    if (order.size() != written.size()) {
      const std::unordered_set<int> walked(order.begin(), order.end());
      const auto left =
          std::find_if(written.begin(), written.end(), [&](int n) { return walked.count(n) == 0; });
      return {{},
              fmt::format("falls into separate pieces: the chain from node {} to node {} leaves "
                          "out node {}",
                          label(order.front()), label(order.back()), label(*left))};
    }
    return {std::move(order), {}};
  }

  /// Spline (or surface) nodes given as `node_set = "name"`: the set's nodes ordered along its
  /// elements. `purpose` says why 3 nodes are the least.
  std::vector<int> spline_nodes_of_set(
      const CheckedTable& t,
      std::string_view purpose = "the control points of a quadratic B-spline") const {
    const std::optional<int> set = node_set(t);
    if (!set)
      return {};
    const std::string& name = model_.node_sets[static_cast<std::size_t>(*set)].name;
    const std::vector<int>& written = node_set_order_[static_cast<std::size_t>(*set)];
    if (written.empty() && nodes_broken_)
      return {}; // a broken [[lines]] block, reported there
    if (written.size() < 3) {
      t.error("node_set", fmt::format("expected a node set of at least 3 nodes ({}), found '{}' "
                                      "with {}",
                                      purpose, name, written.size()));
      return written;
    }
    if (!chain_checkable())
      return written;
    Chain chain = walk_chain(written);
    if (!chain.problem.empty()) {
      t.error("node_set", fmt::format("expected the nodes of one chain of elements, found that "
                                      "node set '{}' {}",
                                      name, chain.problem));
      return written;
    }
    return std::move(chain.nodes);
  }

  /// [[splines]]: each spline's nodes in order along its yarn, and its radius.
  void splines() {
    const auto all = root_.tables("splines");
    if (all.empty())
      return;
    build_incidence();
    for (const CheckedTable& t : all) {
      Spline s;
      if (auto name = t.string("name")) {
        s.name = *name;
        add_name(spline_names_, spline_origins_, *name, t, "name", "spline");
      }
      s.radius = t.number("radius").value_or(0);
      const bool by_set = t.present("node_set");
      const bool by_list = t.present("nodes");
      if (by_set && by_list)
        t.error("nodes", "give either 'node_set' or 'nodes', not both");
      else if (by_set)
        s.nodes = spline_nodes_of_set(t);
      else if (by_list)
        s.nodes = spline_nodes_of_list(t);
      else if (!t.misspelt("node_set") && !t.misspelt("nodes"))
        t.error("missing required key 'node_set' or 'nodes' (the spline's nodes in order along "
                "the yarn)");
      model_.splines.push_back(std::move(s));
    }
  }

  /// incident_, for the chain checks of splines and surfaces (once).
  void build_incidence() {
    if (!chain_checkable() || !incident_.empty())
      return;
    incident_.assign(model_.nodes.size(), {});
    for (std::size_t e = 0; e < model_.elements.size(); ++e)
      for (int j = 0; j < 3; ++j)
        incident_[static_cast<std::size_t>(model_.elements[e].nodes[static_cast<std::size_t>(j)])]
            .emplace_back(static_cast<int>(e), j);
  }

  /// [[surfaces]]: on each element of a node set's chain, in order along it, the contact
  /// surface of the surface-to-surface contact (formulation.md §6). The semi-axes and exponent
  /// default to those of the elements' section shape.
  void surfaces() {
    const auto all = root_.tables("surfaces");
    if (all.empty())
      return;
    build_incidence();
    for (const CheckedTable& t : all) {
      Surface s;
      if (auto name = t.string("name")) {
        s.name = *name;
        add_name(surface_names_, surface_origins_, *name, t, "name", "surface");
      }
      const std::vector<int> chain = t.present("node_set")
                                         ? spline_nodes_of_set(t, "one 3-node element at least")
                                         : std::vector<int>{};
      if (chain.size() >= 3 && chain_checkable())
        s.elements = surface_elements(t, chain);
      // Semi-axes: the keys, else the section of the surface's elements. An element whose
      // section did not resolve (reported where it is named) holds a placeholder index, which
      // may not even exist: used_sections_ has the resolved index per element, or -1.
      const int section_index =
          s.elements.empty() ? -1 : used_sections_[static_cast<std::size_t>(s.elements.front())];
      const Section* section =
          section_index < 0 ? nullptr : &model_.sections[static_cast<std::size_t>(section_index)];
      const bool shaped = section != nullptr && section->shape != SectionShape::General;
      for (std::string_view key : {"a", "b"}) {
        if (t.present(key) || section == nullptr || shaped)
          continue;
        t.error(fmt::format("missing required key '{}' (semi-axis of the contact section, m): "
                            "the elements' section '{}' gives stiffnesses, not a shape",
                            key, section->name));
      }
      if (shaped) {
        s.a = section->a;
        s.b = section->shape == SectionShape::Circle ? section->a : section->b;
        s.exponent = section->exponent;
      }
      s.a = t.number("a").value_or(s.a);
      s.b = t.number("b").value_or(s.b);
      s.exponent = t.number("exponent").value_or(s.exponent);
      model_.surfaces.push_back(std::move(s));
    }
  }

  /// The elements along a chain of nodes (n0, n1, n2, n3, n4, ...: one element per three), each
  /// running along it (its first node is the last of the one before).
  std::vector<int> surface_elements(const CheckedTable& t, std::vector<int> chain) const {
    std::vector<int> out;
    if (chain.size() % 2 == 0) {
      t.error("node_set", fmt::format("expected the nodes of whole 3-node elements (an odd "
                                      "number along the chain), found {}",
                                      chain.size()));
      return out;
    }
    auto element_of = [&](int a, int m, int b, bool& forward) {
      for (const auto& [e, j] : incident_[static_cast<std::size_t>(m)]) {
        const auto& nd = model_.elements[static_cast<std::size_t>(e)].nodes;
        if (j != 1)
          continue;
        if (nd[0] == a && nd[2] == b) {
          forward = true;
          return e;
        }
        if (nd[0] == b && nd[2] == a) {
          forward = false;
          return e;
        }
      }
      return -1;
    };
    // The chain may run against the elements: then it is walked from its other end.
    bool forward = true;
    if (element_of(chain[0], chain[1], chain[2], forward) >= 0 && !forward)
      std::reverse(chain.begin(), chain.end());
    for (std::size_t k = 0; k + 2 < chain.size(); k += 2) {
      bool fwd = true;
      const int e = element_of(chain[k], chain[k + 1], chain[k + 2], fwd);
      if (e < 0 || !fwd) {
        t.error(
            "node_set",
            fmt::format(
                fmt::runtime(e < 0 ? "expected one element on nodes {}, {}, {} (first, middle, "
                                     "last) of the chain, found none"
                                   : "expected the elements to run one way along the chain, found "
                                     "the element on nodes {}, {}, {} running against the others"),
                model_.node_label(chain[k]), model_.node_label(chain[k + 1]),
                model_.node_label(chain[k + 2])));
        return {};
      }
      out.push_back(e);
    }
    return out;
  }

  /// What a contact's groups name: splines or surfaces.
  struct ContactKind {
    const std::vector<std::string>& names;
    std::string_view noun;  ///< "spline"
    std::string_view block; ///< "[[splines]]"
  };

  /// A spline or surface name in a contact group and where the deck gives it.
  struct NameAt {
    std::string name;
    toml::source_region where;
    std::string path;
  };

  /// One group: a spline name or a non-empty array of them; nullopt after reporting.
  std::optional<std::vector<NameAt>> contact_group(const toml::node& group,
                                                   const toml::source_region& fallback,
                                                   const std::string& path,
                                                   const ContactKind& kind) const {
    const auto where = [&](const toml::node& n) {
      return n.source().begin.line != 0 ? n.source() : fallback;
    };
    if (const auto* s = group.as_string())
      return std::vector<NameAt>{{std::string(s->get()), where(group), path}};
    const toml::array* a = group.as_array();
    if (a == nullptr || a->empty()) {
      diagnostics_.error(where(group), path,
                         fmt::format("expected a {0} name or an array of {0} names, found {1}",
                                     kind.noun, describe_found(group)));
      return std::nullopt;
    }
    std::vector<NameAt> out;
    bool ok = true;
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::node& item = *a->get(i);
      const std::string item_path = fmt::format("{}[{}]", path, i);
      if (const auto* s = item.as_string()) {
        out.push_back({std::string(s->get()), where(item), item_path});
      } else {
        diagnostics_.error(where(item), item_path,
                           fmt::format("expected a {} name (a string), found {}", kind.noun,
                                       describe_found(item)));
        ok = false;
      }
    }
    return ok ? std::optional(std::move(out)) : std::nullopt;
  }

  /// `between = [group, group]` (or one group), or `group_a` and `group_b`, resolved to spline
  /// or surface indices. A single group leaves group_b empty; it needs self_contact = true, which
  /// allows contact within each group (between its splines and of a spline with itself; splines
  /// only).
  void contact_groups(const CheckedTable& t, const ContactKind& kind, std::vector<int>& group_a,
                      std::vector<int>& group_b) const {
    const bool between = t.present("between");
    const bool a = t.present("group_a");
    const bool b = t.present("group_b");
    std::vector<std::vector<NameAt>> groups;
    bool ok = true;
    if (between && (a || b)) {
      t.error(a ? "group_a" : "group_b",
              "give either 'between' or 'group_a' and 'group_b', not both");
      return;
    }
    if (between) {
      const toml::node& n = *t.node("between");
      const toml::array* array = n.as_array();
      if (array == nullptr || array->empty() || array->size() > 2) {
        t.error("between", fmt::format("expected one or two groups of {} names, [[\"a\", "
                                       "...], [\"b\", ...]], found {}",
                                       kind.noun, describe_found(n)));
        return;
      }
      for (std::size_t i = 0; i < array->size(); ++i) {
        auto group = contact_group(*array->get(i), t.source("between", i),
                                   fmt::format("{}[{}]", t.path("between"), i), kind);
        ok = group.has_value() && ok;
        if (group)
          groups.push_back(std::move(*group));
      }
    } else if (a) {
      for (std::string_view key : {"group_a", "group_b"}) {
        if (!t.present(key))
          continue;
        ok = t.valid(key) && ok; // a wrong type is reported by the schema
        if (t.valid(key))
          groups.push_back(*contact_group(*t.node(key), t.source(key), t.path(key), kind));
      }
    } else if (b) {
      t.error("group_b", "'group_b' needs 'group_a' as well (or give 'between')");
      return;
    } else {
      if (!t.misspelt("between") && !t.misspelt("group_a") && !t.misspelt("group_b"))
        t.error(fmt::format("missing required key 'between' (one or two groups of {} names), or "
                            "'group_a' and 'group_b'",
                            kind.noun));
      return;
    }
    if (!ok)
      return;

    std::unordered_map<std::string, std::pair<std::size_t, std::string>> first; // group, path
    for (std::size_t g = 0; g < groups.size(); ++g) {
      std::vector<int>& out = g == 0 ? group_a : group_b;
      for (const NameAt& n : groups[g]) {
        const auto it = std::find(kind.names.begin(), kind.names.end(), n.name);
        if (it == kind.names.end()) {
          diagnostics_.error(
              n.where, n.path,
              unknown_name(kind.names, n.name, std::string(kind.noun), std::string(kind.block)));
          continue;
        }
        if (const auto f = first.find(n.name); f != first.end()) {
          diagnostics_.error(
              n.where, n.path,
              f->second.first == g
                  ? fmt::format("expected each {} once in a group, found '{}' again (first "
                                "at {})",
                                kind.noun, n.name, f->second.second)
                  : fmt::format("expected each {} in one group only, found '{}' in both "
                                "groups (also at {})",
                                kind.noun, n.name, f->second.second));
          continue;
        }
        first.emplace(n.name, std::pair{g, n.path});
        out.push_back(static_cast<int>(it - kind.names.begin()));
      }
    }
    // One group touches nothing but itself: that is self-contact, and must be asked for.
    if (groups.size() == 1 && kind.noun == "surface") {
      t.error(between ? "between" : "group_a",
              "expected two groups of surfaces, found one (surface contact within a group is not "
              "available)");
    } else if (groups.size() == 1) {
      if (!t.present("self_contact"))
        t.error(between ? "between" : "group_a",
                "expected two groups of splines, found one (a single group is for contact "
                "within it: give self_contact = true)");
      else if (t.boolean("self_contact") == false)
        t.error("self_contact", "expected true with a single group of splines (contact within "
                                "it), found false");
    }
  }

  /// Which step is explicit, for messages ("steps[2]"), or empty.
  std::string explicit_step_path() const {
    return explicit_step_ != nullptr ? explicit_step_->path() : std::string();
  }

  /// Contact damping (the law's normal `damping`, friction's `tangential_damping`) acts through
  /// the velocities of implicit dynamic steps: reported at the key when the deck has an explicit
  /// step (not available there) or no dynamic step (it would act on nothing).
  void contact_damping_steps(const CheckedTable& t, double normal, double tangential) const {
    for (const auto& [key, value] :
         {std::pair<const char*, double>{"damping", normal}, {"tangential_damping", tangential}}) {
      if (!(value > 0))
        continue;
      if (explicit_step_ != nullptr)
        t.error(key, fmt::format("contact damping is not available on the explicit path in this "
                                 "version ({} is explicit)",
                                 explicit_step_->path()));
      else if (newmark_step_ == nullptr)
        t.error(key, "contact damping acts on the velocities of dynamic steps, and this deck has "
                     "none (static steps have no velocities); remove the key or set it to 0");
    }
  }

  /// The normal interface law (formulation.md §4): linear penalty (optionally regularised) or
  /// power law.
  void contact_law(const CheckedTable& t, InterfaceLawParameters& law) const {
    law.penalty = t.number("penalty").value_or(0);
    law.damping = t.number("damping").value_or(0);
    law.regularisation = t.number("regularisation").value_or(0);
    const std::optional<std::string> name =
        t.present("law") ? t.string("law") : std::optional<std::string>("linear");
    if (name == "linear") {
      if (t.present("exponent"))
        t.error("exponent", fmt::format("'exponent' applies only to law = \"power\"; this "
                                        "contact's law is \"linear\"{}",
                                        t.present("law") ? "" : " (the default)"));
    } else if (name == "power") {
      if (!t.present("exponent"))
        t.missing("exponent", "a number >= 1, for law = \"power\"");
      law.exponent = t.number("exponent").value_or(1);
      if (t.present("regularisation"))
        t.error("regularisation", "'regularisation' applies only to law = \"linear\"; this "
                                  "contact's law is \"power\"");
    } else if (name) {
      static constexpr std::string_view kLaws[] = {"linear", "power"};
      const std::string_view suggestion = closest(*name, kLaws);
      t.error("law",
              fmt::format("expected \"linear\" or \"power\", found \"{}\"{}", *name,
                          suggestion.empty() ? std::string()
                                             : fmt::format("; did you mean \"{}\"?", suggestion)));
    }
  }

  /// [[contacts]]: spline or surface groups as indices into Model::splines or Model::surfaces,
  /// and the interface law.
  void contacts() {
    std::vector<std::string> names;
    std::vector<Origin> origins;
    for (const CheckedTable& t : root_.tables("contacts")) {
      std::string name;
      if (auto n = t.string("name")) {
        name = *n;
        add_name(names, origins, *n, t, "name", "contact");
      }
      // An unknown type is reported, and the keys are then read as a spline contact's so that
      // their problems are reported too.
      const auto type = t.string("type");
      if (type && *type != "spline" && *type != "surface") {
        static constexpr std::string_view kTypes[] = {"spline", "surface"};
        const std::string_view suggestion = closest(*type, kTypes);
        t.error("type", fmt::format("expected \"spline\" (beam-to-beam contact of C1 splines) or "
                                    "\"surface\" (surface-to-surface contact of elliptical "
                                    "cylinders), found \"{}\"{}",
                                    *type,
                                    suggestion.empty()
                                        ? std::string()
                                        : fmt::format("; did you mean \"{}\"?", suggestion)));
      }
      if (type == "surface") {
        SurfaceContactDefinition c;
        c.name = name;
        contact_groups(t, {surface_names_, "surface", "[[surfaces]]"}, c.group_a, c.group_b);
        contact_law(t, c.law);
        if (c.law.damping > 0)
          t.error("damping", "surface contact damping is not available in this version; "
                             "remove the key or set it to 0");
        if (t.present("self_contact"))
          t.error("self_contact", "'self_contact' applies only to type = \"spline\"");
        for (const char* key :
             {"line_contact", "line_angle", "point_angle", "line_penalty", "gauss_points"})
          if (t.present(key))
            t.error(key, fmt::format("'{}' applies only to type = \"spline\"", key));
        // Pointwise friction with its tangential damping, and torsional friction.
        read_contact_friction(t, c.law, c.friction, explicit_step_path());
        contact_damping_steps(t, 0, c.friction.tangential_damping);
        c.margin = t.number("margin").value_or(0);
        model_.surface_contacts.push_back(std::move(c));
        continue;
      }
      SplineContactDefinition c;
      c.name = name;
      contact_groups(t, {spline_names_, "spline", "[[splines]]"}, c.group_a, c.group_b);
      contact_law(t, c.law);
      read_contact_friction(t, c.law, c.friction, explicit_step_path());
      contact_damping_steps(t, c.law.damping, c.friction.tangential_damping);
      c.self_contact = t.boolean("self_contact").value_or(false);
      c.margin = t.number("margin").value_or(0);
      c.line_contact = t.boolean("line_contact").value_or(true);
      c.line_angle = t.number("line_angle").value_or(c.line_angle);
      c.point_angle = t.number("point_angle").value_or(c.point_angle);
      c.line_penalty = t.number("line_penalty").value_or(0);
      c.gauss_points = static_cast<int>(t.integer("gauss_points").value_or(c.gauss_points));
      if (!(c.line_angle < c.point_angle))
        t.error(t.present("point_angle") ? "point_angle" : "line_angle",
                fmt::format("expected line_angle < point_angle (degrees), found {} and {}",
                            c.line_angle, c.point_angle));
      if (!c.line_contact)
        for (const char* key : {"line_angle", "point_angle", "line_penalty", "gauss_points"})
          if (t.present(key))
            t.error(key, fmt::format("'{}' applies only with line_contact = true", key));
      model_.spline_contacts.push_back(std::move(c));
    }
  }

  /// A node that no element uses has no stiffness and would make every solve singular.
  void check_free_nodes() {
    if (nodes_broken_ || elements_broken_ || model_.elements.empty())
      return;
    std::vector<bool> used(model_.nodes.size(), false);
    for (const BeamElement& e : model_.elements)
      for (int n : e.nodes)
        used[static_cast<std::size_t>(n)] = true;
    for (std::size_t i = 0; i < used.size(); ++i)
      if (!used[i])
        diagnostics_.error(node_origin_[i].where, node_origin_[i].path,
                           fmt::format("node {} belongs to no element (a free node has no "
                                       "stiffness)",
                                       model_.node_label(static_cast<int>(i))));
  }

  /// Dynamic steps need mass on every section in use; explicit ones rotary inertia as well.
  void check_mass() {
    if (dynamic_step_ == nullptr)
      return;
    std::vector<bool> checked(model_.sections.size(), false);
    for (int s : used_sections_) {
      if (s < 0 || checked[static_cast<std::size_t>(s)])
        continue;
      checked[static_cast<std::size_t>(s)] = true;
      const Section& sec = model_.sections[static_cast<std::size_t>(s)];
      const CheckedTable& t = *section_tables_[static_cast<std::size_t>(s)];
      if (sec.shape != SectionShape::General || !t.valid("EA"))
        continue; // shape sections get mass from the material; broken ones are reported
      if (sec.rhoA <= 0)
        t.error("rhoA", fmt::format("expected rhoA > 0 (mass per length, kg/m) because {} is "
                                    "dynamic, found {}",
                                    dynamic_step_->path(), sec.rhoA));
      if (explicit_step_ != nullptr && (sec.rhoJ.array() <= 0).any())
        t.error("rhoJ", fmt::format("expected every rhoJ component > 0 (rotary inertia, kg m) "
                                    "because {} is explicit, found {}",
                                    explicit_step_->path(), vector_text(sec.rhoJ)));
    }
  }

  struct NodeOrigin {
    toml::source_region where;
    std::string path;
  };

  CheckedTable root_;
  Diagnostics& diagnostics_;
  Model model_;
  std::vector<std::string> material_names_, section_names_, node_set_names_;
  std::vector<Origin> material_origins_, section_origins_, node_set_origins_;
  /// Per node set, its nodes in the order the deck gives them (generation order for [[lines]]).
  std::vector<std::vector<int>> node_set_order_;
  std::vector<std::string> spline_names_, surface_names_;
  std::vector<Origin> spline_origins_, surface_origins_;
  /// Per node, the (element, position 0..2) pairs that use it; built for the spline checks.
  std::vector<std::vector<std::pair<int, int>>> incident_;
  std::vector<const CheckedTable*> section_tables_;
  std::vector<int> used_sections_;
  std::unordered_map<long long, int> label_to_node_;
  std::vector<NodeOrigin> node_origin_;
  std::vector<Line> lines_;
  bool explicit_labels_ = false;
  bool nodes_broken_ = false;
  bool elements_broken_ = false;
  const CheckedTable* dynamic_step_ = nullptr;
  const CheckedTable* explicit_step_ = nullptr;
  const CheckedTable* newmark_step_ = nullptr; ///< the first implicit dynamic step
};

} // namespace

Model read_model_deck(const toml::table& table, deck::Diagnostics& diagnostics) {
  return DeckBuilder(table, diagnostics).build();
}

} // namespace yarnsim
