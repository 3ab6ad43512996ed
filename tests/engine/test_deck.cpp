#include "deck_errors.hpp"
#include "engine/input/read_deck.hpp"
#include "engine/model/model.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <numbers>
#include <string>
#include <vector>

namespace yarnsim {
namespace {

const std::filesystem::path kExamples = std::filesystem::path(YARNSIM_SOURCE_DIR) / "examples";

/// "deck.toml:line:col: " of the first occurrence of `needle` in `deck` (1-based, as toml++).
std::string where(std::string_view deck, std::string_view needle, std::size_t occurrence = 0) {
  std::size_t at = deck.find(needle);
  for (std::size_t k = 0; k < occurrence; ++k)
    at = deck.find(needle, at + 1);
  EXPECT_NE(at, std::string_view::npos) << needle;
  const std::size_t line_start =
      deck.rfind('\n', at) == std::string_view::npos ? 0 : deck.rfind('\n', at) + 1;
  const auto line = 1 + std::count(deck.begin(), deck.begin() + static_cast<long>(at), '\n');
  return "deck.toml:" + std::to_string(line) + ":" + std::to_string(at - line_start + 1) + ": ";
}

std::vector<std::string> errors_of(std::string_view deck) {
  return test::errors_of(deck, "deck.toml");
}
using test::has;
using test::joined;

// A small valid deck; tests break one thing at a time.
constexpr std::string_view kValid = R"(title = "two elements"
[[materials]]
name = "steel"
E = 2.1e11
nu = 0.3
density = 7850.0

[[sections]]
name = "rod"
shape = "circle"
radius = 0.01
material = "steel"

[[sections]]
name = "beam"
EA = 1e4
GA = 1e4
EI = 1.0
GJ = 1.0

[nodes]
coordinates = [[0, 0, 0], [0.5, 0, 0], [1, 0, 0], [1.5, 0, 0], [2, 0, 0]]

[[elements]]
connectivity = [[1, 2, 3], [3, 4, 5]]
section = "beam"

[[node_sets]]
name = "clamp"
nodes = [1]

[[node_sets]]
name = "tip"
nodes = [5]

[[constraints]]
node_set = "clamp"
dofs = "all"

[[loads]]
node_set = "tip"
force = [0, -1, 0]

[[steps]]
type = "static"
end_time = 1.0
dt = 0.1
dt_max = 0.2

[[monitors]]
name = "tip"
node = 5
)";

std::string replace(std::string_view deck, std::string_view from, std::string_view to) {
  std::string out(deck);
  const auto at = out.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return out.replace(at, from.size(), to);
}

TEST(Deck, ValidDeckResolvesNamesAndLabelsToIndices) {
  const Model m = read_deck_string(kValid, "deck.toml");
  EXPECT_EQ(m.title, "two elements");
  ASSERT_EQ(m.nodes.size(), 5u);
  ASSERT_EQ(m.elements.size(), 2u);
  EXPECT_EQ(m.elements[1].nodes, (std::array<int, 3>{2, 3, 4}));
  EXPECT_EQ(m.elements[0].section, 1);
  EXPECT_TRUE(m.node_labels.empty());
  ASSERT_EQ(m.materials.size(), 1u);
  EXPECT_NEAR(m.materials[0].shear, 2.1e11 / 2.6, 1e-3);
  EXPECT_EQ(m.sections[0].shape, SectionShape::Circle);
  EXPECT_NEAR(m.sections[0].EA, 2.1e11 * std::numbers::pi * 1e-4, 1e-3);
  ASSERT_EQ(m.constraints.size(), 1u);
  EXPECT_EQ(m.constraints[0].node_set, m.find_node_set("clamp"));
  EXPECT_EQ(m.constraints[0].fixed, (std::array<bool, 6>{true, true, true, true, true, true}));
  ASSERT_EQ(m.loads.size(), 1u);
  EXPECT_EQ(m.loads[0].force, Eigen::Vector3d(0, -1, 0));
  EXPECT_DOUBLE_EQ(m.loads[0].factor.at(0.7), 1.0);
  ASSERT_EQ(m.steps.size(), 1u);
  EXPECT_EQ(m.steps[0].type, StepType::Static);
  EXPECT_DOUBLE_EQ(m.steps[0].dt_initial, 0.1);
  EXPECT_DOUBLE_EQ(m.steps[0].dt_max, 0.2);
  EXPECT_EQ(m.steps[0].max_iterations, 20);
  ASSERT_EQ(m.monitors.size(), 1u);
  EXPECT_EQ(m.monitors[0].type, MonitorType::Node);
  EXPECT_EQ(m.monitors[0].target, 4);
}

class ExampleDeck : public testing::TestWithParam<const char*> {};

TEST_P(ExampleDeck, Parses) {
  const std::filesystem::path file = kExamples / GetParam();
  try {
    const Model m = read_deck(file);
    EXPECT_FALSE(m.title.empty());
    EXPECT_FALSE(m.elements.empty());
    EXPECT_FALSE(m.steps.empty());
    EXPECT_FALSE(m.monitors.empty());
  } catch (const InputError& e) {
    FAIL() << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(Examples, ExampleDeck,
                         testing::Values("rollup.toml", "rollup-ten-turns.toml", "elastica.toml",
                                         "cantilever-vibration.toml", "flying-beam.toml",
                                         "crossing-beams.toml"));

TEST(Deck, RollupExampleHasTheVerificationCase) {
  const Model m = read_deck(kExamples / "rollup.toml");
  ASSERT_EQ(m.elements.size(), 16u);
  ASSERT_EQ(m.nodes.size(), 33u);
  EXPECT_NEAR((m.nodes.back() - Eigen::Vector3d(1, 0, 0)).norm(), 0, 1e-15);
  const int tip = m.find_node_set("beam.end");
  ASSERT_GE(tip, 0);
  EXPECT_EQ(m.node_sets[static_cast<std::size_t>(tip)].nodes, std::vector<int>{32});
  EXPECT_EQ(m.node_sets[static_cast<std::size_t>(m.find_node_set("beam"))].nodes.size(), 33u);
  const Section& s = m.sections[static_cast<std::size_t>(m.elements[0].section)];
  ASSERT_EQ(m.loads.size(), 1u);
  EXPECT_NEAR(m.loads[0].moment.z(), 2 * std::numbers::pi * s.EI2 / 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(m.loads[0].factor.at(0.5), 0.5);
  EXPECT_NEAR(m.steps[0].end_time / m.steps[0].dt_initial, 20, 1e-9);
  EXPECT_EQ(m.monitors[0].target, 32);
}

TEST(Deck, FlyingBeamExampleHasTheVerificationCase) {
  const Model m = read_deck(kExamples / "flying-beam.toml");
  EXPECT_NEAR((m.nodes.back() - m.nodes.front()).norm(), 10, 1e-12);
  const Section& s = m.sections[0];
  EXPECT_EQ(s.rhoJ, Eigen::Vector3d(10, 10, 20));
  EXPECT_TRUE(m.constraints.empty());
  EXPECT_DOUBLE_EQ(m.loads[0].factor.at(2.5), 1.0);
  EXPECT_DOUBLE_EQ(m.loads[0].factor.at(3.75), 0.5);
  EXPECT_DOUBLE_EQ(m.loads[0].factor.at(20), 0.0);
  EXPECT_EQ(m.steps[0].type, StepType::Dynamic);
  EXPECT_DOUBLE_EQ(m.steps[0].newmark_beta, 0.25);
  EXPECT_DOUBLE_EQ(m.steps[0].newmark_gamma, 0.5);
}

TEST(Deck, OutOfPlaneDampingBelongsToDynamicSteps) {
  const std::string massive =
      replace(kValid, "GJ = 1.0\n", "GJ = 1.0\nrhoA = 1.0\nrhoJ = [1e-6, 1e-6, 2e-6]\n");
  const Model m = read_deck_string(replace(massive, "type = \"static\"",
                                           "type = \"dynamic\"\nrayleigh = { out_of_plane = 2e3 }"),
                                   "deck.toml");
  EXPECT_EQ(m.steps[0].rayleigh_out_of_plane, 2e3);
  EXPECT_EQ(m.steps[0].rayleigh_mass, 0.0);
  const auto e =
      errors_of(replace(massive, "type = \"static\"\nend_time = 1.0\ndt = 0.1\ndt_max = 0.2",
                        "type = \"explicit\"\nend_time = 1.0\ndt = 0.1\n"
                        "rayleigh = { out_of_plane = -2e3 }"));
  ASSERT_EQ(e.size(), 2u) << e.front();
  EXPECT_NE(e[1].find("rayleigh.out_of_plane: 'out_of_plane' damping applies only to dynamic "
                      "(Newmark) steps; this step is \"explicit\""),
            std::string::npos)
      << e[1];
  EXPECT_NE(e[0].find("rayleigh.out_of_plane: expected a number >= 0, found -2000.0"),
            std::string::npos)
      << e[0];
}

TEST(Deck, UnknownKeyIsReportedWithItsPositionAndASuggestion) {
  const std::string deck = replace(kValid, "EA = 1e4", "EAA = 1e4");
  const auto errors = errors_of(deck);
  ASSERT_FALSE(errors.empty()) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "EAA") +
                           "sections[1].EAA: unknown key 'EAA' in [[sections]]; did you mean "
                           "'EA'?");
}

TEST(Deck, UnknownTopLevelTableIsReportedWithASuggestion) {
  const std::string deck = replace(kValid, "[[monitors]]", "[[monitor]]");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0].rfind(where(deck, "monitor]]") + "monitor: unknown key 'monitor'", 0), 0u)
      << errors[0];
  EXPECT_NE(errors[0].find("did you mean 'monitors'?"), std::string::npos) << errors[0];
}

