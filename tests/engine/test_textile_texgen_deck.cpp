// Fabric decks whose yarns come from a TexGen file ([fabric] texgen, engine/textile/fabric_deck.hpp
// through read_deck), on the sample files of ../shared/data/texgen/ and on broken input.

#include "deck_errors.hpp"
#include "engine/input/read_deck.hpp"
#include "engine/textile/biaxial.hpp"
#include "engine/textile/texgen.hpp"

#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <string>

namespace yarnsim {
namespace {

const std::filesystem::path kTexGen = std::filesystem::path(YARNSIM_SHARED_DIR) / "data/texgen";

/// A deck "fabric.toml" in the samples' folder: texgen = "pweave.tg3" is found next to it.
const std::string kDeckName = (kTexGen / "fabric.toml").string();

constexpr std::string_view kValid = R"(title = "plain weave from TexGen"
[fabric]
texgen = "pweave.tg3"
repeats = [3, 3]
EA = 4000.0
nu = 0.2
density = 2540.0
contact_radius = 0.045e-3

[biaxial]
strain_ratio = 2.0
max_strain = 0.004
type = "static"
)";

std::string with(std::string_view from, std::string_view to) {
  return test::with(kValid, from, to);
}

std::vector<std::string> errors_of(std::string_view deck, const std::string& name = kDeckName) {
  return test::errors_of(deck, name);
}
using test::joined;

using test::has;

/// A folder of its own under the system's temporary folder, emptied.
std::filesystem::path scratch(const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("yarnsim-texgen-deck-" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

void write(const std::filesystem::path& file, std::string_view text) {
  std::ofstream out(file, std::ios::binary);
  out << text;
}

/// A .tg3 of straight yarns given by their two master nodes (mm), elliptical 0.8 x 0.1 mm.
std::string straight_yarns(const std::vector<std::pair<std::string, std::string>>& ends) {
  std::string out = "<?xml version=\"1.0\" ?>\n<TexGenModel>\n<Textile name=\"t\" "
                    "type=\"CTextile\" NeedsBuilding=\"0\">\n";
  int index = 0;
  for (const auto& [from, to] : ends) {
    out += "<Yarn index=\"" + std::to_string(index++) +
           "\">\n<Interpolation Periodic=\"0\" type=\"CInterpolationBezier\" />\n"
           "<YarnSection type=\"CYarnSectionConstant\">\n"
           "<Section type=\"CSectionEllipse\" Width=\"0.8\" Height=\"0.1\" />\n</YarnSection>\n"
           "<MasterNode Position=\"" +
           from + "\" />\n<MasterNode Position=\"" + to + "\" />\n</Yarn>\n";
  }
  return out + "</Textile>\n</TexGenModel>\n";
}

TEST(TexGenDeck, PlainWeaveFileBuildsTheFabricAndTheBiaxialTest) {
  const Model m = read_deck_string(kValid, kDeckName);
  EXPECT_EQ(m.title, "plain weave from TexGen");
  // The same yarns as the reader gives with the same options.
  textile::TexGenOptions o;
  o.material.EA = 4000;
  o.material.poisson = 0.2;
  o.material.density = 2540;
  o.contact_radius = 0.045e-3;
  o.repeats = {3, 3, 1};
  const textile::Fabric f = textile::read_texgen(kTexGen / "pweave.tg3", o);
  ASSERT_EQ(m.nodes.size(), f.model.nodes.size());
  for (std::size_t i = 0; i < m.nodes.size(); ++i)
    EXPECT_EQ(m.nodes[i], f.model.nodes[i]) << "node " << i;
  ASSERT_EQ(m.sections.size(), f.model.sections.size());
  EXPECT_DOUBLE_EQ(m.sections[0].EA, 4000.0);
  // 2 X yarns x 3 copies, 2 Y yarns x 3 copies; the warp-weft spline contact, radius as given.
  ASSERT_TRUE(m.biaxial.has_value());
  EXPECT_EQ(m.biaxial->warp_start.size(), 6u);
  EXPECT_EQ(m.biaxial->weft_start.size(), 6u);
  EXPECT_EQ(m.biaxial->strain_ratio, 2.0);
  EXPECT_NEAR(m.biaxial->length_warp, 6e-3, 1e-15); // 3 periods of 2 mm
  ASSERT_EQ(m.spline_contacts.size(), 1u);
  EXPECT_EQ(m.spline_contacts[0].name, "warp-weft");
  EXPECT_EQ(m.spline_contacts[0].group_a.size(), 6u);
  EXPECT_EQ(m.spline_contacts[0].group_b.size(), 6u);
  EXPECT_DOUBLE_EQ(m.spline_contacts[0].law.penalty, 1.5e6);
  EXPECT_EQ(m.splines[0].radius, 0.045e-3);
  EXPECT_TRUE(m.surface_contacts.empty());
  ASSERT_EQ(m.steps.size(), 1u);
  EXPECT_EQ(m.steps[0].type, StepType::Static);
  // Every yarn end is pulled along its own yarn: warp along x, weft along y.
  EXPECT_EQ(m.prescribed.size(), 2u * 12u);
  const TimeTable& warp_end_x = *m.prescribed[1].displacement[0];
  EXPECT_NEAR(warp_end_x.value.back(), 0.004 * 6e-3 / 2, 1e-18);
  EXPECT_EQ(m.prescribed[1].displacement[1]->value.back(), 0.0);
  EXPECT_EQ(m.monitors.size(), 2u);
}

TEST(TexGenDeck, PathIsRelativeToTheDecksFolderOrAbsolute) {
  const std::filesystem::path dir = scratch("relative");
  std::filesystem::create_directories(dir / "decks");
  std::filesystem::copy_file(kTexGen / "pweave.tg3", dir / "pweave.tg3");
  const std::string relative = with("\"pweave.tg3\"", "\"../pweave.tg3\"");
  EXPECT_EQ(read_deck_string(relative, (dir / "decks" / "fabric.toml").string()).nodes.size(),
            read_deck_string(kValid, kDeckName).nodes.size());
  // The same deck elsewhere does not find it.
  const auto e = errors_of(relative, (dir / "fabric.toml").string());
  ASSERT_EQ(e.size(), 1u) << joined(e);
  EXPECT_EQ(e[0], (dir / "fabric.toml").string() +
                      ":3:10: fabric.texgen: expected a TexGen file (.tg3, relative to the "
                      "deck's folder or absolute), found no file at " +
                      (dir / "../pweave.tg3").string());
  const std::string absolute =
      with("\"pweave.tg3\"", "\"" + (kTexGen / "cotton.tg3").string() + "\"");
  EXPECT_EQ(read_deck_string(absolute, "elsewhere/fabric.toml").title, "plain weave from TexGen");
}

TEST(TexGenDeck, SurfaceContactTakesTheSemiAxesFromTheFilesSections) {
  const Model m =
      read_deck_string(std::string(kValid) + "\n[contact]\ntype = \"surface\"\n", kDeckName);
  EXPECT_TRUE(m.spline_contacts.empty());
  ASSERT_EQ(m.surface_contacts.size(), 1u);
  EXPECT_EQ(m.surface_contacts[0].name, "warp-weft");
  EXPECT_DOUBLE_EQ(m.surface_contacts[0].law.penalty, 3.5e5); // the paper's surface value
  EXPECT_EQ(m.surface_contacts[0].group_a.size(), 6u);
  EXPECT_EQ(m.surface_contacts[0].group_b.size(), 6u);
  // pweave.tg3: CSectionEllipse Width 0.8, Height 0.1 mm.
  ASSERT_FALSE(m.surfaces.empty());
  for (const Surface& s : m.surfaces) {
    EXPECT_NEAR(s.a, 0.4e-3, 1e-18) << s.name;
    EXPECT_NEAR(s.b, 0.05e-3, 1e-18) << s.name;
  }
  // Lenticular sections (cotton.tg3, 0.3 x 0.14 mm): the ellipse of the same width and height.
  const Model c = read_deck_string(
      with("\"pweave.tg3\"", "\"cotton.tg3\"") + "\n[contact]\ntype = \"surface\"\n", kDeckName);
  for (const Surface& s : c.surfaces) {
    EXPECT_NEAR(s.a, 0.15e-3, 1e-15) << s.name;
    EXPECT_NEAR(s.b, 0.07e-3, 1e-15) << s.name;
  }
}

TEST(TexGenDeck, ExplicitTestRunsOnTheFilesFabric) {
  const Model m = read_deck_string(
      with("type = \"static\"", "type = \"explicit\"\nexplicit = { dt = 1e-4 }"), kDeckName);
  ASSERT_EQ(m.steps.size(), 1u);
  EXPECT_EQ(m.steps[0].type, StepType::Explicit);
  EXPECT_EQ(m.steps[0].dt_initial, 1e-4);
  EXPECT_EQ(m.biaxial->warp_end.size(), 6u);
}

TEST(TexGenDeck, WeaveKeysWithTexGenAndTexGenKeysWithoutAreErrors) {
  const auto e = errors_of(with("EA = 4000.0", "EA = 4000.0\ngap = 0.1e-3\na = 1e-3\nn_warp = 3"));
  ASSERT_EQ(e.size(), 3u) << joined(e);
  EXPECT_EQ(e[0], kDeckName + ":6:7: fabric.gap: 'gap' applies only without texgen (a woven "
                              "fabric built from its parameters); with texgen the yarns come "
                              "from the file");
  EXPECT_TRUE(e[1].starts_with(kDeckName + ":7:5: fabric.a: 'a' applies only without texgen"))
      << e[1];
  EXPECT_TRUE(e[2].starts_with(kDeckName + ":8:10: fabric.n_warp: 'n_warp' applies only")) << e[2];

  // A woven deck with TexGen's keys.
  const std::string woven = R"([fabric]
spacing_warp = 4e-3
spacing_weft = 5e-3
length_warp = 25e-3
length_weft = 20e-3
gap = 0.1e-3
a = 1e-3
b = 0.3e-3
E = 3.7e10
nu = 0.2
density = 2540.0
repeats = [2, 2]
elements_per_interval = 2

[biaxial]
strain_ratio = 1.0
)";
  const auto w = errors_of(woven, "woven.toml");
  ASSERT_EQ(w.size(), 2u) << joined(w);
  EXPECT_EQ(w[0], "woven.toml:12:11: fabric.repeats: 'repeats' applies only with texgen = "
                  "\"file.tg3\"");
  EXPECT_EQ(w[1], "woven.toml:13:25: fabric.elements_per_interval: 'elements_per_interval' "
                  "applies only with texgen = \"file.tg3\"");
}

TEST(TexGenDeck, BadTexGenOptionsAreReportedAllAtOnce) {
  const std::string deck = with("repeats = [3, 3]", "repeats = [3, 0]\nlength_scale = -1.0\n"
                                                    "elements_per_interval = 0\ntextile = 5");
  const auto e = errors_of(deck);
  ASSERT_EQ(e.size(), 4u) << joined(e);
  EXPECT_EQ(e[0], kDeckName + ":4:15: fabric.repeats[1]: expected an integer in [1, 10000], "
                              "found an integer (0)");
  EXPECT_TRUE(e[1].starts_with(kDeckName + ":5:16: fabric.length_scale: expected a number > 0"))
      << e[1];
  EXPECT_TRUE(e[2].starts_with(kDeckName + ":6:25: fabric.elements_per_interval: expected an "
                                           "integer in [1, 1000]"))
      << e[2];
  EXPECT_TRUE(e[3].starts_with(kDeckName + ":7:11: fabric.textile: expected a string")) << e[3];
  const auto four = errors_of(with("repeats = [3, 3]", "repeats = [1, 1, 1, 1]"));
  ASSERT_EQ(four.size(), 1u) << joined(four);
  EXPECT_TRUE(four[0].starts_with(kDeckName + ":4:11: fabric.repeats: expected an array of 1 to "
                                              "3 integers >= 1"))
      << four[0];
  // A textile the file does not hold is the file's problem.
  const auto name = errors_of(with("repeats = [3, 3]", "textile = \"twill\""));
  EXPECT_TRUE(has(name, "expected a <Textile> named 'twill', found '2DWeave(W:2,H:2)'"))
      << joined(name);
}

TEST(TexGenDeck, ProblemsOfTheFileFollowTheKeyWithTheirOwnLineAndColumn) {
  const std::filesystem::path dir = scratch("broken");
  std::string tg3 = straight_yarns({{"0, 0, 0", "2, 0, 0"}, {"1, -1, 0.1", "1, 1, 0.1"}});
  tg3.replace(tg3.find("Width=\"0.8\""), 11, "Width=\"-0.8\"");
  tg3.replace(tg3.find("\"1, 1, 0.1\""), 11, "\"1, one, 0.1\"");
  write(dir / "broken.tg3", tg3);
  // The deck's own problems come too, all at once, in the deck's order.
  std::string deck = with("pweave.tg3", "broken.tg3");
  deck = deck.replace(deck.find("density = 2540.0"), 16, "density = -1.0");
  const std::string name = (dir / "fabric.toml").string();
  const auto e = errors_of(deck, name);
  ASSERT_EQ(e.size(), 4u) << joined(e);
  EXPECT_EQ(e[0], name +
                      ":3:10: fabric.texgen: expected a TexGen file that reads cleanly, "
                      "found 2 problem(s) in " +
                      (dir / "broken.tg3").string() + " (listed next, at their place in it)");
  EXPECT_EQ(e[1], (dir / "broken.tg3").string() +
                      ":7:40: <Section> attribute 'Width': expected a number > 0, found \"-0.8\"");
  EXPECT_TRUE(
      e[2].starts_with((dir / "broken.tg3").string() + ":18:23: <MasterNode> attribute 'Position'"))
      << e[2];
  EXPECT_TRUE(e[3].starts_with(name + ":7:11: fabric.density: expected a number > 0")) << e[3];
}

TEST(TexGenDeck, AFileWithYarnsOfOneDirectionCannotTakeTheBiaxialTest) {
  const std::filesystem::path dir = scratch("one-direction");
  write(dir / "warp.tg3", straight_yarns({{"0, 0, 0", "2, 0, 0"}, {"0, 1, 0", "2, 1, 0"}}));
  const std::string name = (dir / "fabric.toml").string();
  const auto e = errors_of(with("pweave.tg3", "warp.tg3"), name);
  ASSERT_EQ(e.size(), 1u) << joined(e);
  EXPECT_EQ(e[0], name + ":3:10: fabric.texgen: the yarns of " + (dir / "warp.tg3").string() +
                      " cannot take the biaxial test: biaxial: expected warp and weft yarns, "
                      "found only one direction");
  // A yarn without in-plane extent is reported by the reader, at the yarn.
  write(dir / "upright.tg3", straight_yarns({{"0, 0, 0", "2, 0, 0"}, {"1, 0, 0.1", "1, 0, 0.5"}}));
  const auto u = errors_of(with("pweave.tg3", "upright.tg3"), name);
  EXPECT_TRUE(has(u, "upright.tg3:12:1: yarn 1: expected the yarn's ends at different in-plane "
                     "points"))
      << joined(u);
}

TEST(TexGenDeck, StrainIsEachYarnsOwnWhenTheYarnsDifferInLength) {
  // Two warp yarns of 2 and 4 mm over one weft yarn: pulled to the same strain, each is read at
  // it (over the first yarn's length the second would read twice the strain).
  const std::filesystem::path dir = scratch("lengths");
  write(dir / "lengths.tg3",
        straight_yarns(
            {{"0, 0, 0", "2, 0, 0"}, {"0, 1, 0", "4, 1, 0"}, {"1, -1, 0.1", "1, 2, 0.1"}}));
  const Model m =
      read_deck_string(with("pweave.tg3", "lengths.tg3"), (dir / "fabric.toml").string());
  // Positions at the end of the step: every prescribed displacement applied, the rest unmoved.
  Eigen::Matrix3Xd x(3, static_cast<Eigen::Index>(m.nodes.size()));
  for (std::size_t i = 0; i < m.nodes.size(); ++i)
    x.col(static_cast<Eigen::Index>(i)) = m.nodes[i];
  for (const PrescribedMotion& p : m.prescribed)
    for (int node : m.node_sets[static_cast<std::size_t>(p.node_set)].nodes)
      for (int c = 0; c < 3; ++c)
        x(c, node) += p.displacement[static_cast<std::size_t>(c)]->value.back();
  const textile::BiaxialReading r =
      textile::read_biaxial(m, x, Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, x.cols()));
  EXPECT_NEAR(r.strain_warp, 0.004, 1e-12); // k = 2: max_strain on the warp
  EXPECT_NEAR(r.strain_weft, 0.002, 1e-12);
}

} // namespace
} // namespace yarnsim
