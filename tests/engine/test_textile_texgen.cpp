// The TexGen .tg3 reader (engine/textile/texgen.hpp) on the sample files of
// ../shared/data/texgen/ and on broken input.

#include "engine/model/deck.hpp"
#include "engine/textile/texgen.hpp"

#include <filesystem>
#include <gtest/gtest.h>
#include <iostream>
#include <map>
#include <numbers>
#include <string>

namespace yarnsim::textile {
namespace {

const std::filesystem::path kTexGen = std::filesystem::path(YARNSIM_SHARED_DIR) / "data/texgen";

TexGenOptions glass() {
  TexGenOptions o;
  o.material.young = 73e9;
  o.material.poisson = 0.2;
  o.material.density = 2540;
  return o;
}

/// The messages of the InputError a text throws; a test failure when it reads cleanly.
std::vector<std::string> errors_of(std::string_view text) {
  try {
    read_texgen_string(text, "bad.tg3", glass());
  } catch (const InputError& e) {
    return e.messages();
  }
  ADD_FAILURE() << "read without errors:\n" << text;
  return {};
}

void expect_sound(const Fabric& f, const std::string& file) {
  ASSERT_FALSE(f.yarns.empty()) << file;
  for (const Eigen::Vector3d& x : f.model.nodes)
    EXPECT_TRUE(x.allFinite()) << file;
  for (const Section& s : f.model.sections) {
    for (double v : {s.EA, s.GA1, s.GA2, s.EI1, s.EI2, s.GJ, s.rhoA, s.a, s.b})
      EXPECT_GT(v, 0) << file << " section " << s.name;
    EXPECT_TRUE((s.rhoJ.array() > 0).all()) << file;
  }
  std::size_t nodes = 0;
  for (const Yarn& y : f.yarns) {
    nodes += y.nodes.size();
    EXPECT_EQ(y.nodes.size() % 2, 1u);
    // Each yarn runs from its smaller to its larger coordinate along its direction.
    const Eigen::Vector3d a = f.model.nodes[static_cast<std::size_t>(y.nodes.front())];
    const Eigen::Vector3d b = f.model.nodes[static_cast<std::size_t>(y.nodes.back())];
    EXPECT_GT(y.warp ? b.x() - a.x() : b.y() - a.y(), 0) << file;
  }
  EXPECT_EQ(nodes, f.model.nodes.size());
  EXPECT_EQ(f.model.splines.size(), f.yarns.size());
  for (const BeamElement& e : f.model.elements)
    EXPECT_NEAR(e.reference_vector.norm(), 1.0, 1e-12);
}

TEST(TexGen, EverySampleFileReads) {
  struct Expected {
    std::size_t warp, weft, nodes_per_warp, nodes_per_weft;
  };
  // Master-node intervals x 4 elements x 2 + 1 nodes per yarn.
  const std::map<std::string, Expected> expected{
      {"pweave.tg3", {2, 2, 17, 17}},    // 2 intervals per yarn, Bezier, written yarns
      {"2dweave.tg3", {4, 4, 33, 33}},   // built from a 4 x 4 pattern
      {"3dweave.tg3", {12, 28, 65, 33}}, // 4 rows x 3 layers; columns of 4 and 3 layers
      {"cotton.tg3", {2, 2, 17, 17}},    // cubic, lenticular
      {"polyester.tg3", {2, 2, 17, 17}}, // cubic, ellipse
  };
  std::size_t seen = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kTexGen)) {
    if (entry.path().extension() != ".tg3")
      continue;
    ++seen;
    const std::string file = entry.path().filename().string();
    Fabric f;
    try {
      f = read_texgen(entry.path(), glass());
    } catch (const InputError& e) {
      ADD_FAILURE() << file << ": " << e.what();
      continue;
    }
    expect_sound(f, file);
    const auto it = expected.find(file);
    ASSERT_NE(it, expected.end()) << "a new sample file: add its counts to the test: " << file;
    std::size_t warp = 0, weft = 0;
    for (const Yarn& y : f.yarns) {
      (y.warp ? warp : weft)++;
      EXPECT_EQ(y.nodes.size(), y.warp ? it->second.nodes_per_warp : it->second.nodes_per_weft)
          << file;
    }
    EXPECT_EQ(warp, it->second.warp) << file;
    EXPECT_EQ(weft, it->second.weft) << file;
    std::cout << "[ texgen ] " << file << ": " << warp << " warp + " << weft << " weft yarns, "
              << f.model.nodes.size() << " nodes, " << f.model.elements.size() << " elements\n";
  }
  EXPECT_EQ(seen, expected.size());
}