TEST(Deck, UnknownKeyWithoutACloseMatchListsTheKnownKeys) {
  const std::string deck = replace(kValid, "nu = 0.3", "nu = 0.3\ncolour = \"grey\"");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_NE(errors[0].find("known keys: name, E, nu, G, density"), std::string::npos) << errors[0];
}

TEST(Deck, WrongTypeNamesExpectedAndFound) {
  const std::string deck = replace(kValid, "EA = 1e4", "EA = \"1e4\"");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "\"1e4\"") +
                           "sections[1].EA: expected a number > 0, found a string \"1e4\"");
}

TEST(Deck, LoadAxesAreGlobalUnlessSectionIsAsked) {
  EXPECT_EQ(read_deck_string(kValid, "deck.toml").loads[0].axes, LoadAxes::Global);
  const std::string global =
      replace(kValid, "force = [0, -1, 0]", "axes = \"global\"\nforce = [0, -1, 0]");
  EXPECT_EQ(read_deck_string(global, "deck.toml").loads[0].axes, LoadAxes::Global);
  const std::string section = replace(kValid, "force = [0, -1, 0]",
                                      "moment = [0, 0, 1]\nfollower = true\naxes = \"section\"");
  const Model m = read_deck_string(section, "deck.toml");
  EXPECT_EQ(m.loads[0].axes, LoadAxes::Section);
  EXPECT_TRUE(m.loads[0].follower_moment);
}

TEST(Deck, UnknownLoadAxesAreReportedWithPositionExpectedAndFound) {
  const std::string deck =
      replace(kValid, "force = [0, -1, 0]", "force = [0, -1, 0]\naxes = \"sectoin\"");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0],
            where(deck, "\"sectoin\"") +
                "loads[0].axes: expected \"global\" or \"section\", found \"sectoin\"; did "
                "you mean \"section\"?");
  const std::string number = replace(kValid, "force = [0, -1, 0]", "force = [0, -1, 0]\naxes = 1");
  const auto wrong_type = errors_of(number);
  ASSERT_EQ(wrong_type.size(), 1u) << joined(wrong_type);
  EXPECT_NE(wrong_type[0].find("loads[0].axes: expected a string"), std::string::npos)
      << wrong_type[0];
}

TEST(Deck, NegativeStiffnessIsOutOfRange) {
  const std::string deck = replace(kValid, "EI = 1.0", "EI = -1.0");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "-1.0") + "sections[1].EI: expected a number > 0, found -1.0");
}

TEST(Deck, ReferenceToAMissingNodeNamesTheLabel) {
  const std::string deck = replace(kValid, "[3, 4, 5]]", "[3, 4, 9]]");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "9]]") +
                           "elements[0].connectivity[1][2]: no node labelled 9 (nodes are "
                           "labelled 1 to 5)");
}

TEST(Deck, ReferenceToAMissingNodeSetNamesTheSetAndSuggests) {
  const std::string deck = replace(kValid, "node_set = \"tip\"", "node_set = \"tipp\"");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "\"tipp\"") +
                           "loads[0].node_set: no node set named 'tipp'; did you mean 'tip'?");
}

TEST(Deck, ReferencesToMissingSectionsAndMaterialsAreNamed) {
  std::string deck = replace(kValid, "section = \"beam\"", "section = \"girder\"");
  deck = replace(deck, "material = \"steel\"", "material = \"wood\"");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 2u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "\"wood\"") +
                           "sections[0].material: no material named 'wood' (defined: steel)");
  EXPECT_EQ(errors[1], where(deck, "\"girder\"") +
                           "elements[0].section: no section named 'girder' (defined: rod, beam)");
}

TEST(Deck, AllErrorsAreReportedAtOnceInFileOrder) {
  std::string deck = replace(kValid, "density = 7850.0", "density = 0.0");
  deck = replace(deck, "GJ = 1.0", "GJJ = 1.0");
  deck = replace(deck, "node = 5", "node = 6");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 3u) << joined(errors);
  EXPECT_EQ(errors[0],
            where(deck, "0.0\n") + "materials[0].density: expected a number > 0, found 0.0");
  EXPECT_EQ(errors[1], where(deck, "GJJ") +
                           "sections[1].GJJ: unknown key 'GJJ' in [[sections]]; did you mean "
                           "'GJ'?");
  // The misspelt key is not reported a second time as a missing 'GJ'.
  EXPECT_EQ(errors[2], where(deck, "6\n") +
                           "monitors[0].node: no node labelled 6 (nodes are labelled 1 to 5)");
}

TEST(Deck, ThreeIndependentErrorsGiveThreeMessages) {
  std::string deck = replace(kValid, "nu = 0.3", "nu = 0.7");
  deck = replace(deck, "dofs = \"all\"", "dofs = [\"ux\", \"uyy\"]");
  deck = replace(deck, "type = \"static\"", "type = 1");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 3u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "0.7") + "materials[0].nu: expected a number in (-1, 0.5], "
                                            "found 0.7");
  EXPECT_EQ(errors[1], where(deck, "\"uyy\"") +
                           "constraints[0].dofs[1]: expected \"all\", \"translations\", "
                           "\"rotations\" or DOF names \"ux\", \"uy\", \"uz\", \"rx\", \"ry\", "
                           "\"rz\", found \"uyy\"; did you mean \"uy\"?");
  EXPECT_EQ(errors[2], where(deck, "1\nend_time") + "steps[0].type: expected a string, found an "
                                                    "integer (1)");
}

TEST(Deck, SyntaxErrorHasAPosition) {
  const std::string deck = replace(kValid, "E = 2.1e11", "E = = 2.1e11");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0].rfind("deck.toml:4:5: syntax error", 0), 0u) << errors[0];
}

