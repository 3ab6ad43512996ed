#include "engine/textile/fabric_deck.hpp"

#include "engine/model/contact_friction.hpp"
#include "engine/model/deck.hpp"
#include "engine/textile/biaxial.hpp"
#include "engine/textile/shear_kinematics.hpp"
#include "engine/textile/shear_tests.hpp"
#include "engine/textile/specimen.hpp"
#include "engine/textile/texgen.hpp"
#include "engine/textile/weave.hpp"

#include <algorithm>
#include <array>
#include <fmt/format.h>
#include <stdexcept>

namespace yarnsim::textile {

namespace {

using namespace deck;

// ---------------------------------------------------------------------------------------------
// Schema of the fabric deck (docs/input.md, "Fabric decks").

constexpr Range kUnitOpen{0, 1, true, true};
constexpr Range kUnitHalfOpen{0, 1, true, false};
constexpr Range kElements{1, 1000, false, false};
constexpr Range kYarnCount{1, 10000, false, false};

constexpr KeySpec kFabricKeys[] = {
    {"pattern", Type::Any},
    {"n_warp", Type::Integer, kOptional, kYarnCount},
    {"n_weft", Type::Integer, kOptional, kYarnCount},
    {"spacing_warp", Type::Number, kRequired, kPositive},
    {"spacing_weft", Type::Number, kRequired, kPositive},
    {"length_warp", Type::Number, kRequired, kPositive},
    {"length_weft", Type::Number, kRequired, kPositive},
    {"gap", Type::Number, kRequired, kNonNegative},
    {"a", Type::Number, kRequired, kPositive},
    {"b", Type::Number, kRequired, kPositive},
    {"contact_radius", Type::Number, kOptional, kPositive},
    {"E", Type::Number, kOptional, kPositive},
    {"EA", Type::Number, kOptional, kPositive},
    {"nu", Type::Number, kOptional, kPoisson},
    {"G", Type::Number, kOptional, kPositive},
    {"density", Type::Number, kRequired, kPositive},
    {"reduce_lower_inertia", Type::Number, kOptional, kUnitHalfOpen},
    {"reduce_upper_inertia", Type::Number, kOptional, kUnitHalfOpen},
    {"shear_factor", Type::Number, kOptional, kUnitHalfOpen},
    {"elements_per_spacing", Type::Integer, kOptional, kElements},
    // A TexGen file instead of the weave parameters (TexGenOptions, engine/textile/texgen.hpp).
    {"texgen", Type::String},
    {"textile", Type::String},
    {"repeats", Type::Any},
    {"elements_per_interval", Type::Integer, kOptional, kElements},
    {"length_scale", Type::Number, kOptional, kPositive},
    {"rebuild_weaves", Type::Boolean},
};
constexpr TableSpec kFabric{"[fabric]", kFabricKeys};

/// Keys that describe the weave: errors with `texgen`, whose file holds the geometry.
constexpr std::string_view kWeaveOnlyKeys[] = {"pattern",
                                               "n_warp",
                                               "n_weft",
                                               "spacing_warp",
                                               "spacing_weft",
                                               "length_warp",
                                               "length_weft",
                                               "gap",
                                               "a",
                                               "b",
                                               "elements_per_spacing"};
/// Keys that only a TexGen file gives a meaning to: errors without `texgen`.
constexpr std::string_view kTexGenOnlyKeys[] = {"textile", "repeats", "elements_per_interval",
                                                "length_scale", "rebuild_weaves"};

constexpr bool weave_only(std::string_view key) {
  return std::find(std::begin(kWeaveOnlyKeys), std::end(kWeaveOnlyKeys), key) !=
         std::end(kWeaveOnlyKeys);
}

/// [fabric] with `texgen`: the weave's required keys are not required (given, they are errors).
constexpr auto kTexGenFabricKeys = [] {
  std::array<KeySpec, std::size(kFabricKeys)> out{};
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i] = kFabricKeys[i];
    if (weave_only(out[i].name))
      out[i].need = kOptional;
  }
  return out;
}();
constexpr TableSpec kTexGenFabric{"[fabric]", kTexGenFabricKeys};

/// Keys of [fabric] that the bias extension's specimen decides ([bias_extension] height and
/// width): errors there.
constexpr std::string_view kSpecimenDecidedKeys[] = {"n_warp", "n_weft", "length_warp",
                                                     "length_weft"};
/// [fabric] with [bias_extension]: the yarn counts and lengths are not required (given, they are
/// errors).
constexpr auto kSpecimenFabricKeys = [] {
  std::array<KeySpec, std::size(kFabricKeys)> out{};
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i] = kFabricKeys[i];
    for (std::string_view k : kSpecimenDecidedKeys)
      if (out[i].name == k)
        out[i].need = kOptional;
  }
  return out;
}();
constexpr TableSpec kSpecimenFabric{"[fabric]", kSpecimenFabricKeys};

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
constexpr KeySpec kExplicitKeys[] = {
    {"dt", Type::Number, kOptional, kPositive},
    {"mass_scaling_dt", Type::Number, kOptional, kNonNegative},
    {"safety_factor", Type::Number, kOptional, kUnitHalfOpen},
    {"stable_dt_every", Type::Integer, kOptional, kAtLeastOne},
    {"output_every", Type::Integer, kOptional, kAtLeastOne},
    {"energy_monitor", Type::Boolean},
};
constexpr TableSpec kExplicit{"explicit", kExplicitKeys};
constexpr KeySpec kRayleighKeys[] = {
    {"mass", Type::Number, kOptional, kNonNegative},
    {"stiffness", Type::Number, kOptional, kNonNegative},
    {"out_of_plane", Type::Number, kOptional, kNonNegative},
};
constexpr TableSpec kRayleigh{"rayleigh", kRayleighKeys};
/// The keys of every test's loading step (LoadingParameters, engine/textile/loading.hpp).
constexpr KeySpec kLoadingKeys[] = {
    {"loading_time", Type::Number, kOptional, kPositive},
    {"type", Type::String},
    {"ramp", Type::String},
    {"dt", Type::Number, kOptional, kPositive},
    {"dt_min", Type::Number, kOptional, kPositive},
    {"dt_max", Type::Number, kOptional, kPositive},
    {"max_iterations", Type::Integer, kOptional, kIterations},
    {"tolerance", Type::Table, kOptional, kAnyValue, &kTolerance},
    {"newmark", Type::Table, kOptional, kAnyValue, &kNewmark},
    {"output_every", Type::Integer, kOptional, kAtLeastOne},
    {"explicit", Type::Table, kOptional, kAnyValue, &kExplicit},
    {"rayleigh", Type::Table, kOptional, kAnyValue, &kRayleigh},
};