TEST(TexGen, PlainWeaveYarnsFollowTheirMasterNodes) {
  const Fabric f = read_texgen(kTexGen / "pweave.tg3", glass());
  // Yarn 0: master nodes (0, 0, 0.05), (1, 0, 0.15), (2, 0, 0.05) mm, in-plane tangents; the
  // crossings are nodes 0, 8 and 16.
  const Yarn& y = f.yarns[0];
  ASSERT_TRUE(y.warp);
  const auto& n = f.model.nodes;
  EXPECT_TRUE(n[static_cast<std::size_t>(y.nodes[0])].isApprox(Eigen::Vector3d(0, 0, 0.05e-3)));
  EXPECT_TRUE(n[static_cast<std::size_t>(y.nodes[8])].isApprox(Eigen::Vector3d(1e-3, 0, 0.15e-3)));
  EXPECT_TRUE(n[static_cast<std::size_t>(y.nodes[16])].isApprox(Eigen::Vector3d(2e-3, 0, 0.05e-3)));
  // Symmetric about the crest, rising monotonically to it.
  for (int k = 1; k < 8; ++k) {
    const Eigen::Vector3d& lo = n[static_cast<std::size_t>(y.nodes[static_cast<std::size_t>(k)])];
    const Eigen::Vector3d& hi =
        n[static_cast<std::size_t>(y.nodes[static_cast<std::size_t>(16 - k)])];
    EXPECT_NEAR(lo.z(), hi.z(), 1e-15);
    EXPECT_NEAR(lo.x() + hi.x(), 2e-3, 1e-15);
    EXPECT_GT(lo.z(), n[static_cast<std::size_t>(y.nodes[static_cast<std::size_t>(k - 1)])].z());
  }
  // Ellipse Width 0.8, Height 0.1 mm: semi-axes 0.4 and 0.05 mm; contact radius = 0.05 mm.
  EXPECT_NEAR(f.model.sections[0].a, 0.4e-3, 1e-15);
  EXPECT_NEAR(f.model.sections[0].b, 0.05e-3, 1e-15);
  EXPECT_NEAR(f.model.splines[0].radius, 0.05e-3, 1e-15);
  ASSERT_EQ(f.model.spline_contacts.size(), 1u);
  EXPECT_EQ(f.model.spline_contacts[0].group_a.size(), 2u);
}

TEST(TexGen, WeaveBuiltFromItsPatternMatchesTheWrittenYarns) {
  TexGenOptions o = glass();
  const Fabric written = read_texgen(kTexGen / "pweave.tg3", o);
  o.rebuild_weaves = true;
  const Fabric built = read_texgen(kTexGen / "pweave.tg3", o);
  ASSERT_EQ(built.model.nodes.size(), written.model.nodes.size());
  for (std::size_t i = 0; i < built.model.nodes.size(); ++i)
    EXPECT_LT((built.model.nodes[i] - written.model.nodes[i]).norm(), 1e-15) << "node " << i;
}