TEST(Deck, StepLimitsAndNewmarkAreChecked) {
  std::string deck = replace(kValid, "dt_max = 0.2", "dt_max = 0.2\ndt_min = 0.5");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0],
            where(deck, "0.5\n") + "steps[0].dt_min: expected dt_min <= dt_max (0.2), found 0.5");

  deck = replace(kValid, "type = \"static\"",
                 "type = \"dynamic\"\nnewmark = { beta = 0.6, gamma = 0.5 }");
  deck = replace(deck, "GJ = 1.0", "GJ = 1.0\nrhoA = 1.0");
  const auto beta = errors_of(deck);
  ASSERT_EQ(beta.size(), 1u) << joined(beta);
  EXPECT_EQ(beta[0],
            where(deck, "0.6") + "steps[0].newmark.beta: expected a number in (0, 0.5], found 0.6");

  deck = replace(kValid, "dt_max = 0.2", "dt_max = 0.2\nnewmark = { beta = 0.25 }");
  const auto static_newmark = errors_of(deck);
  ASSERT_EQ(static_newmark.size(), 1u) << joined(static_newmark);
  EXPECT_NE(static_newmark[0].find("'newmark' applies only to type = \"dynamic\""),
            std::string::npos);
}

TEST(Deck, StepsMustFollowEachOtherInTime) {
  const std::string deck = std::string(kValid) + R"(
[[steps]]
type = "static"
end_time = 0.5
dt = 0.1
)";
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "0.5\n") +
                           "steps[1].end_time: expected an end time > 1 (the end of steps[0]; "
                           "times are absolute), found 0.5");
}

TEST(Deck, TimeTableMustIncrease) {
  const std::string deck =
      replace(kValid, "force = [0, -1, 0]", "force = [0, -1, 0]\ntable = [[0, 0], [1, 1], [1, 2]]");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "1, 2]") +
                           "loads[0].table[2][0]: expected a time > 1.0 (times must increase), "
                           "found 1.0");
}

TEST(Deck, DynamicStepNeedsMass) {
  const std::string deck = replace(kValid, "type = \"static\"", "type = \"dynamic\"");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "[[sections]]", 1) +
                           "sections[1].rhoA: expected rhoA > 0 (mass per length, kg/m) because "
                           "steps[0] is dynamic, found 0");
}

TEST(Deck, SectionFormsCannotBeMixed) {
  const std::string deck = replace(kValid, "radius = 0.01", "radius = 0.01\nEA = 5.0");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_NE(errors[0].find("sections[0]: give either stiffnesses"), std::string::npos) << errors[0];
}

TEST(Deck, MonitorNeedsExactlyOneTarget) {
  const std::string deck = replace(kValid, "node = 5", "node = 5\nelement = 1");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_NE(errors[0].find("monitors[0]: expected exactly one of 'node', 'node_set', 'element', "
                           "found node, element"),
            std::string::npos)
      << errors[0];
}

TEST(Deck, ExplicitNodeIdsFillNodeLabels) {
  std::string deck = replace(kValid, R"([nodes]
coordinates = [[0, 0, 0], [0.5, 0, 0], [1, 0, 0], [1.5, 0, 0], [2, 0, 0]])",
                             R"([[nodes]]
id = 10
position = [0, 0, 0]
[[nodes]]
id = 20
position = [0.5, 0, 0]
[[nodes]]
id = 30
position = [1, 0, 0]
[[nodes]]
id = 40
position = [1.5, 0, 0]
[[nodes]]
id = 50
position = [2, 0, 0])");
  deck = replace(deck, "[[1, 2, 3], [3, 4, 5]]", "[[10, 20, 30], [30, 40, 50]]");
  deck = replace(deck, "nodes = [1]", "nodes = [10]");
  deck = replace(deck, "nodes = [5]", "nodes = [50]");
  deck = replace(deck, "node = 5", "node = 50");
  deck += R"(
[[lines]]
name = "extra"
from = [0, 1, 0]
to = [1, 1, 0]
elements = 1
section = "rod"
)";
  const Model m = read_deck_string(deck, "deck.toml");
  ASSERT_EQ(m.node_labels.size(), 8u);
  EXPECT_EQ(m.node_labels[1], 20);
  EXPECT_EQ(m.node_labels[5], 51); // generated nodes continue after the largest id
  EXPECT_EQ(m.monitors[0].target, 4);
  EXPECT_EQ(m.elements.size(), 3u);
  EXPECT_EQ(m.elements[2].section, 0);
}

TEST(Deck, LinesMakeNodesElementsAndNodeSets) {
  const Model m = read_deck_string(R"(
title = "line"
[[sections]]
name = "s"
EA = 1.0
GA1 = 1.0
GA2 = 2.0
EI1 = 1.0
EI2 = 3.0
GJ = 1.0
[[lines]]
name = "yarn"
from = [0, 0, 0]
to = [0, 0, 2]
elements = 2
section = "s"
reference_vector = [2, 0, 0]
[[steps]]
type = "static"
end_time = 1
dt = 1
[[monitors]]
name = "mid"
element = 2
)",
                                   "deck.toml");
  ASSERT_EQ(m.nodes.size(), 5u);
  EXPECT_EQ(m.nodes[3], Eigen::Vector3d(0, 0, 1.5));
  ASSERT_EQ(m.elements.size(), 2u);
  EXPECT_EQ(m.elements[1].nodes, (std::array<int, 3>{2, 3, 4}));
  EXPECT_EQ(m.elements[1].reference_vector, Eigen::Vector3d(1, 0, 0));
  EXPECT_EQ(m.node_sets[static_cast<std::size_t>(m.find_node_set("yarn.end"))].nodes,
            std::vector<int>{4});
  EXPECT_DOUBLE_EQ(m.sections[0].GA2, 2.0);
  EXPECT_DOUBLE_EQ(m.sections[0].EI2, 3.0);
  EXPECT_EQ(m.monitors[0].type, MonitorType::Element);
  EXPECT_EQ(m.monitors[0].target, 1);
}

TEST(Deck, DefaultReferenceVectorParallelToTheLineIsReported) {
  const std::string deck = R"(title = "t"
[[sections]]
name = "s"
EA = 1.0
GA = 1.0
EI = 1.0
GJ = 1.0
[[lines]]
name = "yarn"
from = [0, 0, 0]
to = [0, 3, 0]
elements = 2
section = "s"
[[steps]]
type = "static"
end_time = 1
dt = 1
)";
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_NE(errors[0].find("lines[0].reference_vector: expected a vector not parallel to the axis "
                           "of the line [0, 1, 0], found [0, 1, 0] (the default)"),
            std::string::npos)
      << errors[0];
}

TEST(Deck, ReadDeckReportsTheFileName) {
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / "yarnsim_test_deck_bad.toml";
  {
    std::ofstream out(file);
    out << replace(kValid, "EA = 1e4", "EA = -1e4");
  }
  try {
    read_deck(file);
    FAIL() << "no error";
  } catch (const InputError& e) {
    ASSERT_EQ(e.messages().size(), 1u) << e.what();
    EXPECT_EQ(e.messages()[0].rfind(file.string() + ":16:6: sections[1].EA:", 0), 0u) << e.what();
  }
  std::filesystem::remove(file);
  EXPECT_THROW(read_deck(file), InputError);
}

// kValid with a second beam crossing the first, three splines and two contacts.
const std::string kSplines = std::string(kValid) + R"(
[[lines]]
name = "cross"
from = [1, -1, 0.02]
to = [1, 1, 0.02]
elements = 2
section = "rod"
reference_vector = [1, 0, 0]

[[node_sets]]
name = "backwards"
nodes = [5, 4, 3, 2, 1]

[[splines]]
name = "rod"
node_set = "backwards"
radius = 0.01

[[splines]]
name = "cross"
node_set = "cross"
radius = 0.01

[[splines]]
name = "listed"
nodes = [10, 9, 8]
radius = 0.02

[[contacts]]
name = "rod-cross"
type = "spline"
between = [["rod"], ["cross", "listed"]]
law = "power"
penalty = 2e6
exponent = 1.5
damping = 0.0
margin = 0.001

[[contacts]]
name = "cross-self"
type = "spline"
group_a = "cross"
penalty = 1e5
self_contact = true
)";