/// A test's own keys followed by kLoadingKeys.
template <std::size_t N>
constexpr std::array<KeySpec, N + std::size(kLoadingKeys)> with_loading(const KeySpec (&own)[N]) {
  std::array<KeySpec, N + std::size(kLoadingKeys)> out{};
  for (std::size_t i = 0; i < N; ++i)
    out[i] = own[i];
  for (std::size_t i = 0; i < std::size(kLoadingKeys); ++i)
    out[N + i] = kLoadingKeys[i];
  return out;
}

constexpr KeySpec kBiaxialOwnKeys[] = {
    {"strain_ratio", Type::Number, kRequired, kPositive},
    {"max_strain", Type::Number, kOptional, kUnitOpen},
    {"monitors", Type::Boolean},
};
constexpr auto kBiaxialKeys = with_loading(kBiaxialOwnKeys);
constexpr TableSpec kBiaxial{"[biaxial]", kBiaxialKeys};

constexpr Range kShearAngle{0, 90, true, true};
constexpr Range kPretension{0, 0.1, false, true};
constexpr KeySpec kPictureFrameOwnKeys[] = {
    {"max_angle", Type::Number, kOptional, kShearAngle},
    {"ends", Type::String},
    {"central_region", Type::Number, kOptional, kUnitHalfOpen},
    {"pretension", Type::Number, kOptional, kPretension},
    {"pretension_time", Type::Number, kOptional, kPositive},
};
constexpr auto kPictureFrameKeys = with_loading(kPictureFrameOwnKeys);
constexpr TableSpec kPictureFrame{"[picture_frame]", kPictureFrameKeys};

constexpr KeySpec kUniaxialOwnKeys[] = {
    {"direction", Type::String},
    {"max_strain", Type::Number, kOptional, kUnitOpen},
    {"monitors", Type::Boolean},
};
constexpr auto kUniaxialKeys = with_loading(kUniaxialOwnKeys);
constexpr TableSpec kUniaxial{"[uniaxial]", kUniaxialKeys};

constexpr KeySpec kBiasExtensionOwnKeys[] = {
    {"height", Type::Number, kRequired, kPositive},
    {"width", Type::Number, kRequired, kPositive},
    {"clamp_length", Type::Number, kOptional, kNonNegative},
    {"max_angle", Type::Number, kOptional, kShearAngle},
    {"central_region", Type::Number, kOptional, kUnitHalfOpen},
    {"compaction", Type::Number, kOptional, kNonNegative},
    {"compaction_time", Type::Number, kOptional, kPositive},
};
constexpr auto kBiasExtensionKeys = with_loading(kBiasExtensionOwnKeys);
constexpr TableSpec kBiasExtension{"[bias_extension]", kBiasExtensionKeys};

/// The test blocks of a fabric deck: exactly one is given.
constexpr std::string_view kTests[] = {"biaxial", "uniaxial", "picture_frame", "bias_extension"};

constexpr KeySpec kContactKeys[] = {
    {"type", Type::String},
    {"law", Type::String},
    {"penalty", Type::Number, kOptional, kPositive},
    {"exponent", Type::Number, kOptional, kAtLeastOne},
    {"regularisation", Type::Number, kOptional, kPositive},
    {"damping", Type::Number, kOptional, kNonNegative},
    {"friction", Type::Number, kOptional, kNonNegative},
    {"static_friction", Type::Number, kOptional, kNonNegative},
    {"kinetic_friction", Type::Number, kOptional, kNonNegative},
    {"tangential_penalty", Type::Number, kOptional, kPositive},
    {"elastic_slip", Type::Number, kOptional, kPositive},
    {"tangential_damping", Type::Number, kOptional, kNonNegative},
    {"same_direction", Type::Boolean},
    {"torsional_friction", Type::Boolean},
    {"torsional_radius", Type::Number, kOptional, kPositive},
    {"torsional_penalty", Type::Number, kOptional, kPositive},
};
constexpr TableSpec kContact{"[contact]", kContactKeys};

/// The top level of a fabric deck whose [fabric] follows `fabric`.
constexpr std::array<KeySpec, 7> fabric_deck_keys(const TableSpec* fabric) {
  return {{
      {"title", Type::String},
      {"fabric", Type::Table, kRequired, kAnyValue, fabric},
      {"biaxial", Type::Table, kOptional, kAnyValue, &kBiaxial},
      {"uniaxial", Type::Table, kOptional, kAnyValue, &kUniaxial},
      {"picture_frame", Type::Table, kOptional, kAnyValue, &kPictureFrame},
      {"bias_extension", Type::Table, kOptional, kAnyValue, &kBiasExtension},
      {"contact", Type::Table, kOptional, kAnyValue, &kContact},
  }};
}
constexpr auto kFabricDeckKeys = fabric_deck_keys(&kFabric);
constexpr TableSpec kFabricDeck{"the top level of a fabric deck", kFabricDeckKeys};
constexpr auto kTexGenFabricDeckKeys = fabric_deck_keys(&kTexGenFabric);
constexpr TableSpec kTexGenFabricDeck{"the top level of a fabric deck", kTexGenFabricDeckKeys};
constexpr auto kSpecimenFabricDeckKeys = fabric_deck_keys(&kSpecimenFabric);
constexpr TableSpec kSpecimenFabricDeck{"the top level of a fabric deck", kSpecimenFabricDeckKeys};