TEST(TexGen, CubicPeriodicYarnIsSmoothAcrossItsEnds) {
  const Fabric f = read_texgen(kTexGen / "cotton.tg3", glass());
  // Yarn 0: (0, 0, 0), (0.35, 0, 0.15), (0.7, 0, 0) mm, periodic cubic: symmetric, zero slope
  // at the master nodes.
  const Yarn& y = f.yarns[0];
  const auto& n = f.model.nodes;
  // The periodic spline has zero slope at all three nodes and uniform speed in x: between two
  // master nodes z is TexGen's cubic z0 + (z1 - z0)(3t^2 - 2t^3) and x is linear in t.
  for (int k = 0; k <= 16; ++k) {
    const double t = k <= 8 ? k / 8.0 : (16 - k) / 8.0;
    const Eigen::Vector3d& x = n[static_cast<std::size_t>(y.nodes[static_cast<std::size_t>(k)])];
    EXPECT_NEAR(x.z(), 0.15e-3 * t * t * (3 - 2 * t), 1e-15) << k;
    EXPECT_NEAR(x.x(), 0.7e-3 * k / 16, 1e-15) << k;
  }
  // Lenticular section: area between the ellipse's and the rhombus's.
  const Section& s = f.model.sections[0];
  const double w = 0.3e-3, h = 0.14e-3;
  const double area = s.EA / 73e9;
  EXPECT_GT(area, w * h / 2);
  EXPECT_LT(area, std::numbers::pi * w * h / 4);
}

TEST(TexGen, RepeatsExtendAlongAndCopyAcross) {
  TexGenOptions o = glass();
  o.repeats = {3, 2, 1};
  const Fabric f = read_texgen(kTexGen / "pweave.tg3", o);
  std::size_t warp = 0, weft = 0;
  for (const Yarn& y : f.yarns) {
    (y.warp ? warp : weft)++;
    // X yarns: 3 periods of 2 intervals; Y yarns: the second repeat (0, 2, 0) extends them twice.
    EXPECT_EQ(y.nodes.size(), y.warp ? 3u * 2u * 8u + 1u : 2u * 2u * 8u + 1u);
  }
  EXPECT_EQ(warp, 2u * 2u); // 2 X yarns, 2 copies along (0, 2, 0)
  EXPECT_EQ(weft, 2u * 3u); // 2 Y yarns, 3 copies along (2, 0, 0)
  expect_sound(f, "pweave.tg3 x (3, 2)");
}

TEST(TexGen, BrokenFilesAreReportedWithTheirLineAndColumn) {
  // Bad XML stops the reading at its position.
  auto e = errors_of("<?xml version=\"1.0\" ?>\n<TexGenModel>\n  <Textile name=\"a\">\n"
                     "  </Textil>\n</TexGenModel>\n");
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0].rfind("bad.tg3:4:", 0), 0u) << e[0];
  EXPECT_NE(e[0].find("expected </Textile>"), std::string::npos) << e[0];

  const std::string head = "<?xml version=\"1.0\" ?>\n<TexGenModel>\n<Textile name=\"t\" "
                           "type=\"CTextile\" NeedsBuilding=\"0\">\n"
                           "<Yarn index=\"0\">\n"
                           "<Interpolation Periodic=\"0\" type=\"CInterpolationBezier\" />\n"
                           "<YarnSection type=\"CYarnSectionConstant\">\n";
  const std::string section = "<Section type=\"CSectionEllipse\" Width=\"0.8\" Height=\"0.1\" />\n"
                              "</YarnSection>\n";
  const std::string tail = "</Yarn>\n</Textile>\n</TexGenModel>\n";
  // A master node without a position (line 10): at the element's '<'.
  e = errors_of(head + section +
                "<MasterNode Position=\"0, 0, 0\" />\n<MasterNode Up=\"0, 0, 1\" />\n" + tail);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0], "bad.tg3:10:1: <MasterNode>: missing attribute 'Position' (3 numbers \"x, y, "
                  "z\" separated by commas)");
  // A malformed vector: at the attribute's value.
  e = errors_of(head + section +
                "<MasterNode Position=\"0, 0, 0\" />\n"
                "<MasterNode Position=\"1, zero, 0\" />\n" +
                tail);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0], "bad.tg3:10:23: <MasterNode> attribute 'Position': expected 3 numbers \"x, y, "
                  "z\" separated by commas, found \"1, zero, 0\"");
  // An unsupported section (line 7).
  e = errors_of(head + "<Section type=\"CSectionPolygon\" />\n</YarnSection>\n" +
                "<MasterNode Position=\"0, 0, 0\" />\n<MasterNode Position=\"1, 0, 0\" />\n" +
                tail);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0].rfind("bad.tg3:7:16: <Section> attribute 'type': expected a supported section "
                       "type (CSectionEllipse, ",
                       0),
            0u)
      << e[0];
  // A file that is not there.
  EXPECT_THROW(read_texgen(kTexGen / "missing.tg3", glass()), InputError);
}