TEST(DeckSplines, SplinesAndContactsResolveToIndices) {
  const Model m = read_deck_string(kSplines, "deck.toml");
  ASSERT_EQ(m.splines.size(), 3u);
  // A node set's direction comes from the order the deck writes it: node 5 first.
  EXPECT_EQ(m.splines[0].name, "rod");
  EXPECT_EQ(m.splines[0].nodes, (std::vector<int>{4, 3, 2, 1, 0}));
  EXPECT_DOUBLE_EQ(m.splines[0].radius, 0.01);
  // A [[lines]] set runs from 'from' to 'to' (labels 6 to 10).
  EXPECT_EQ(m.splines[1].nodes, (std::vector<int>{5, 6, 7, 8, 9}));
  // An explicit list keeps its order.
  EXPECT_EQ(m.splines[2].nodes, (std::vector<int>{9, 8, 7}));
  EXPECT_DOUBLE_EQ(m.splines[2].radius, 0.02);

  ASSERT_EQ(m.spline_contacts.size(), 2u);
  const SplineContactDefinition& c = m.spline_contacts[0];
  EXPECT_EQ(c.name, "rod-cross");
  EXPECT_EQ(c.group_a, std::vector<int>{0});
  EXPECT_EQ(c.group_b, (std::vector<int>{1, 2}));
  EXPECT_DOUBLE_EQ(c.law.penalty, 2e6);
  EXPECT_DOUBLE_EQ(c.law.exponent, 1.5);
  EXPECT_DOUBLE_EQ(c.law.damping, 0.0);
  EXPECT_DOUBLE_EQ(c.margin, 0.001);
  EXPECT_FALSE(c.self_contact);

  // One group, with self-contact: contact within it; the law defaults to the linear penalty.
  const SplineContactDefinition& self = m.spline_contacts[1];
  EXPECT_EQ(self.group_a, std::vector<int>{1});
  EXPECT_TRUE(self.group_b.empty());
  EXPECT_TRUE(self.self_contact);
  EXPECT_DOUBLE_EQ(self.law.penalty, 1e5);
  EXPECT_DOUBLE_EQ(self.law.exponent, 1.0);
  EXPECT_DOUBLE_EQ(self.law.damping, 0.0);
  EXPECT_DOUBLE_EQ(self.margin, 0.0);
}

TEST(DeckSplines, NodeSetIsOrderedAlongTheElementsNotByLabel) {
  // The chain runs 5 - 3 - 1 - 4 - 2; the set is written sorted, so its first end is node 2.
  std::string deck = replace(kValid, "[[1, 2, 3], [3, 4, 5]]", "[[5, 3, 1], [1, 4, 2]]");
  deck = replace(deck, "[[0, 0, 0], [0.5, 0, 0], [1, 0, 0], [1.5, 0, 0], [2, 0, 0]]",
                 "[[1, 0, 0], [2, 0, 0], [0.5, 0, 0], [1.5, 0, 0], [0, 0, 0]]");
  deck += R"(
[[node_sets]]
name = "yarn"
nodes = [1, 2, 3, 4, 5]

[[splines]]
name = "yarn"
node_set = "yarn"
radius = 0.01
)";
  const Model m = read_deck_string(deck, "deck.toml");
  ASSERT_EQ(m.splines.size(), 1u);
  EXPECT_EQ(m.splines[0].nodes, (std::vector<int>{1, 3, 0, 2, 4}));
}

TEST(DeckSplines, UnknownSplineNameIsReportedWithASuggestion) {
  const std::string deck = replace(kSplines, "[\"cross\", \"listed\"]", "[\"cross\", \"lsited\"]");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "\"lsited\"") +
                           "contacts[0].between[1][1]: no spline named 'lsited'; did you mean "
                           "'listed'?");

  const std::string group = replace(kSplines, "group_a = \"cross\"", "group_a = \"crosss\"");
  const auto group_errors = errors_of(group);
  ASSERT_EQ(group_errors.size(), 1u) << joined(group_errors);
  EXPECT_EQ(group_errors[0], where(group, "\"crosss\"") +
                                 "contacts[1].group_a: no spline named 'crosss'; did you mean "
                                 "'cross'?");
}

TEST(DeckSplines, RadiusMustBePositive) {
  const std::string deck = replace(kSplines, "radius = 0.02", "radius = 0.0");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "0.0\n\n[[contacts]]") +
                           "splines[2].radius: expected a number > 0, found 0.0");
}

TEST(DeckSplines, ListedNodesMustFollowTheElements) {
  // 8 and 10 are the ends of element 4 (the cross line's second): its middle node 9 is skipped.
  const std::string deck = replace(kSplines, "nodes = [10, 9, 8]", "nodes = [6, 7, 8, 10]");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "10]") +
                           "splines[2].nodes[3]: expected a node next to node 8 along an element, "
                           "found node 10: nodes 8 and 10 are the end nodes of element 4, so its "
                           "middle node 9 must come between them (every node is a control point)");

  const std::string apart = replace(kSplines, "nodes = [10, 9, 8]", "nodes = [1, 2, 3, 8]");
  const auto apart_errors = errors_of(apart);
  ASSERT_EQ(apart_errors.size(), 1u) << joined(apart_errors);
  EXPECT_EQ(apart_errors[0], where(apart, "8]") +
                                 "splines[2].nodes[3]: expected a node next to node 3 along an "
                                 "element, found node 8: node 8 shares no element with node 3 (the "
                                 "nodes next to node 3 are 2, 4)");
}

TEST(DeckSplines, NodeSetMustBeOneChain) {
  // Nodes 1, 3 are the ends of element 1 without its middle node 2.
  std::string deck = replace(kSplines, "nodes = [5, 4, 3, 2, 1]", "nodes = [1, 3, 4, 5]");
  auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "\"backwards\"", 1) +
                           "splines[0].node_set: expected the nodes of one chain of elements, "
                           "found that node set 'backwards' holds nodes 1 and 3, the end nodes of "
                           "element 1, without its middle node 2 (every node is a control point)");

  // Two pieces: 1 - 2 - 3 and 7 - 8 (the cross line).
  deck = replace(kSplines, "nodes = [5, 4, 3, 2, 1]", "nodes = [1, 2, 3, 7, 8]");
  errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "\"backwards\"", 1) +
                           "splines[0].node_set: expected the nodes of one chain of elements, "
                           "found that node set 'backwards' falls into separate pieces: the chain "
                           "from node 1 to node 3 leaves out node 7");
}

TEST(DeckSplines, NodeSetMustBeAnOpenChainWithoutBranches) {
  // A third element from node 3 makes a T.
  std::string deck =
      replace(kSplines, "[[1, 2, 3], [3, 4, 5]]", "[[1, 2, 3], [3, 4, 5], [3, 6, 7]]");
  deck = replace(deck, "[2, 0, 0]]", "[2, 0, 0], [1, 0, 0.5], [1, 0, 1]]");
  deck = replace(deck, "from = [1, -1, 0.02]", "from = [3, -1, 0.02]");
  deck = replace(deck, "to = [1, 1, 0.02]", "to = [3, 1, 0.02]");
  deck = replace(deck, "nodes = [5, 4, 3, 2, 1]", "nodes = [5, 4, 3, 2, 1, 6, 7]");
  deck = replace(deck, "nodes = [10, 9, 8]", "nodes = [12, 11, 10]");
  auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "\"backwards\"", 1) +
                           "splines[0].node_set: expected the nodes of one chain of elements, "
                           "found that node set 'backwards' branches at node 3, which is next to "
                           "nodes 2, 4, 6 of the set");

  // A third element from node 5 back to node 1 closes a ring.
  deck = replace(kSplines, "[[1, 2, 3], [3, 4, 5]]", "[[1, 2, 3], [3, 4, 5], [5, 6, 1]]");
  deck = replace(deck, "[2, 0, 0]]", "[2, 0, 0], [1, 0, 0.5]]");
  deck = replace(deck, "nodes = [5, 4, 3, 2, 1]", "nodes = [1, 2, 3, 4, 5, 6]");
  deck = replace(deck, "nodes = [10, 9, 8]", "nodes = [11, 10, 9]");
  errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "\"backwards\"", 1) +
                           "splines[0].node_set: expected the nodes of one chain of elements, "
                           "found that node set 'backwards' forms a closed loop (a spline needs an "
                           "open chain with two ends)");
}