/// Whether [fabric] takes its yarns from a TexGen file (has a `texgen` key, of whatever type).
bool uses_texgen(const toml::table& table) {
  const toml::table* fabric = table["fabric"].as_table();
  return fabric != nullptr && fabric->contains("texgen");
}

/// Whether the deck runs the bias extension, whose specimen is cut from the weave.
bool cuts_specimen(const toml::table& table) {
  return table.contains("bias_extension");
}

// ---------------------------------------------------------------------------------------------

std::string suggestion_text(std::string_view word, std::span<const std::string_view> choices) {
  const std::string_view s = closest(word, choices);
  return s.empty() ? std::string() : fmt::format("; did you mean \"{}\"?", s);
}

/// The pattern: "plain", "twill" (2/2), "basket" (2x2) or a matrix [[1, 0], [0, 1]] of 0 and 1.
std::optional<Eigen::MatrixXi> pattern(const CheckedTable& t) {
  const toml::node* n = t.node("pattern");
  if (n == nullptr)
    return plain_pattern();
  static constexpr std::string_view kNames[] = {"plain", "twill", "basket"};
  constexpr std::string_view kExpected =
      "expected \"plain\", \"twill\", \"basket\" or a matrix of 0 and 1 ([[1, 0], [0, 1]])";
  if (const auto* s = n->as_string()) {
    const std::string_view name = s->get();
    if (name == "plain")
      return plain_pattern();
    if (name == "twill")
      return twill_pattern(2, 2);
    if (name == "basket")
      return basket_pattern(2);
    t.error("pattern",
            fmt::format("{}, found \"{}\"{}", kExpected, name, suggestion_text(name, kNames)));
    return std::nullopt;
  }
  const toml::array* rows = n->as_array();
  if (rows == nullptr || rows->empty()) {
    t.error("pattern", fmt::format("{}, found {}", kExpected, describe_found(*n)));
    return std::nullopt;
  }
  Eigen::MatrixXi out;
  bool ok = true;
  for (std::size_t i = 0; i < rows->size(); ++i) {
    const toml::node& row = *rows->get(i);
    const toml::array* r = row.as_array();
    const std::size_t cols = out.cols() > 0 ? static_cast<std::size_t>(out.cols()) : 0;
    if (r == nullptr || r->empty() || (i > 0 && r->size() != cols)) {
      t.error("pattern", i,
              i > 0 && r != nullptr
                  ? fmt::format("expected a row of {} entries like the first, found {}", cols,
                                describe_found(row))
                  : fmt::format("expected a row of 0 and 1, found {}", describe_found(row)));
      ok = false;
      continue;
    }
    if (i == 0)
      out.resize(static_cast<Eigen::Index>(rows->size()), static_cast<Eigen::Index>(r->size()));
    for (std::size_t j = 0; j < r->size(); ++j) {
      const toml::node& v = *r->get(j);
      const auto* integer = v.as_integer();
      if (integer == nullptr || (integer->get() != 0 && integer->get() != 1)) {
        t.diagnostics().error(
            v.source().begin.line != 0 ? v.source() : t.source("pattern"),
            fmt::format("{}[{}][{}]", t.path("pattern"), i, j),
            fmt::format("expected 0 (warp under) or 1 (warp over), found {}", describe_found(v)));
        ok = false;
        continue;
      }
      out(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) =
          static_cast<int>(integer->get());
    }
  }
  if (!ok)
    return std::nullopt;
  return out;
}

/// Exactly one of two keys; reports both or neither. Returns the one given, or empty.
std::string_view one_of(const CheckedTable& t, std::string_view first, std::string_view second,
                        std::string_view what) {
  const bool a = t.present(first);
  const bool b = t.present(second);
  if (a && b) {
    t.error(second, fmt::format("give either {} or {}, not both", first, second));
    return {};
  }
  if (!a && !b) {
    if (!t.misspelt(first) && !t.misspelt(second))
      t.error(fmt::format("missing required key '{}' or '{}' ({})", first, second, what));
    return {};
  }
  return a ? first : second;
}

class FabricDeckBuilder {
public:
  FabricDeckBuilder(const toml::table& table, Diagnostics& diagnostics,
                    std::filesystem::path folder)
      : texgen_(uses_texgen(table)), specimen_(cuts_specimen(table)),
        root_(table,
              texgen_     ? kTexGenFabricDeck
              : specimen_ ? kSpecimenFabricDeck
                          : kFabricDeck,
              "", diagnostics),
        diagnostics_(diagnostics), folder_(std::move(folder)) {}