/// Every message of `errors` equals the expected one, in order.
void expect_messages(const std::vector<std::string>& errors,
                     const std::vector<std::string>& expected) {
  EXPECT_EQ(errors.size(), expected.size());
  for (std::size_t i = 0; i < std::min(errors.size(), expected.size()); ++i)
    EXPECT_EQ(errors[i], expected[i]) << "message " << i;
  for (std::size_t i = expected.size(); i < errors.size(); ++i)
    ADD_FAILURE() << "unexpected message: " << errors[i];
}

TEST(TexGen, EveryProblemOfAFileIsReportedAtOnce) {
  // Problems in the textile's attributes, in an interpolation, a section, master nodes, a yarn
  // with too few master nodes, an unsupported section, and a yarn read cleanly whose ends meet
  // in the plane (found when it is built): all of them, in file order, each where it is.
  const std::string text = R"(<?xml version="1.0" ?>
<TexGenModel>
  <Textile name="t" type="CTextile" NeedsBuilding="0" GeometryScale="furlong">
    <Yarn index="0">
      <Interpolation Periodic="maybe" type="CInterpolationBezier" />
      <YarnSection type="CYarnSectionConstant">
        <Section type="CSectionEllipse" Width="-0.8" Height="0.1" />
      </YarnSection>
      <MasterNode Position="0, 0, 0" />
      <MasterNode Position="1, zero, 0" Up="0, 0" />
      <MasterNode Tangent="1, 0, 0" />
    </Yarn>
    <Yarn index="1">
      <YarnSection type="CYarnSectionConstant">
        <Section type="CSectionPolygon" />
      </YarnSection>
      <MasterNode Position="0, 0, 0" />
    </Yarn>
    <Yarn index="2">
      <YarnSection type="CYarnSectionConstant">
        <Section type="CSectionEllipse" Width="0.8" Height="0.1" />
      </YarnSection>
      <MasterNode Position="0, 0, 0" />
      <MasterNode Position="0, 0, 1" />
    </Yarn>
    <Yarn index="3">
      <YarnSection type="CYarnSectionConstant">
        <Section type="CSectionEllipse" Width="0.8" Height="0.1" />
      </YarnSection>
      <MasterNode Position="0, 0, 0" />
      <MasterNode Position="5, 0, 0" />
    </Yarn>
  </Textile>
</TexGenModel>
)";
  const std::string vector = "3 numbers \"x, y, z\" separated by commas";
  expect_messages(
      errors_of(text),
      {"bad.tg3:3:70: <Textile> attribute 'GeometryScale': expected \"mm\", \"cm\", \"m\", "
       "\"um\" or \"in\", found \"furlong\"",
       "bad.tg3:5:32: <Interpolation> attribute 'Periodic': expected 0 or 1, found \"maybe\"",
       "bad.tg3:7:48: <Section> attribute 'Width': expected a number > 0, found \"-0.8\"",
       "bad.tg3:10:29: <MasterNode> attribute 'Position': expected " + vector +
           ", found \"1, zero, 0\"",
       "bad.tg3:10:45: <MasterNode> attribute 'Up': expected " + vector + ", found \"0, 0\"",
       "bad.tg3:11:7: <MasterNode>: missing attribute 'Position' (" + vector + ")",
       "bad.tg3:13:5: yarn 1: expected at least 2 <MasterNode>, found 1",
       "bad.tg3:15:24: <Section> attribute 'type': expected a supported section type "
       "(CSectionEllipse, CSectionLenticular, CSectionPowerEllipse, CSectionRectangle), found "
       "\"CSectionPolygon\"",
       "bad.tg3:19:5: yarn 2: expected the yarn's ends at different in-plane points, found both "
       "at (0, 0) m (closed or through-thickness yarns are not supported)"});
}