TEST(DeckSplines, FewerThanThreeNodesAreReported) {
  std::string deck = replace(kSplines, "nodes = [10, 9, 8]", "nodes = [10, 9]");
  auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "[10, 9]") +
                           "splines[2].nodes: expected at least 3 nodes (the control points of a "
                           "quadratic B-spline), found 2");

  deck = replace(kSplines, "node_set = \"backwards\"", "node_set = \"tip\"");
  errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "\"tip\"\nradius") +
                           "splines[0].node_set: expected a node set of at least 3 nodes (the "
                           "control points of a quadratic B-spline), found 'tip' with 1");
}

TEST(DeckSplines, SplineNeedsItsNodesOnce) {
  std::string deck = replace(kSplines, "nodes = [10, 9, 8]", "");
  auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_NE(errors[0].find("splines[2]: missing required key 'node_set' or 'nodes'"),
            std::string::npos)
      << errors[0];

  deck = replace(kSplines, "nodes = [10, 9, 8]", "nodes = [10, 9, 8]\nnode_set = \"cross\"");
  errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "[10, 9, 8]") +
                           "splines[2].nodes: give either 'node_set' or 'nodes', not both");
}

TEST(DeckSplines, UnknownLawIsReportedWithASuggestion) {
  const std::string deck = replace(kSplines, "law = \"power\"", "law = \"powr\"");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "\"powr\"") +
                           "contacts[0].law: expected \"linear\" or \"power\", found \"powr\"; did "
                           "you mean \"power\"?");
}

TEST(DeckSplines, ExponentBelongsToThePowerLawOnly) {
  std::string deck = replace(kSplines, "law = \"power\"", "law = \"linear\"");
  auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "1.5\ndamping") +
                           "contacts[0].exponent: 'exponent' applies only to law = \"power\"; "
                           "this contact's law is \"linear\"");

  deck = replace(kSplines, "exponent = 1.5\n", "");
  errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "[[contacts]]") +
                           "contacts[0]: missing required key 'exponent' (a number >= 1, for law "
                           "= \"power\")");

  deck = replace(kSplines, "exponent = 1.5", "exponent = 0.5");
  errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0],
            where(deck, "0.5\n") + "contacts[0].exponent: expected a number >= 1, found 0.5");
}

TEST(DeckSplines, RegularisationBelongsToTheLinearLawOnly) {
  std::string deck = replace(replace(kSplines, "law = \"power\"", "law = \"linear\""),
                             "exponent = 1.5", "regularisation = 2e-6");
  const Model m = read_deck_string(deck, "deck.toml");
  EXPECT_EQ(m.spline_contacts[0].law.regularisation, 2e-6);
  EXPECT_EQ(m.spline_contacts[0].law.exponent, 1.0);

  deck = replace(kSplines, "exponent = 1.5", "exponent = 1.5\nregularisation = 2e-6");
  auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "2e-6") +
                           "contacts[0].regularisation: 'regularisation' applies only to law = "
                           "\"linear\"; this contact's law is \"power\"");

  deck = replace(replace(kSplines, "law = \"power\"", "law = \"linear\""), "exponent = 1.5",
                 "regularisation = 0");
  errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "0\ndamping") +
                           "contacts[0].regularisation: expected a number > 0, found 0");
}

TEST(DeckSplines, SplineInBothGroupsIsReported) {
  const std::string deck = replace(kSplines, "[[\"rod\"], [\"cross\", \"listed\"]]",
                                   "[[\"rod\"], [\"cross\", \"rod\"]]");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "\"rod\"]]") +
                           "contacts[0].between[1][1]: expected each spline in one group only, "
                           "found 'rod' in both groups (also at contacts[0].between[0][0])");
}

TEST(DeckSplines, GroupsAreGivenOneWay) {
  std::string deck =
      replace(kSplines, "group_a = \"cross\"", "group_a = \"cross\"\nbetween = [\"cross\"]");
  auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "\"cross\"\nbetween") +
                           "contacts[1].group_a: give either 'between' or 'group_a' and "
                           "'group_b', not both");

  deck = replace(kSplines, "between = [[\"rod\"], [\"cross\", \"listed\"]]",
                 "between = [[\"rod\"], [\"cross\"], [\"listed\"]]");
  errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "[[\"rod\"]") +
                           "contacts[0].between: expected one or two groups of spline names, "
                           "[[\"a\", ...], [\"b\", ...]], found an array of 3 elements");

  // A single group touches only itself: self-contact must be asked for.
  deck = replace(kSplines, "self_contact = true\n", "");
  errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "\"cross\"\npenalty") +
                           "contacts[1].group_a: expected two groups of splines, found one (a "
                           "single group is for contact within it: give self_contact = true)");

  deck = replace(kSplines, "self_contact = true", "self_contact = false");
  deck = replace(deck, "group_a = \"cross\"", "group_a = [\"cross\", \"rod\"]");
  errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "false") +
                           "contacts[1].self_contact: expected true with a single group of "
                           "splines (contact within it), found false");
}

TEST(DeckSplines, ContactDampingActsOnDynamicStepsOnly) {
  // A static deck: the damping would act on nothing (no velocities).
  std::string deck = replace(kSplines, "damping = 0.0", "damping = 0.1");
  auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "0.1\nmargin") +
                           "contacts[0].damping: contact damping acts on the velocities of "
                           "dynamic steps, and this deck has none (static steps have no "
                           "velocities); remove the key or set it to 0");
  // A dynamic step: read, normal and tangential.
  const std::string dynamic =
      replace(replace(deck, "type = \"static\"", "type = \"dynamic\""), "GJ = 1.0\n",
              "GJ = 1.0\nrhoA = 0.1\nrhoJ = [1e-3, 1e-3, 1e-3]\n");
  const Model m =
      read_deck_string(replace(dynamic, "margin = 0.001\n",
                               "margin = 0.001\nfriction = 0.2\ntangential_penalty = 1e5\n"
                               "tangential_damping = 3.0\n"),
                       "deck.toml");
  EXPECT_DOUBLE_EQ(m.spline_contacts[0].law.damping, 0.1);
  EXPECT_DOUBLE_EQ(m.spline_contacts[0].friction.tangential_damping, 3.0);
  // Not on the explicit path.
  errors = errors_of(replace(deck, "type = \"static\"", "type = \"explicit\""));
  EXPECT_TRUE(has(errors, "contacts[0].damping: contact damping is not available on the explicit "
                          "path in this version (steps[0] is explicit)"))
      << joined(errors);
  // Tangential damping needs friction.
  errors = errors_of(replace(dynamic, "damping = 0.1", "damping = 0.0\ntangential_damping = 1.0"));
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_TRUE(has(errors, "contacts[0].tangential_damping: 'tangential_damping' applies only with "
                          "friction"))
      << joined(errors);
}