  Model build() {
    const CheckedTable* fabric = root_.table("fabric");
    const CheckedTable* biaxial = root_.table("biaxial");
    const CheckedTable* uniaxial = root_.table("uniaxial");
    const CheckedTable* frame = root_.table("picture_frame");
    const CheckedTable* bias = root_.table("bias_extension");
    const CheckedTable* contact = root_.table("contact");
    if (fabric)
      misplaced_keys(*fabric);
    // Exactly one test block.
    std::vector<std::string_view> tests;
    for (std::string_view t : kTests)
      if (root_.present(t))
        tests.push_back(t);
    if (tests.empty() && std::none_of(std::begin(kTests), std::end(kTests),
                                      [&](std::string_view t) { return root_.misspelt(t); }))
      root_.error("expected a test block: [biaxial], [uniaxial], [picture_frame] or "
                  "[bias_extension] (docs/input.md, \"Fabric decks\")");
    for (std::size_t k = 1; k < tests.size(); ++k)
      root_.error(tests[k], fmt::format("a fabric deck runs one test: found [{}] and [{}]",
                                        tests[0], tests[k]));
    if (bias && texgen_)
      fabric->error("texgen", "the bias extension's specimen is cut from a weave built from its "
                              "parameters; a TexGen file cannot give it in this version");
    const ContactFormulation formulation =
        contact ? contact_formulation(*contact) : ContactFormulation::Spline;
    const InterfaceLawParameters law =
        contact ? contact_law(*contact, formulation) : default_law(formulation);
    std::optional<BiaxialParameters> biaxial_test = biaxial    ? biaxial_parameters(*biaxial)
                                                    : uniaxial ? uniaxial_parameters(*uniaxial)
                                                               : std::nullopt;
    std::optional<PictureFrameParameters> frame_test =
        frame ? picture_frame_parameters(*frame) : std::nullopt;
    std::optional<BiasExtensionParameters> bias_test;
    std::optional<BiasSpecimenParameters> specimen;
    if (bias)
      bias_extension_parameters(*bias, bias_test, specimen);
    const LoadingParameters* loading = nullptr;
    if (biaxial_test)
      loading = &*biaxial_test;
    else if (frame_test)
      loading = &*frame_test;
    else if (bias_test)
      loading = &*bias_test;
    const CheckedTable* test_table = biaxial ? biaxial : uniaxial ? uniaxial : frame ? frame : bias;
    const std::string block =
        test_table ? fmt::format("[{}]", tests.empty() ? "test" : tests.front()) : "the test";
    // The test in words ("picture frame"), for messages about the yarns a file gives.
    std::string test_words(tests.empty() ? "fabric" : tests.front());
    std::replace(test_words.begin(), test_words.end(), '_', ' ');
    FrictionParameters friction;
    // Contact between neighbouring yarns of one direction (warp-warp, weft-weft): spline
    // contact only.
    // On by default in the shear tests, where sheared yarns come to lie side by side.
    const bool same_direction =
        contact && contact->present("same_direction")
            ? contact->boolean("same_direction").value_or(false)
            : (frame != nullptr || bias != nullptr) && formulation == ContactFormulation::Spline;
    if (same_direction && formulation == ContactFormulation::Surface)
      contact->error("same_direction", "'same_direction' applies only to type = \"spline\" "
                                       "(the surface contact has no contact within a group in "
                                       "this version)");
    if (contact) {
      read_contact_friction(*contact, law, friction,
                            loading && loading->type == StepType::Explicit ? block : std::string());
      // Contact damping acts through the velocities of implicit dynamic steps.
      for (const auto& [damping, value] : {std::pair<const char*, double>{"damping", law.damping},
                                           {"tangential_damping", friction.tangential_damping}}) {
        if (!(value > 0))
          continue;
        if (formulation == ContactFormulation::Surface && std::string_view(damping) == "damping")
          contact->error(damping, "surface contact damping is not available in this version; "
                                  "remove the key or set it to 0");
        else if (loading && loading->type == StepType::Explicit)
          contact->error(damping, fmt::format("contact damping is not available on the explicit "
                                              "path in this version ({} type = \"explicit\")",
                                              block));
        else if (loading && loading->type == StepType::Static)
          contact->error(damping, fmt::format("contact damping acts on the velocities of dynamic "
                                              "steps ({} type = \"dynamic\"); a static test has "
                                              "none",
                                              block));
      }
    }
    // A TexGen file is read, and its own problems reported, whatever the rest of the deck holds.
    std::optional<Fabric> built;
    if (texgen_)
      built = fabric ? texgen_fabric(*fabric, law, formulation) : std::nullopt;
    std::optional<WeaveParameters> weave =
        fabric && !texgen_ ? weave_parameters(*fabric) : std::nullopt;
    if (weave) {
      weave->contact_law = law;
      weave->contact = formulation;
    }
    if ((!weave && !built) || !loading || !diagnostics_.empty())
      return {};
    try {
      if (weave && specimen) {
        specimen->weave = *weave;
        built = build_bias_specimen(*specimen);
      } else if (weave) {
        built = build_weave(*weave);
      }
    } catch (const std::invalid_argument& e) {
      (specimen ? *test_table : *fabric).error(e.what());
      return {};
    }
    try {
      if (biaxial_test)
        add_biaxial_test(*built, *biaxial_test);
      else if (frame_test)
        add_picture_frame_test(*built, *frame_test);
      else
        add_bias_extension_test(*built, *specimen, *bias_test);
    } catch (const std::invalid_argument& e) {
      // With a TexGen file what the test cannot find (a direction without yarns, ends off the
      // frame) is the file's.
      if (texgen_)
        fabric->error("texgen", fmt::format("the yarns of {} cannot take the {} test: {}",
                                            texgen_path(*fabric).string(), test_words, e.what()));
      else
        test_table->error(e.what());
      return {};
    }
    if (auto title = root_.string("title"))
      built->model.title = *title;
    if (same_direction)
      add_same_direction_contacts(built->model);
    for (SplineContactDefinition& c : built->model.spline_contacts)
      c.friction = friction;
    for (SurfaceContactDefinition& c : built->model.surface_contacts)
      c.friction = friction;
    return std::move(built->model);
  }

private:
  /// Contacts "warp-warp" and "weft-weft" beside "warp-weft": each direction's splines as one
  /// group in contact within itself (self_contact, between different yarns only), with the
  /// warp-weft contact's law and broad-phase margin, where the direction has two yarns or more.
  /// Yarns of one direction touch side by side, across their width: the contact radius is the
  /// sections' in-plane semi-axis a (Spline::width / 2), not the spline's own (b), so they lock
  /// where the geometry says (acos(w / p), docs/shear-tests.md). The splines are named warp<i> and
  /// weft<j>.
  static void add_same_direction_contacts(Model& model) {
    if (model.spline_contacts.empty())
      return;
    const SplineContactDefinition base = model.spline_contacts.front();
    // The largest in-plane semi-axis of the yarns' sections (axis 1 lies in the fabric plane).
    double side_radius = 0;
    for (const Spline& s : model.splines)
      side_radius = std::max(side_radius, s.width / 2);
    for (const char* direction : {"warp", "weft"}) {
      SplineContactDefinition c = base;
      c.name = fmt::format("{}-{}", direction, direction);
      c.group_a.clear();
      c.group_b.clear();
      c.self_contact = true;
      c.within_spline = false;                 // a yarn does not touch itself in a fabric
      c.radius = side_radius;                  // side by side: across the width
      c.compaction = TimeTable::constant(0.0); // the crossings' alone
      for (std::size_t s = 0; s < model.splines.size(); ++s)
        if (model.splines[s].name.rfind(direction, 0) == 0)
          c.group_a.push_back(static_cast<int>(s));
      if (c.group_a.size() >= 2)
        model.spline_contacts.push_back(std::move(c));
    }
  }