TEST(TexGen, EveryProblemOfAWeavePatternIsReportedAtOnce) {
  // A count that is not a number: the cells and yarn data are still checked one by one.
  expect_messages(errors_of(R"(<?xml version="1.0" ?>
<TexGenModel>
  <Textile name="w" type="CTextileWeave2D" NumXYarns="2" NumYYarns="two" GapSize="0">
    <PatternCell x="0" y="0">
      <PatternElement value="0" />
      <PatternElement value="3" />
    </PatternCell>
    <PatternCell x="1" y="2">
      <PatternElement value="1" />
    </PatternCell>
    <XYarnData index="0" Width="4" Height="0" Spacing="5" />
    <XYarnData index="1" Width="4" Height="0.8" Spacing="5" />
    <YYarnData index="0" Width="4" Height="0.8" />
  </Textile>
</TexGenModel>
)"),
                  {"bad.tg3:3:69: <Textile> attribute 'NumYYarns': expected an integer in [1, "
                   "10000], found \"two\"",
                   "bad.tg3:6:30: <PatternElement> attribute 'value': expected 0 (Y yarn), 1 (X "
                   "yarn) or 2 (none), found \"3\"",
                   "bad.tg3:8:27: <PatternCell> attribute 'y': expected an integer in [0, 2) "
                   "(NumXYarns), found \"2\"",
                   "bad.tg3:11:44: <XYarnData> attribute 'Height': expected a number > 0, found "
                   "\"0\"",
                   "bad.tg3:13:5: <YYarnData>: missing attribute 'Spacing' (a number > 0)"});
  // Cells and yarn data given twice, and what is then missing.
  expect_messages(errors_of(R"(<?xml version="1.0" ?>
<TexGenModel>
  <Textile name="w" type="CTextileWeave2D" NumXYarns="1" NumYYarns="2">
    <PatternCell x="0" y="0">
      <PatternElement value="0" />
      <PatternElement value="1" />
    </PatternCell>
    <PatternCell x="0" y="0">
      <PatternElement value="1" />
      <PatternElement value="0" />
    </PatternCell>
    <XYarnData index="0" Width="4" Height="0.8" Spacing="5" />
    <YYarnData index="0" Width="4" Height="0.8" Spacing="5" />
    <YYarnData index="0" Width="4" Height="0.8" Spacing="5" />
  </Textile>
</TexGenModel>
)"),
                  {"bad.tg3:3:3: expected a <YYarnData index=\"1\">, found none",
                   "bad.tg3:3:3: expected a <PatternCell x=\"1\" y=\"0\">, found none",
                   "bad.tg3:8:5: expected each <PatternCell> once, found x=\"0\" y=\"0\" again "
                   "(first at line 4)",
                   "bad.tg3:14:23: <YYarnData> attribute 'index': expected each index once, "
                   "found 0 again"});
  // More cells in the pattern than in the file: one problem, not one per cell.
  expect_messages(errors_of(R"(<?xml version="1.0" ?>
<TexGenModel>
  <Textile name="w" type="CTextileWeave2D" NumXYarns="1" NumYYarns="10000">
    <PatternCell x="0" y="0"><PatternElement value="1" /></PatternCell>
    <XYarnData index="0" Width="4" Height="0.8" Spacing="5" />
  </Textile>
</TexGenModel>
)"),
                  {"bad.tg3:3:3: expected a <YYarnData> for each of the 10000 Y yarns "
                   "(NumYYarns), found 0",
                   "bad.tg3:3:3: expected a <PatternCell> for each of the 10000 x 1 cells "
                   "(NumYYarns x NumXYarns), found 1"});
}

} // namespace
} // namespace yarnsim::textile