TEST(DeckSplines, FrictionKeysAreReadAndChecked) {
  EXPECT_FALSE(read_deck_string(kSplines, "deck.toml").spline_contacts[0].friction.active());
  const auto friction_of = [](const std::string& deck) {
    return read_deck_string(deck, "deck.toml").spline_contacts[0].friction;
  };
  // One coefficient for both; the power law needs its tangential penalty in N/m.
  FrictionParameters f = friction_of(replace(
      kSplines, "margin = 0.001\n", "margin = 0.001\nfriction = 0.2\ntangential_penalty = 1e5\n"));
  EXPECT_DOUBLE_EQ(f.mu_static, 0.2);
  EXPECT_DOUBLE_EQ(f.mu_kinetic, 0.2);
  EXPECT_DOUBLE_EQ(f.tangential_penalty, 1e5);
  f = friction_of(replace(kSplines, "margin = 0.001\n",
                          "margin = 0.001\nstatic_friction = 0.3\nkinetic_friction = 0.2\n"
                          "tangential_penalty = 1e5\n"));
  EXPECT_DOUBLE_EQ(f.mu_static, 0.3);
  EXPECT_DOUBLE_EQ(f.mu_kinetic, 0.2);
  // A linear law lends its penalty to the tangential one.
  std::string linear = replace(kSplines, "law = \"power\"", "law = \"linear\"");
  linear = replace(linear, "exponent = 1.5\n", "");
  f = friction_of(replace(linear, "margin = 0.001\n", "margin = 0.001\nfriction = 0.2\n"));
  EXPECT_DOUBLE_EQ(f.tangential_penalty,
                   read_deck_string(linear, "deck.toml").spline_contacts[0].law.penalty);

  // The contact with `keys` added reports one problem, holding `text`.
  const auto expect_one_error = [](const std::string& keys, std::string_view text) {
    const auto errors = errors_of(replace(kSplines, "margin = 0.001\n", "margin = 0.001\n" + keys));
    EXPECT_EQ(errors.size(), 1u) << joined(errors);
    EXPECT_TRUE(has(errors, text)) << keys << joined(errors);
  };
  expect_one_error("friction = 0.2\n",
                   "contacts[0]: missing required key 'tangential_penalty' (a number > 0 (N/m), "
                   "or an elastic_slip (m), with friction on a power law");
  expect_one_error("friction = 0.2\nstatic_friction = 0.3\n",
                   "contacts[0].static_friction: give either 'friction' (one coefficient) or "
                   "'static_friction' and 'kinetic_friction', not both");
  expect_one_error("static_friction = 0.2\nkinetic_friction = 0.3\ntangential_penalty = 1e5\n",
                   "contacts[0].kinetic_friction: expected kinetic_friction <= static_friction "
                   "(0.2), found 0.3");
  expect_one_error("static_friction = 0.2\ntangential_penalty = 1e5\n",
                   "missing required key 'kinetic_friction'");
  expect_one_error("tangential_penalty = 1e5\n",
                   "contacts[0].tangential_penalty: 'tangential_penalty' applies only with "
                   "friction");
  expect_one_error("friction = -0.1\n", "contacts[0].friction: expected a number >= 0, found -0.1");
  // An elastic slip in place of the tangential penalty (also on a power law).
  f = friction_of(replace(kSplines, "margin = 0.001\n",
                          "margin = 0.001\nfriction = 0.2\nelastic_slip = 1e-5\n"));
  EXPECT_DOUBLE_EQ(f.elastic_slip, 1e-5);
  EXPECT_EQ(f.tangential_penalty, 0.0);
  expect_one_error("friction = 0.2\nelastic_slip = 1e-5\ntangential_penalty = 1e5\n",
                   "contacts[0].tangential_penalty: give either 'tangential_penalty' (a constant "
                   "stick stiffness) or 'elastic_slip'");
  expect_one_error("elastic_slip = 1e-5\n",
                   "contacts[0].elastic_slip: 'elastic_slip' applies only with friction");
  expect_one_error("friction = 0.2\nelastic_slip = 0\n",
                   "contacts[0].elastic_slip: expected a number > 0, found 0");
  const FrictionParameters twist =
      friction_of(replace(kSplines, "margin = 0.001\n",
                          "margin = 0.001\nfriction = 0.2\nelastic_slip = 1e-5\n"
                          "torsional_friction = true\n"));
  EXPECT_TRUE(twist.torsional);
  EXPECT_DOUBLE_EQ(twist.elastic_slip, 1e-5);
  // Torsional friction: off by default; its radius and penalty default to 0 (derived per pair).
  EXPECT_FALSE(f.torsional);
  f = friction_of(replace(kSplines, "margin = 0.001\n",
                          "margin = 0.001\nfriction = 0.2\ntangential_penalty = 1e5\n"
                          "torsional_friction = true\n"));
  EXPECT_TRUE(f.torsional);
  EXPECT_EQ(f.torsional_radius, 0.0);
  EXPECT_EQ(f.torsional_penalty, 0.0);
  f = friction_of(replace(kSplines, "margin = 0.001\n",
                          "margin = 0.001\nfriction = 0.2\ntangential_penalty = 1e5\n"
                          "torsional_friction = true\ntorsional_radius = 4e-4\n"
                          "torsional_penalty = 0.02\n"));
  EXPECT_DOUBLE_EQ(f.torsional_radius, 4e-4);
  EXPECT_DOUBLE_EQ(f.torsional_penalty, 0.02);
  expect_one_error("torsional_friction = true\n",
                   "contacts[0].torsional_friction: 'torsional_friction' applies only with "
                   "friction (a coefficient above 0)");
  expect_one_error("friction = 0.2\ntangential_penalty = 1e5\ntorsional_radius = 4e-4\n",
                   "contacts[0].torsional_radius: 'torsional_radius' applies only with "
                   "torsional_friction = true");
  expect_one_error("friction = 0.2\ntangential_penalty = 1e5\ntorsional_friction = false\n"
                   "torsional_penalty = 0.02\n",
                   "contacts[0].torsional_penalty: 'torsional_penalty' applies only with "
                   "torsional_friction = true");
  expect_one_error("friction = 0.2\ntangential_penalty = 1e5\ntorsional_friction = true\n"
                   "torsional_radius = 0\n",
                   "contacts[0].torsional_radius: expected a number > 0, found 0");
  // On the explicit path too: read as on the others.
  const auto errors =
      errors_of(replace(replace(kSplines, "margin = 0.001\n",
                                "margin = 0.001\nfriction = 0.2\ntangential_penalty = 1e5\n"),
                        "type = \"static\"", "type = \"explicit\""));
  EXPECT_FALSE(has(errors, "contacts[0]")) << joined(errors);
  EXPECT_TRUE(has(errors, "because steps[0] is dynamic")) << joined(errors); // this deck's masses
  // Not the elastic slip, whose stick stiffness the stable step cannot bound before the run.
  const auto elastic =
      errors_of(replace(replace(kSplines, "margin = 0.001\n",
                                "margin = 0.001\nfriction = 0.2\nelastic_slip = 1e-5\n"),
                        "type = \"static\"", "type = \"explicit\""));
  EXPECT_TRUE(has(elastic, "contacts[0].elastic_slip: 'elastic_slip' is not available on the "
                           "explicit path"))
      << joined(elastic);
}

TEST(DeckSplines, AllAngleContactKeysDefaultAndAreChecked) {
  // Defaults: the all-angle contact, line below 10 degrees, point above 20, 5 Gauss points,
  // the line penalty from the radii (0).
  const Model defaults = read_deck_string(kSplines, "deck.toml");
  const SplineContactDefinition& d = defaults.spline_contacts[0];
  EXPECT_TRUE(d.line_contact);
  EXPECT_DOUBLE_EQ(d.line_angle, 10.0);
  EXPECT_DOUBLE_EQ(d.point_angle, 20.0);
  EXPECT_DOUBLE_EQ(d.line_penalty, 0.0);
  EXPECT_EQ(d.gauss_points, 5);

  std::string deck = replace(kSplines, "margin = 0.001\n",
                             "margin = 0.001\nline_angle = 5.0\npoint_angle = 15.0\n"
                             "line_penalty = 3e9\ngauss_points = 8\n");
  const SplineContactDefinition c = read_deck_string(deck, "deck.toml").spline_contacts[0];
  EXPECT_DOUBLE_EQ(c.line_angle, 5.0);
  EXPECT_DOUBLE_EQ(c.point_angle, 15.0);
  EXPECT_DOUBLE_EQ(c.line_penalty, 3e9);
  EXPECT_EQ(c.gauss_points, 8);

  deck = replace(kSplines, "margin = 0.001\n", "margin = 0.001\nline_angle = 25.0\n");
  auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "25.0") + "contacts[0].line_angle: expected line_angle < "
                                             "point_angle (degrees), found 25 and 20");

  deck = replace(kSplines, "margin = 0.001\n", "margin = 0.001\ngauss_points = 11\n");
  errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_NE(errors[0].find("contacts[0].gauss_points"), std::string::npos) << errors[0];

  deck = replace(kSplines, "margin = 0.001\n",
                 "margin = 0.001\nline_contact = false\n"
                 "point_angle = 30.0\n");
  errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "30.0") + "contacts[0].point_angle: 'point_angle' applies "
                                             "only with line_contact = true");

  deck = replace(kSplines, "margin = 0.001\n", "margin = 0.001\nline_angel = 5.0\n");
  errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_NE(errors[0].find("did you mean 'line_angle'"), std::string::npos) << errors[0];
}