  /// Weave keys with a TexGen file, TexGen keys without one.
  void misplaced_keys(const CheckedTable& t) const {
    if (specimen_ && !texgen_)
      for (std::string_view k : kSpecimenDecidedKeys)
        if (t.present(k))
          t.error(k, fmt::format("'{}' does not apply to the bias extension: the specimen's "
                                 "height and width ([bias_extension]) decide which yarns there "
                                 "are and how long they are",
                                 k));
    if (texgen_) {
      for (std::string_view k : kWeaveOnlyKeys)
        if (t.present(k))
          t.error(k, fmt::format("'{}' applies only without texgen (a woven fabric built from "
                                 "its parameters); with texgen the yarns come from the file",
                                 k));
    } else {
      for (std::string_view k : kTexGenOnlyKeys)
        if (t.present(k))
          t.error(k, fmt::format("'{}' applies only with texgen = \"file.tg3\"", k));
    }
  }

  /// The TexGen file as the reader opens it: relative to the deck's folder.
  std::filesystem::path texgen_path(const CheckedTable& t) const {
    const std::filesystem::path p(t.string("texgen").value_or(""));
    return p.is_absolute() ? p : folder_ / p;
  }

  /// E or EA, nu or G, density; false when one is missing or bad (reported).
  static bool material(const CheckedTable& t, YarnMaterial& m) {
    bool ok = true;
    if (auto v = t.number("density"))
      m.density = *v;
    else
      ok = false;
    const std::string_view stiffness = one_of(t, "E", "EA", "a number > 0, Pa or N");
    if (stiffness.empty())
      ok = false;
    else if (auto v = t.number(stiffness))
      (stiffness == "E" ? m.young : m.EA) = *v;
    else
      ok = false;
    const std::string_view shear = one_of(t, "nu", "G", "Poisson ratio or shear modulus");
    if (shear.empty())
      ok = false;
    else if (auto v = t.number(shear))
      (shear == "nu" ? m.poisson : m.shear) = *v;
    else
      ok = false;
    return ok;
  }