TEST(DeckSplines, ContactTypeIsChecked) {
  const std::string deck = replace(kSplines, "type = \"spline\"", "type = \"spilne\"");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_EQ(errors[0], where(deck, "\"spilne\"") +
                           "contacts[0].type: expected \"spline\" (beam-to-beam contact of C1 "
                           "splines) or \"surface\" (surface-to-surface contact of elliptical "
                           "cylinders), found \"spilne\"; did you mean \"spline\"?");
}

// kSplines with surfaces on the crossing line (a circle section) and on the first beam (a
// stiffness section, so the semi-axes are given), and a surface contact between them.
const std::string kSurfaces = kSplines + R"(
[[surfaces]]
name = "cross"
node_set = "cross"

[[surfaces]]
name = "rod"
node_set = "backwards"
a = 0.02
b = 0.01
exponent = 4

[[contacts]]
name = "surf"
type = "surface"
between = ["rod", "cross"]
penalty = 3.5e5
)";

TEST(DeckSurfaces, SurfacesAndSurfaceContactsResolveToIndices) {
  const Model m = read_deck_string(kSurfaces, "deck.toml");
  ASSERT_EQ(m.surfaces.size(), 2u);
  // The [[lines]] elements follow the two [[elements]]; semi-axes from the circle section.
  EXPECT_EQ(m.surfaces[0].name, "cross");
  EXPECT_EQ(m.surfaces[0].elements, (std::vector<int>{2, 3}));
  EXPECT_DOUBLE_EQ(m.surfaces[0].a, 0.01);
  EXPECT_DOUBLE_EQ(m.surfaces[0].b, 0.01);
  EXPECT_DOUBLE_EQ(m.surfaces[0].exponent, 2.0);
  // A set written against the elements' direction is walked along them.
  EXPECT_EQ(m.surfaces[1].elements, (std::vector<int>{0, 1}));
  EXPECT_DOUBLE_EQ(m.surfaces[1].a, 0.02);
  EXPECT_DOUBLE_EQ(m.surfaces[1].b, 0.01);
  EXPECT_DOUBLE_EQ(m.surfaces[1].exponent, 4.0);
  ASSERT_EQ(m.surface_contacts.size(), 1u);
  EXPECT_EQ(m.surface_contacts[0].name, "surf");
  EXPECT_EQ(m.surface_contacts[0].group_a, std::vector<int>{1});
  EXPECT_EQ(m.surface_contacts[0].group_b, std::vector<int>{0});
  EXPECT_DOUBLE_EQ(m.surface_contacts[0].law.penalty, 3.5e5);
  EXPECT_EQ(m.spline_contacts.size(), 2u);
}

TEST(DeckSurfaces, SurfaceContactFrictionIsReadWithItsTangentialDamping) {
  const Model m =
      read_deck_string(kSurfaces + "static_friction = 0.3\nkinetic_friction = 0.2\n", "deck.toml");
  const FrictionParameters& f = m.surface_contacts[0].friction;
  EXPECT_DOUBLE_EQ(f.mu_static, 0.3);
  EXPECT_DOUBLE_EQ(f.mu_kinetic, 0.2);
  EXPECT_DOUBLE_EQ(f.tangential_penalty, 3.5e5); // the linear law's penalty
  EXPECT_FALSE(f.torsional);
  EXPECT_EQ(f.tangential_damping, 0.0);
  // Tangential damping acts on the velocities of dynamic steps, as on the spline contact.
  const auto errors = errors_of(kSurfaces + "friction = 0.2\ntangential_damping = 1.0\n");
  ASSERT_EQ(errors.size(), 1u) << joined(errors);
  EXPECT_TRUE(has(errors, "contact damping acts on the velocities of dynamic steps"))
      << joined(errors);
  // On a dynamic step (the beam section given a mass; the rod's comes from its material).
  const std::string dynamic_deck =
      replace(replace(kSurfaces, "type = \"static\"", "type = \"dynamic\""), "GJ = 1.0",
              "GJ = 1.0\nrhoA = 1.0");
  const Model dynamic =
      read_deck_string(dynamic_deck + "friction = 0.2\ntangential_damping = 1.0\n", "deck.toml");
  EXPECT_DOUBLE_EQ(dynamic.surface_contacts[0].friction.tangential_damping, 1.0);
  // The normal law's damping stays the spline contact's.
  const auto normal = errors_of(dynamic_deck + "damping = 1.0\n");
  ASSERT_EQ(normal.size(), 1u) << joined(normal);
  EXPECT_TRUE(has(normal, "surface contact damping is not available in this version"))
      << joined(normal);
}

TEST(DeckSurfaces, SurfaceContactTorsionalFrictionIsReadWithItsChecks) {
  const Model m =
      read_deck_string(kSurfaces + "friction = 0.2\ntorsional_friction = true\n", "deck.toml");
  const FrictionParameters& f = m.surface_contacts[0].friction;
  EXPECT_TRUE(f.torsional);
  EXPECT_EQ(f.torsional_radius, 0.0); // the defaults: from the widths, eps_t rho^2
  EXPECT_EQ(f.torsional_penalty, 0.0);
  const Model set = read_deck_string(kSurfaces + "friction = 0.2\ntorsional_friction = true\n"
                                                 "torsional_radius = 0.004\n"
                                                 "torsional_penalty = 0.5\n",
                                     "deck.toml");
  EXPECT_DOUBLE_EQ(set.surface_contacts[0].friction.torsional_radius, 0.004);
  EXPECT_DOUBLE_EQ(set.surface_contacts[0].friction.torsional_penalty, 0.5);
  // The spline contact's checks: the radius and penalty only with torsional friction, and
  // positive.
  const auto without = errors_of(kSurfaces + "friction = 0.2\ntorsional_radius = 0.004\n");
  ASSERT_EQ(without.size(), 1u) << joined(without);
  EXPECT_TRUE(has(without, "'torsional_radius' applies only with torsional_friction = true"))
      << joined(without);
  const auto negative =
      errors_of(kSurfaces + "friction = 0.2\ntorsional_friction = true\ntorsional_penalty = -1\n");
  ASSERT_EQ(negative.size(), 1u) << joined(negative);
  EXPECT_TRUE(has(negative, "torsional_penalty")) << joined(negative);
}

TEST(DeckSurfaces, AllSurfaceErrorsAreReportedAtOnce) {
  // A stiffness section without semi-axes, an unknown surface name, a single group.
  std::string deck = replace(kSurfaces, "a = 0.02\nb = 0.01\n", "");
  deck = replace(deck, "between = [\"rod\", \"cross\"]", "between = [[\"rod\", \"crosss\"]]");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 4u) << joined(errors);
  EXPECT_NE(joined(errors).find("surfaces[1]: missing required key 'a' (semi-axis of the contact "
                                "section, m): the elements' section 'beam' gives stiffnesses, not "
                                "a shape"),
            std::string::npos)
      << joined(errors);
  EXPECT_NE(joined(errors).find("missing required key 'b'"), std::string::npos) << joined(errors);
  EXPECT_NE(joined(errors).find("no surface named 'crosss'; did you mean 'cross'?"),
            std::string::npos)
      << joined(errors);
  EXPECT_NE(joined(errors).find("expected two groups of surfaces, found one"), std::string::npos)
      << joined(errors);
}