  /// repeats = [n1, n2, n3]: 1 to 3 integers >= 1, one per <Repeat> of each yarn.
  static std::optional<std::array<int, 3>> repeats(const CheckedTable& t) {
    std::array<int, 3> out{1, 1, 1};
    const toml::node* n = t.node("repeats");
    if (n == nullptr)
      return out;
    constexpr std::string_view kExpected = "expected an array of 1 to 3 integers >= 1 ([n1, n2, "
                                           "n3], one per <Repeat> of each yarn, in file order)";
    const toml::array* a = n->as_array();
    if (a == nullptr || a->empty() || a->size() > 3) {
      t.error("repeats", fmt::format("{}, found {}", kExpected, describe_found(*n)));
      return std::nullopt;
    }
    bool ok = true;
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::node& v = *a->get(i);
      const auto* integer = v.as_integer();
      if (integer == nullptr || integer->get() < 1 || integer->get() > 10000) {
        t.error("repeats", i,
                fmt::format("expected an integer in [1, 10000], found {}", describe_found(v)));
        ok = false;
        continue;
      }
      out[i] = static_cast<int>(integer->get());
    }
    if (!ok)
      return std::nullopt;
    return out;
  }

  /// The fabric of [fabric] texgen; its problems, and the file's, are reported.
  std::optional<Fabric> texgen_fabric(const CheckedTable& t, const InterfaceLawParameters& law,
                                      ContactFormulation formulation) {
    TexGenOptions o;
    bool ok = material(t, o.material);
    auto number = [&](std::string_view key, double& out) {
      if (auto v = t.number(key))
        out = *v;
      else if (t.present(key))
        ok = false;
    };
    number("reduce_lower_inertia", o.reduce_lower_inertia);
    number("reduce_upper_inertia", o.reduce_upper_inertia);
    number("shear_factor", o.shear_factor);
    number("contact_radius", o.contact_radius);
    number("length_scale", o.length_scale);
    o.elements_per_interval = static_cast<int>(t.integer("elements_per_interval").value_or(4));
    o.textile = t.string("textile").value_or("");
    o.rebuild_weaves = t.boolean("rebuild_weaves").value_or(false);
    for (std::string_view k : {"elements_per_interval", "textile", "rebuild_weaves"})
      ok = ok && (!t.present(k) || t.valid(k));
    if (auto r = repeats(t))
      o.repeats = *r;
    else
      ok = false;
    o.contact_law = law;
    o.contact = formulation;
    if (!t.valid("texgen"))
      return std::nullopt;
    const std::filesystem::path file = texgen_path(t);
    std::error_code ec;
    if (!std::filesystem::is_regular_file(file, ec)) {
      t.error("texgen",
              fmt::format("expected a TexGen file (.tg3, relative to the deck's folder "
                          "or absolute), found {} at {}",
                          std::filesystem::exists(file, ec) ? "no regular file" : "no file",
                          file.string()));
      return std::nullopt;
    }
    // Bad deck values are reported above; the file is still read, with stand-ins, for its own.
    if (!ok) {
      o.material = {1.0, 0.0, 0.2, 0.0, 1.0};
      o.reduce_lower_inertia = 0.1;
      o.reduce_upper_inertia = 1.0;
      o.shear_factor = 5.0 / 6.0;
      o.contact_radius = 0;
      o.length_scale = 0;
    }
    try {
      Fabric f = read_texgen(file, o);
      if (!ok)
        return std::nullopt;
      return f;
    } catch (const InputError& e) {
      t.error("texgen", fmt::format("expected a TexGen file that reads cleanly, found {} "
                                    "problem(s) in {} (listed next, at their place in it)",
                                    e.messages().size(), file.string()));
      for (const std::string& m : e.messages())
        diagnostics_.attach(t.source("texgen"), m);
    } catch (const std::invalid_argument& e) {
      t.error("texgen", fmt::format("cannot build the fabric of {}: {}", file.string(), e.what()));
    }
    return std::nullopt;
  }

  std::optional<WeaveParameters> weave_parameters(const CheckedTable& t) {
    WeaveParameters p;
    bool ok = true;
    if (auto m = pattern(t))
      p.pattern = *m;
    else
      ok = false;
    p.n_warp = static_cast<int>(t.integer("n_warp").value_or(6));
    p.n_weft = static_cast<int>(t.integer("n_weft").value_or(6));
    auto number = [&](std::string_view key, double& out) {
      // Absent optional keys keep their default; a bad or missing required value is reported.
      if (auto v = t.number(key))
        out = *v;
      else if (t.present(key) || t.spec().find(key)->need == kRequired)
        ok = false;
    };
    number("spacing_warp", p.spacing_warp);
    number("spacing_weft", p.spacing_weft);
    number("length_warp", p.length_warp);
    number("length_weft", p.length_weft);
    number("gap", p.gap);
    number("a", p.a);
    number("b", p.b);
    number("contact_radius", p.contact_radius);
    number("reduce_lower_inertia", p.reduce_lower_inertia);
    number("reduce_upper_inertia", p.reduce_upper_inertia);
    number("shear_factor", p.shear_factor);
    p.elements_per_spacing = static_cast<int>(t.integer("elements_per_spacing").value_or(4));
    for (std::string_view k : {"n_warp", "n_weft", "elements_per_spacing"})
      ok = ok && (!t.present(k) || t.valid(k));

    ok = material(t, p.material) && ok;

    // Cross-field rules, checked when their values are good.
    if (t.valid("length_warp") && t.valid("spacing_weft") &&
        (!t.present("n_weft") || t.valid("n_weft")) &&
        p.length_warp < (p.n_weft - 1) * p.spacing_weft * (1 - 1e-9)) {
      t.error("length_warp",
              fmt::format("expected length_warp >= (n_weft - 1) spacing_weft = {} (a warp yarn "
                          "must reach its outer crossings), found {}",
                          (p.n_weft - 1) * p.spacing_weft, p.length_warp));
      ok = false;
    }
    if (t.valid("length_weft") && t.valid("spacing_warp") &&
        (!t.present("n_warp") || t.valid("n_warp")) &&
        p.length_weft < (p.n_warp - 1) * p.spacing_warp * (1 - 1e-9)) {
      t.error("length_weft",
              fmt::format("expected length_weft >= (n_warp - 1) spacing_warp = {} (a weft yarn "
                          "must reach its outer crossings), found {}",
                          (p.n_warp - 1) * p.spacing_warp, p.length_weft));
      ok = false;
    }
    if (t.valid("contact_radius") && t.valid("b") && t.valid("gap") &&
        p.contact_radius > p.b + p.gap / 2) {
      t.error("contact_radius",
              fmt::format("expected contact_radius <= b + gap / 2 = {} (the centre lines are "
                          "2 b + gap apart at a crossing; a larger radius starts in contact), "
                          "found {}",
                          p.b + p.gap / 2, p.contact_radius));
      ok = false;
    }
    if (!ok)
      return std::nullopt;
    return p;
  }

  /// The paper's law of each formulation: linear, 1.5e6 N/m (spline), 3.5e5 N/m (surface).
  static InterfaceLawParameters default_law(ContactFormulation formulation) {
    return {formulation == ContactFormulation::Spline ? 1.5e6 : 3.5e5, 1.0, 0.0};
  }

  /// The [contact] type: "spline" (default) or "surface".
  ContactFormulation contact_formulation(const CheckedTable& t) {
    static constexpr std::string_view kTypes[] = {"spline", "surface"};
    const std::string type = t.string("type").value_or("spline");
    if (type == "surface")
      return ContactFormulation::Surface;
    if (type != "spline" && t.valid("type"))
      t.error("type", fmt::format("expected \"spline\" (beam-to-beam contact of C1 splines) or "
                                  "\"surface\" (surface-to-surface contact of elliptical "
                                  "cylinders), found \"{}\"{}",
                                  type, suggestion_text(type, kTypes)));
    return ContactFormulation::Spline;
  }

  /// The [contact] law; its problems are reported (the returned law is then a placeholder).
  InterfaceLawParameters contact_law(const CheckedTable& t, ContactFormulation formulation) {
    InterfaceLawParameters out = default_law(formulation);
    static constexpr std::string_view kLaws[] = {"linear", "power"};
    const std::string law = t.string("law").value_or("linear");
    if (t.present("law") && !t.valid("law"))
      return out;
    if (law != "linear" && law != "power") {
      t.error("law", fmt::format("expected \"linear\" or \"power\", found \"{}\"{}", law,
                                 suggestion_text(law, kLaws)));
      return out;
    }
    if (law == "linear" && t.present("exponent"))
      t.error("exponent", "'exponent' applies only to law = \"power\"");
    if (law == "power" && !t.present("exponent"))
      t.missing("exponent", "a number >= 1, for law = \"power\"");
    if (law == "power" && t.present("regularisation"))
      t.error("regularisation", "'regularisation' applies only to law = \"linear\"");
    out.regularisation = law == "linear" ? t.number("regularisation").value_or(0) : 0.0;
    out.penalty = t.number("penalty").value_or(out.penalty);
    out.exponent = law == "power" ? t.number("exponent").value_or(1) : 1.0;
    out.damping = t.number("damping").value_or(0);
    return out;
  }

  std::optional<BiaxialParameters> biaxial_parameters(const CheckedTable& t) {
    BiaxialParameters p;
    bool ok = loading_parameters(t, kBiaxialKeys, "[biaxial]", p);
    if (auto k = t.number("strain_ratio"))
      p.strain_ratio = *k;
    else
      ok = false;
    p.max_strain = t.number("max_strain").value_or(p.max_strain);
    p.monitors = t.boolean("monitors").value_or(true);
    if (!ok)
      return std::nullopt;
    return p;
  }

  std::optional<BiaxialParameters> uniaxial_parameters(const CheckedTable& t) {
    BiaxialParameters p;
    bool ok = loading_parameters(t, kUniaxialKeys, "[uniaxial]", p);
    p.uniaxial = FabricDirection::Warp;
    if (auto d = t.string("direction")) {
      static constexpr std::string_view kDirections[] = {"warp", "weft"};
      if (*d == "warp" || *d == "weft") {
        p.uniaxial = *d == "warp" ? FabricDirection::Warp : FabricDirection::Weft;
      } else {
        t.error("direction", fmt::format("expected \"warp\" or \"weft\" (the direction pulled), "
                                         "found \"{}\"{}",
                                         *d, suggestion_text(*d, kDirections)));
        ok = false;
      }
    }
    p.max_strain = t.number("max_strain").value_or(p.max_strain);
    p.monitors = t.boolean("monitors").value_or(true);
    if (!ok)
      return std::nullopt;
    return p;
  }

  /// [bias_extension]: the test and the specimen's size (the weave is [fabric]'s, set later).
  void bias_extension_parameters(const CheckedTable& t,
                                 std::optional<BiasExtensionParameters>& test,
                                 std::optional<BiasSpecimenParameters>& specimen) {
    BiasExtensionParameters p;
    bool ok = loading_parameters(t, kBiasExtensionKeys, "[bias_extension]", p);
    p.max_angle = t.number("max_angle").value_or(p.max_angle);
    p.central_region = t.number("central_region").value_or(p.central_region);
    p.compaction = t.number("compaction").value_or(p.compaction);
    p.compaction_time = t.number("compaction_time").value_or(p.compaction_time);
    BiasSpecimenParameters s;
    if (auto h = t.number("height"))
      s.height = *h;
    else
      ok = false;
    if (auto w = t.number("width"))
      s.width = *w;
    else
      ok = false;
    s.clamp_length = t.number("clamp_length").value_or(0.0);
    if (t.valid("height") && t.valid("width") &&
        (!t.present("clamp_length") || t.valid("clamp_length")) &&
        !textile::bias_extension_zones_fit(s.height - 2 * s.clamp_length, s.width)) {
      t.error(t.present("clamp_length") ? "clamp_length" : "height",
              fmt::format("expected a free length height - 2 clamp_length >= 2 width = {} m (the "
                          "three zones of the test and the benchmark's energy method need it), "
                          "found {} m",
                          2 * s.width, s.height - 2 * s.clamp_length));
      ok = false;
    }
    if (!ok)
      return;
    test = p;
    specimen = s;
  }

  std::optional<PictureFrameParameters> picture_frame_parameters(const CheckedTable& t) {
    PictureFrameParameters p;
    bool ok = loading_parameters(t, kPictureFrameKeys, "[picture_frame]", p);
    p.max_angle = t.number("max_angle").value_or(p.max_angle);
    p.central_region = t.number("central_region").value_or(p.central_region);
    p.pretension = t.number("pretension").value_or(p.pretension);
    p.pretension_time = t.number("pretension_time").value_or(p.pretension_time);
    if (auto ends = t.string("ends")) {
      static constexpr std::string_view kEnds[] = {"pinned", "clamped"};
      if (*ends == "pinned" || *ends == "clamped") {
        p.clamped = *ends == "clamped";
      } else {
        t.error("ends", fmt::format("expected \"pinned\" or \"clamped\", found \"{}\"{}", *ends,
                                    suggestion_text(*ends, kEnds)));
        ok = false;
      }
    }
    if (!ok)
      return std::nullopt;
    return p;
  }

  /// The loading step of a test block (kLoadingKeys); `block` names it in messages
  /// ("[biaxial]"). Every key of `keys` that is present must be valid. False when something
  /// was wrong (reported).
  bool loading_parameters(const CheckedTable& t, std::span<const KeySpec> keys,
                          std::string_view block, LoadingParameters& p) {
    bool ok = true;
    for (const KeySpec& k : keys)
      ok = ok && (!t.present(k.name) || t.valid(k.name));
    p.loading_time = t.number("loading_time").value_or(p.loading_time);
    if (auto type = t.string("type")) {
      static constexpr std::string_view kTypes[] = {"dynamic", "static", "explicit"};
      if (*type == "dynamic") {
        p.type = StepType::Dynamic;
      } else if (*type == "static") {
        p.type = StepType::Static;
      } else if (*type == "explicit") {
        p.type = StepType::Explicit;
      } else {
        t.error("type", fmt::format("expected \"dynamic\", \"static\" or \"explicit\", found "
                                    "\"{}\"{}",
                                    *type, suggestion_text(*type, kTypes)));
        ok = false;
      }
    }
    if (auto ramp = t.string("ramp")) {
      static constexpr std::string_view kRamps[] = {"linear", "smooth"};
      if (*ramp == "linear") {
        p.ramp = LoadingRamp::Linear;
      } else if (*ramp == "smooth") {
        p.ramp = LoadingRamp::Smooth;
      } else {
        t.error("ramp", fmt::format("expected \"linear\" or \"smooth\", found \"{}\"{}", *ramp,
                                    suggestion_text(*ramp, kRamps)));
        ok = false;
      }
    }
    if (p.type == StepType::Static && t.present("newmark")) {
      t.error("newmark", "'newmark' applies only to type = \"dynamic\"; this test is \"static\"");
      ok = false;
    }
    // The implicit keys have no meaning on an explicit test: its step is [<test>.explicit]'s.
    // (The explicit table may come with an implicit test: a study then runs it on both paths.)
    if (p.type == StepType::Explicit)
      for (std::string_view k :
           {"dt", "dt_min", "dt_max", "max_iterations", "tolerance", "newmark", "output_every"})
        if (t.present(k)) {
          t.error(k, fmt::format("'{}' applies only to implicit (static, dynamic) tests; this test "
                                 "is \"explicit\": its step is set in [{}.explicit]",
                                 k, block.substr(1, block.size() - 2)));
          ok = false;
        }
    if (const CheckedTable* x = t.table("explicit")) {
      for (const KeySpec& k : kExplicitKeys)
        ok = ok && (!x->present(k.name) || x->valid(k.name));
      ExplicitLoading& e = p.explicit_;
      e.mass_scaling_dt = x->number("mass_scaling_dt").value_or(e.mass_scaling_dt);
      e.dt = x->number("dt").value_or(e.dt);
      e.safety_factor = x->number("safety_factor").value_or(e.safety_factor);
      e.stable_dt_every = static_cast<int>(std::min<long long>(
          x->integer("stable_dt_every").value_or(e.stable_dt_every), 1'000'000'000));
      e.output_every = static_cast<int>(
          std::min<long long>(x->integer("output_every").value_or(e.output_every), 1'000'000'000));
      e.energy_monitor = x->boolean("energy_monitor").value_or(e.energy_monitor);
      const double T = p.loading_time;
      if (x->valid("mass_scaling_dt") && e.mass_scaling_dt == 0 && !x->present("dt")) {
        x->error("mass_scaling_dt", "without mass scaling (mass_scaling_dt = 0) give the time "
                                    "step 'dt', below the stable limit");
        ok = false;
      }
      for (std::string_view k : {"dt", "mass_scaling_dt"})
        if (x->valid(k) && *x->number(k) > T * (1 + 1e-12)) {
          x->error(k, fmt::format("expected a time step <= loading_time ({}), found {}", T,
                                  *x->number(k)));
          ok = false;
        }
    }
    const double T = p.loading_time;
    p.dt = t.number("dt").value_or(0);
    p.dt_min = t.number("dt_min").value_or(0);
    p.dt_max = t.number("dt_max").value_or(0);
    const double dt = p.dt > 0 ? p.dt : T / 100;
    const double dt_max = p.dt_max > 0 ? p.dt_max : std::max(T / 50, dt);
    const double dt_min = p.dt_min > 0 ? p.dt_min : std::min(T * 1e-6, dt);
    if (t.valid("dt") && dt > T * (1 + 1e-12)) {
      t.error("dt", fmt::format("expected a time step <= loading_time ({}), found {}", T, dt));
      ok = false;
    } else if (t.valid("dt_min") && t.valid("dt_max") && dt_min > dt_max) {
      t.error("dt_min", fmt::format("expected dt_min <= dt_max ({}), found {}", dt_max, dt_min));
      ok = false;
    } else if (dt > dt_max) {
      t.error(t.present("dt") ? "dt" : "dt_max",
              fmt::format("expected dt ({}) <= dt_max ({})", dt, dt_max));
      ok = false;
    } else if (dt < dt_min) {
      t.error(t.present("dt") ? "dt" : "dt_min",
              fmt::format("expected dt ({}) >= dt_min ({})", dt, dt_min));
      ok = false;
    }
    p.max_iterations = static_cast<int>(t.integer("max_iterations").value_or(p.max_iterations));
    if (const CheckedTable* tol = t.table("tolerance")) {
      p.tol_force = tol->number("force").value_or(p.tol_force);
      p.tol_increment = tol->number("increment").value_or(p.tol_increment);
      ok = ok && (!tol->present("force") || tol->valid("force")) &&
           (!tol->present("increment") || tol->valid("increment"));
    }
    if (const CheckedTable* nm = t.table("newmark")) {
      p.newmark_beta = nm->number("beta").value_or(p.newmark_beta);
      p.newmark_gamma = nm->number("gamma").value_or(p.newmark_gamma);
      ok = ok && (!nm->present("beta") || nm->valid("beta")) &&
           (!nm->present("gamma") || nm->valid("gamma"));
    }
    p.output_every =
        static_cast<int>(std::min<long long>(t.integer("output_every").value_or(1), 1'000'000'000));
    if (const CheckedTable* ray = t.table("rayleigh")) {
      ok = ok && (!ray->present("mass") || ray->valid("mass")) &&
           (!ray->present("stiffness") || ray->valid("stiffness")) &&
           (!ray->present("out_of_plane") || ray->valid("out_of_plane"));
      if (p.type == StepType::Explicit && ray->present("out_of_plane")) {
        ray->error("out_of_plane", "'out_of_plane' damping applies only to dynamic (Newmark) "
                                   "tests; this test is \"explicit\"");
        ok = false;
      }
      if (p.type == StepType::Static) {
        t.error("rayleigh", "'rayleigh' damping applies only to dynamic and explicit tests; this "
                            "test is \"static\"");
        ok = false;
      }
      // Absent mass: the stabilising default of dynamic steps (loading.hpp).
      p.rayleigh_mass = ray->number("mass").value_or(p.rayleigh_mass);
      p.rayleigh_stiffness = ray->number("stiffness").value_or(p.rayleigh_stiffness);
      p.rayleigh_out_of_plane = ray->number("out_of_plane").value_or(p.rayleigh_out_of_plane);
    }
    return ok;
  }

  bool texgen_;   ///< [fabric] names a TexGen file
  bool specimen_; ///< [bias_extension]: the yarns are cut from the weave to its specimen
  CheckedTable root_;
  Diagnostics& diagnostics_;
  std::filesystem::path folder_; ///< the deck's folder: relative TexGen paths start there
};

} // namespace

std::optional<Model> read_fabric_deck(const toml::table& table, Diagnostics& diagnostics,
                                      const std::filesystem::path& folder) {
  if (!table.contains("fabric"))
    return std::nullopt;
  return FabricDeckBuilder(table, diagnostics, folder).build();
}

} // namespace yarnsim::textile