TEST(DeckSurfaces, SurfaceOnElementsOfAnUnknownSectionIsReportedNotRead) {
  // Found by fuzzing: with no [[sections]] at all, an element whose section does not resolve
  // holds a placeholder index into an empty list, and a surface on it read its semi-axes there.
  // In a Release build the old code happened to read nothing (the empty list's null data); the
  // sanitizer suite (scripts/test --sanitize, in CI) stops this test there with UBSan's report.
  std::ifstream in(kExamples / "crossing-ellipses.toml");
  std::string deck((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string section = "[[sections]]\nname = \"flat-rod\"\n";
  ASSERT_NE(deck.find(section), std::string::npos);
  deck = replace(deck, section, "[[unused]]\nname = \"flat-rod\"\n");
  const auto errors = errors_of(deck);
  const std::string all = joined(errors);
  ASSERT_EQ(errors.size(), 3u) << all;
  EXPECT_NE(errors[0].find("unused: unknown key 'unused' in the top level of the deck"),
            std::string::npos)
      << all;
  EXPECT_NE(errors[1].find("lines[0].section: no section named 'flat-rod' (the deck has no "
                           "[[sections]])"),
            std::string::npos)
      << all;
  EXPECT_NE(errors[2].find("lines[1].section: no section named 'flat-rod'"), std::string::npos)
      << all;
}

TEST(DeckSplines, AllSplineAndContactErrorsAreReportedAtOnce) {
  std::string deck = replace(kSplines, "radius = 0.02", "radius = -1.0");
  deck = replace(deck, "nodes = [10, 9, 8]", "nodes = [10, 9]");
  deck = replace(deck, "[\"cross\", \"listed\"]", "[\"cross\", \"lsited\"]");
  deck = replace(deck, "law = \"power\"", "law = \"powr\"");
  const auto errors = errors_of(deck);
  ASSERT_EQ(errors.size(), 4u) << joined(errors);
  EXPECT_NE(errors[0].find("splines[2].nodes:"), std::string::npos) << errors[0];
  EXPECT_NE(errors[1].find("splines[2].radius:"), std::string::npos) << errors[1];
  EXPECT_NE(errors[2].find("contacts[0].between[1][1]:"), std::string::npos) << errors[2];
  EXPECT_NE(errors[3].find("contacts[0].law:"), std::string::npos) << errors[3];
}

TEST(DeckSplines, CrossingBeamsExampleHasTheVerificationCase) {
  const Model m = read_deck(kExamples / "crossing-beams.toml");
  ASSERT_EQ(m.splines.size(), 2u);
  ASSERT_EQ(m.splines[0].nodes.size(), 21u);
  ASSERT_EQ(m.splines[1].nodes.size(), 21u);
  EXPECT_EQ(m.splines[1].nodes.front(), 21);
  EXPECT_DOUBLE_EQ(m.splines[0].radius, 0.01);
  // Initially touching: centre lines 2 r apart at the crossing.
  const Eigen::Vector3d bottom_mid = m.nodes[static_cast<std::size_t>(m.splines[0].nodes[10])];
  const Eigen::Vector3d top_mid = m.nodes[static_cast<std::size_t>(m.splines[1].nodes[10])];
  EXPECT_NEAR((top_mid - bottom_mid).norm(), 2 * 0.01, 1e-15);
  ASSERT_EQ(m.spline_contacts.size(), 1u);
  EXPECT_EQ(m.spline_contacts[0].group_a, std::vector<int>{0});
  EXPECT_EQ(m.spline_contacts[0].group_b, std::vector<int>{1});
  EXPECT_DOUBLE_EQ(m.spline_contacts[0].law.penalty, 1e5);
  EXPECT_DOUBLE_EQ(m.spline_contacts[0].law.exponent, 1.0);
  // F_c = P / (2 + k / eps) with k = 48 EI / L^3 (verification.md).
  const double EI = m.sections[0].EI1;
  EXPECT_NEAR(EI, 7.85398, 1e-5);
  EXPECT_NEAR(1.0 / (2 + 48 * EI / 1e5), 0.499059, 1e-6);
  EXPECT_EQ(m.loads[0].force, Eigen::Vector3d(0, 0, -1));
  EXPECT_EQ(m.node_sets[static_cast<std::size_t>(m.loads[0].node_set)].nodes,
            std::vector<int>{m.splines[1].nodes[10]});
}

// The study's elliptical yarn section (formulation.md §1): a = 1.136364 mm, b = 0.2840909 mm,
// EA = 38 000 N, nu = 0.2, the lower moment of inertia (about axis 1, a > b) times 0.1.
TEST(SectionFromShape, ReproducesThePapersEllipticalYarn) {
  const double a = 1.136364e-3;
  const double b = 0.2840909e-3;
  const double area = std::numbers::pi * a * b;
  Material glass{"glass", 38000 / area, 0, 2540};
  glass.shear = glass.young / (2 * (1 + 0.2));
  const Section s =
      section_from_shape("yarn", SectionShape::Ellipse, a, b, 2, glass, 0.1, 1.0, 5.0 / 6.0);
  EXPECT_NEAR(s.EA, 38000, 1e-6);
  EXPECT_NEAR(s.EI1, 7.67e-5, 0.005e-5);
  EXPECT_NEAR(s.EI2, 1.23e-2, 0.005e-2);
  EXPECT_NEAR(s.GJ, 1.20e-3, 0.005e-3);
  EXPECT_NEAR(s.rhoA, 2.576e-3, 0.0005e-3);
}

TEST(SectionFromShape, DeckShapeFormMatchesTheFunction) {
  const Model m = read_deck_string(R"(title = "yarn"
[[materials]]
name = "glass"
E = 3.7469e10
nu = 0.2
density = 2540
[[sections]]
name = "yarn"
shape = "ellipse"
a = 1.136364e-3
b = 0.2840909e-3
material = "glass"
reduce_I1 = 0.1
[[lines]]
name = "yarn"
from = [0, 0, 0]
to = [0.04, 0, 0]
elements = 4
section = "yarn"
[[steps]]
type = "static"
end_time = 1
dt = 0.1
)",
                                   "deck.toml");
  const Section expected = section_from_shape("yarn", SectionShape::Ellipse, 1.136364e-3,
                                              0.2840909e-3, 2, m.materials[0], 0.1, 1, 5.0 / 6.0);
  EXPECT_DOUBLE_EQ(m.sections[0].EI1, expected.EI1);
  EXPECT_DOUBLE_EQ(m.sections[0].GJ, expected.GJ);
  EXPECT_DOUBLE_EQ(m.sections[0].GA1, expected.GA1);
  EXPECT_NEAR(m.sections[0].EI1, 7.67e-5, 0.005e-5);
}

TEST(SectionFromShape, SuperEllipseAreaTendsToTheBoundingRectangle) {
  const Material mat{"m", 1, 0.5, 1};
  const double a = 2;
  const double b = 0.5;
  const double ellipse =
      section_from_shape("s", SectionShape::SuperEllipse, a, b, 2, mat, 1, 1, 1).EA;
  EXPECT_NEAR(ellipse, std::numbers::pi * a * b, 1e-12);
  double previous = ellipse;
  for (double m : {4.0, 10.0, 100.0, 1000.0}) {
    const double area =
        section_from_shape("s", SectionShape::SuperEllipse, a, b, m, mat, 1, 1, 1).EA;
    EXPECT_GT(area, previous);
    EXPECT_LT(area, 4 * a * b);
    previous = area;
  }
  EXPECT_NEAR(previous, 4 * a * b, 4 * a * b * 2e-3);
}

} // namespace
} // namespace yarnsim
