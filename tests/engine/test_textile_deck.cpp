// Fabric decks (engine/textile/fabric_deck.hpp through read_deck) and the study's examples.

#include "deck_errors.hpp"
#include "engine/input/read_deck.hpp"
#include "engine/textile/biaxial.hpp"
#include "engine/textile/loading.hpp"
#include "engine/textile/weave.hpp"

#include <algorithm>
#include <filesystem>
#include <gtest/gtest.h>
#include <string>

namespace yarnsim {
namespace {

const std::filesystem::path kExamples = std::filesystem::path(YARNSIM_SOURCE_DIR) / "examples";

std::vector<std::string> errors_of(std::string_view deck) {
  return test::errors_of(deck, "fabric.toml");
}
using test::joined;

constexpr std::string_view kValid = R"(title = "small fabric"
[fabric]
pattern = [[1, 0], [0, 1]]
n_warp = 3
n_weft = 4
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

[biaxial]
strain_ratio = 2.0
type = "static"
)";

std::string with(std::string_view from, std::string_view to) {
  return test::with(kValid, from, to);
}

TEST(FabricDeck, SmallDeckBuildsTheWeaveAndTheTest) {
  const Model m = read_deck_string(kValid, "fabric.toml");
  EXPECT_EQ(m.title, "small fabric");
  EXPECT_EQ(m.splines.size(), 7u);
  ASSERT_EQ(m.spline_contacts.size(), 1u);
  EXPECT_DOUBLE_EQ(m.spline_contacts[0].law.penalty, 1.5e6); // default: the paper's
  EXPECT_EQ(m.spline_contacts[0].law.regularisation, 0.0);
  const Model regularised =
      read_deck_string(std::string(kValid) + "[contact]\nregularisation = 2e-6\n", "fabric.toml");
  EXPECT_EQ(regularised.spline_contacts[0].law.regularisation, 2e-6);
  ASSERT_TRUE(m.biaxial.has_value());
  EXPECT_EQ(m.biaxial->strain_ratio, 2.0);
  EXPECT_EQ(m.biaxial->warp_start.size(), 3u);
  EXPECT_EQ(m.biaxial->weft_start.size(), 4u);
  ASSERT_EQ(m.steps.size(), 1u);
  EXPECT_EQ(m.steps[0].type, StepType::Static);
  // 25 mm warp = 3 spacings between 4 crossings + 2 x 5 mm of straight end (4 elements each).
  const int warp0 = m.find_node_set("warp0");
  ASSERT_GE(warp0, 0);
  EXPECT_EQ(m.node_sets[static_cast<std::size_t>(warp0)].nodes.size(), 2u * (3 * 4 + 2 * 4) + 1);
}

TEST(FabricDeck, MinimalDeckTakesTheDefaults) {
  // The deck of docs/input.md, "Fabric decks".
  const Model m = read_deck_string(R"(title = "Biaxial tension of a plain weave, k = 2"

[fabric]
pattern = "plain"
spacing_warp = 4.54545e-3
spacing_weft = 4.54545e-3
length_warp = 40.90909e-3
length_weft = 40.90909e-3
gap = 0.11364e-3
a = 1.136364e-3
b = 0.2840909e-3
EA = 38000.0
nu = 0.2
density = 2540.0

[contact]
penalty = 1.5e6

[biaxial]
strain_ratio = 2.0
)",
                                   "fabric.toml");
  textile::Fabric expected = textile::build_weave(textile::paper_fabric());
  textile::BiaxialParameters b;
  b.strain_ratio = 2;
  textile::add_biaxial_test(expected, b);
  ASSERT_EQ(m.nodes.size(), expected.model.nodes.size());
  for (std::size_t i = 0; i < m.nodes.size(); ++i)
    EXPECT_EQ(m.nodes[i], expected.model.nodes[i]);
  EXPECT_EQ(m.steps[0].type, StepType::Dynamic);
  EXPECT_EQ(m.steps[0].dt_initial, 0.01);
  EXPECT_EQ(m.monitors.size(), 2u);
}

TEST(FabricDeck, ContactFrictionReachesTheWarpWeftContact) {
  const Model frictionless = read_deck_string(kValid, "fabric.toml");
  ASSERT_EQ(frictionless.spline_contacts.size(), 1u);
  EXPECT_FALSE(frictionless.spline_contacts[0].friction.active());
  const Model m = read_deck_string(std::string(kValid) + "[contact]\npenalty = 2e6\n"
                                                         "static_friction = 0.3\n"
                                                         "kinetic_friction = 0.2\n",
                                   "fabric.toml");
  ASSERT_EQ(m.spline_contacts.size(), 1u);
  const FrictionParameters& f = m.spline_contacts[0].friction;
  EXPECT_DOUBLE_EQ(f.mu_static, 0.3);
  EXPECT_DOUBLE_EQ(f.mu_kinetic, 0.2);
  EXPECT_DOUBLE_EQ(f.tangential_penalty, 2e6); // the linear law's penalty
  EXPECT_FALSE(f.torsional);
  // Torsional friction: the footprint is the yarns' widths, 2 a (Spline::width).
  const Model t = read_deck_string(std::string(kValid) + "[contact]\nfriction = 0.2\n"
                                                         "torsional_friction = true\n",
                                   "fabric.toml");
  EXPECT_TRUE(t.spline_contacts[0].friction.torsional);
  for (const Spline& s : t.splines) {
    const int element = [&] {
      for (std::size_t e = 0; e < t.elements.size(); ++e)
        if (t.elements[e].nodes[0] == s.nodes[0])
          return static_cast<int>(e);
      return -1;
    }();
    ASSERT_GE(element, 0) << s.name;
    EXPECT_DOUBLE_EQ(s.width, 2 * t.sections[t.elements[element].section].a) << s.name;
    EXPECT_GT(s.width, 2 * s.radius) << s.name; // flat yarns: wider than the contact circle
  }
  // Surface contact: pointwise friction, its tangential damping and torsional friction reach its
  // definition.
  const Model surface = read_deck_string(
      std::string(kValid) + "[contact]\ntype = \"surface\"\nfriction = 0.2\n", "fabric.toml");
  ASSERT_EQ(surface.surface_contacts.size(), 1u);
  EXPECT_DOUBLE_EQ(surface.surface_contacts[0].friction.mu_static, 0.2);
  EXPECT_DOUBLE_EQ(surface.surface_contacts[0].friction.tangential_penalty,
                   surface.surface_contacts[0].law.penalty);
  const Model twisted =
      read_deck_string(std::string(kValid) + "[contact]\ntype = \"surface\"\nfriction = 0.2\n"
                                             "torsional_friction = true\ntorsional_radius = 3e-4\n",
                       "fabric.toml");
  ASSERT_EQ(twisted.surface_contacts.size(), 1u);
  EXPECT_TRUE(twisted.surface_contacts[0].friction.torsional);
  EXPECT_DOUBLE_EQ(twisted.surface_contacts[0].friction.torsional_radius, 3e-4);
  // Tangential damping: on dynamic tests only, as on the spline contact.
  const auto e = errors_of(std::string(kValid) + "[contact]\ntype = \"surface\"\nfriction = 0.2\n"
                                                 "tangential_damping = 1.0\n");
  ASSERT_EQ(e.size(), 1u) << joined(e);
  EXPECT_NE(e[0].find("contact.tangential_damping: contact damping acts on the velocities of "
                      "dynamic steps"),
            std::string::npos)
      << e[0];
  // On the explicit path too (its energy balance counts the dissipation); its contact damping
  // is refused at the key.
  const Model x = read_deck_string(with("type = \"static\"", "type = \"explicit\"") +
                                       "[contact]\nfriction = 0.2\n",
                                   "fabric.toml");
  ASSERT_EQ(x.steps.back().type, StepType::Explicit);
  EXPECT_DOUBLE_EQ(x.spline_contacts[0].friction.mu_static, 0.2);
  const auto xd = errors_of(with("type = \"static\"", "type = \"explicit\"") +
                            "[contact]\nfriction = 0.2\ntangential_damping = 1\n");
  ASSERT_EQ(xd.size(), 1u) << joined(xd);
  EXPECT_NE(xd[0].find("contact.tangential_damping: contact damping is not available on the "
                       "explicit path"),
            std::string::npos)
      << xd[0];
  // An elastic slip reaches every definition (the same direction's too) in place of the
  // penalty; not on the explicit path.
  const Model es = read_deck_string(std::string(kValid) + "[contact]\nfriction = 0.2\n"
                                                          "elastic_slip = 1e-5\n"
                                                          "same_direction = true\n",
                                    "fabric.toml");
  ASSERT_EQ(es.spline_contacts.size(), 3u);
  for (const SplineContactDefinition& c : es.spline_contacts) {
    EXPECT_DOUBLE_EQ(c.friction.elastic_slip, 1e-5) << c.name;
    EXPECT_EQ(c.friction.tangential_penalty, 0.0) << c.name;
  }
  const auto xe = errors_of(with("type = \"static\"", "type = \"explicit\"") +
                            "[contact]\nfriction = 0.2\nelastic_slip = 1e-5\n");
  ASSERT_EQ(xe.size(), 1u) << joined(xe);
  EXPECT_NE(xe[0].find("contact.elastic_slip: 'elastic_slip' is not available on the explicit "
                       "path"),
            std::string::npos)
      << xe[0];
}

TEST(FabricDeck, SameDirectionContactAddsWarpWarpAndWeftWeft) {
  const Model m = read_deck_string(std::string(kValid) + "[contact]\nsame_direction = true\n"
                                                         "friction = 0.2\n",
                                   "fabric.toml");
  ASSERT_EQ(m.spline_contacts.size(), 3u);
  const SplineContactDefinition& cross = m.spline_contacts[0];
  EXPECT_EQ(cross.name, "warp-weft");
  for (int k : {1, 2}) {
    const SplineContactDefinition& c = m.spline_contacts[k];
    const std::string direction = k == 1 ? "warp" : "weft";
    EXPECT_EQ(c.name, direction + "-" + direction);
    EXPECT_TRUE(c.self_contact);
    EXPECT_FALSE(c.within_spline); // between different yarns only
    EXPECT_TRUE(c.group_b.empty());
    EXPECT_EQ(c.group_a.size(), (k == 1 ? cross.group_a : cross.group_b).size());
    for (int s : c.group_a)
      EXPECT_EQ(m.splines[s].name.rfind(direction, 0), 0u) << m.splines[s].name;
    EXPECT_EQ(c.law.penalty, cross.law.penalty);
    EXPECT_DOUBLE_EQ(c.friction.mu_static, 0.2); // the deck's friction on all three
    // Side by side, across the width: the in-plane semi-axis a, not the spline's radius b.
    EXPECT_DOUBLE_EQ(c.radius, 1e-3);
    EXPECT_DOUBLE_EQ(c.margin, cross.margin);
  }
  // Spline contact only: said at the key.
  const auto e =
      errors_of(std::string(kValid) + "[contact]\ntype = \"surface\"\nsame_direction = true\n");
  ASSERT_EQ(e.size(), 1u) << joined(e);
  EXPECT_NE(e[0].find("contact.same_direction: 'same_direction' applies only to type = "
                      "\"spline\""),
            std::string::npos)
      << e[0];
}

TEST(FabricDeck, ExamplesAreThePapersStudy) {
  for (auto [file, k] : {std::pair{"biaxial-k1.toml", 1.0}, std::pair{"biaxial-k2.toml", 2.0},
                         std::pair{"biaxial-k0.5.toml", 0.5}}) {
    const Model m = read_deck(kExamples / file);
    textile::Fabric expected = textile::build_weave(textile::paper_fabric());
    textile::BiaxialParameters b;
    b.strain_ratio = k;
    textile::add_biaxial_test(expected, b);
    const Model& e = expected.model;
    ASSERT_EQ(m.nodes.size(), e.nodes.size()) << file;
    for (std::size_t i = 0; i < m.nodes.size(); ++i)
      EXPECT_LT((m.nodes[i] - e.nodes[i]).norm(), 1e-15) << file << " node " << i;
    EXPECT_EQ(m.elements.size(), e.elements.size());
    EXPECT_NEAR(m.sections[0].EA, 38000, 1e-9);
    EXPECT_DOUBLE_EQ(m.sections[0].EI1, e.sections[0].EI1);
    EXPECT_DOUBLE_EQ(m.spline_contacts[0].law.penalty, 1.5e6);
    EXPECT_EQ(m.biaxial->strain_ratio, k);
    EXPECT_EQ(m.steps[0].type, StepType::Dynamic);
    EXPECT_EQ(m.steps[0].newmark_beta, 0.3);
    EXPECT_EQ(m.steps[0].dt_initial, e.steps[0].dt_initial);
    EXPECT_EQ(m.steps[0].dt_max, e.steps[0].dt_max);
    EXPECT_EQ(m.steps[0].dt_min, e.steps[0].dt_min);
    ASSERT_EQ(m.prescribed.size(), e.prescribed.size());
    for (std::size_t i = 0; i < m.prescribed.size(); ++i)
      for (std::size_t c = 0; c < 3; ++c)
        EXPECT_EQ(m.prescribed[i].displacement[c]->at(1.0),
                  e.prescribed[i].displacement[c]->at(1.0));
  }
}

TEST(FabricDeck, UnknownKeyIsReportedWithItsLineAndASuggestion) {
  const auto e = errors_of(with("gap = 0.1e-3", "gapp = 0.1e-3"));
  ASSERT_EQ(e.size(), 1u) << joined(e);
  EXPECT_EQ(e[0], "fabric.toml:10:1: fabric.gapp: unknown key 'gapp' in [fabric]; did you mean "
                  "'gap'?");
}

TEST(FabricDeck, UpperInertiaFactorReachesTheYarnSection) {
  // reduce_upper_inertia scales the upper moment of inertia (about axis 2 here, b < a: the
  // in-plane bending of the flat yarn) and leaves the lower one and the rest of the section.
  const Model plain = read_deck_string(kValid, "fabric.toml");
  const Model reduced = read_deck_string(
      with("density = 2540.0", "density = 2540.0\nreduce_upper_inertia = 0.01"), "fabric.toml");
  ASSERT_EQ(plain.sections.size(), 1u);
  ASSERT_EQ(reduced.sections.size(), 1u);
  const Section &p = plain.sections[0], &r = reduced.sections[0];
  EXPECT_DOUBLE_EQ(r.EI2, 0.01 * p.EI2);
  EXPECT_EQ(r.EI1, p.EI1);
  EXPECT_EQ(r.EA, p.EA);
  EXPECT_EQ(r.GJ, p.GJ);
  // Its range is the lower factor's, (0, 1].
  for (const char* bad : {"0.0", "1.5"}) {
    const auto e = errors_of(
        with("density = 2540.0", std::string("density = 2540.0\nreduce_upper_inertia = ") + bad));
    ASSERT_EQ(e.size(), 1u) << joined(e);
    EXPECT_NE(e[0].find("fabric.toml:16:24:"), std::string::npos) << e[0];
    EXPECT_NE(e[0].find("fabric.reduce_upper_inertia: expected a number in (0, 1]"),
              std::string::npos)
        << e[0];
  }
}

TEST(FabricDeck, WrongTypesAndValuesAreReportedAllAtOnce) {
  std::string deck = with("n_warp = 3", "n_warp = 3.0");
  deck.replace(deck.find("strain_ratio = 2.0"), 18, "strain_ratio = \"two\"");
  deck.replace(deck.find("[[1, 0], [0, 1]]"), 16, "[[1, 0], [0, 2]]");
  deck.replace(deck.find("type = \"static\""), 15, "type = \"statik\"");
  const auto e = errors_of(deck);
  ASSERT_EQ(e.size(), 4u) << joined(e);
  EXPECT_EQ(e[0], "fabric.toml:3:24: fabric.pattern[1][1]: expected 0 (warp under) or 1 (warp "
                  "over), found an integer (2)");
  EXPECT_EQ(e[1], "fabric.toml:4:10: fabric.n_warp: expected an integer in [1, 10000], "
                  "found a floating-point number (3.0)");
  EXPECT_EQ(e[2], "fabric.toml:18:16: biaxial.strain_ratio: expected a number > 0, found a "
                  "string \"two\"");
  EXPECT_EQ(e[3], "fabric.toml:19:8: biaxial.type: expected \"dynamic\", \"static\" or "
                  "\"explicit\", found \"statik\"; did you mean \"static\"?");
}

TEST(FabricDeck, ExplicitExampleIsTheK1ModelOnTheExplicitPath) {
  const Model x = read_deck(kExamples / "biaxial-k1-explicit.toml");
  const Model i = read_deck(kExamples / "biaxial-k1.toml");
  ASSERT_EQ(x.nodes.size(), i.nodes.size());
  for (std::size_t n = 0; n < x.nodes.size(); ++n)
    EXPECT_EQ(x.nodes[n], i.nodes[n]) << "node " << n;
  EXPECT_EQ(x.elements.size(), i.elements.size());
  EXPECT_EQ(x.spline_contacts[0].law.penalty, i.spline_contacts[0].law.penalty);
  ASSERT_EQ(x.prescribed.size(), i.prescribed.size());
  for (std::size_t n = 0; n < x.prescribed.size(); ++n)
    for (std::size_t c = 0; c < 3; ++c)
      for (double t : {0.0, 0.25, 1.0})
        EXPECT_EQ(x.prescribed[n].displacement[c]->at(t), i.prescribed[n].displacement[c]->at(t));
  ASSERT_EQ(x.steps.size(), 1u);
  const SolutionStep& s = x.steps[0];
  EXPECT_EQ(s.type, StepType::Explicit);
  EXPECT_EQ(s.end_time, 1.0);
  EXPECT_EQ(s.mass_scaling_dt, 2e-5);
  EXPECT_EQ(s.dt_initial, 2e-5);
  EXPECT_EQ(s.safety_factor, 0.8);
  EXPECT_EQ(s.output_every, 250);
  EXPECT_TRUE(s.energy_monitor);
}

TEST(FabricDeck, ExplicitTestTakesItsDefaultsAndItsTable) {
  Model m = read_deck_string(with("type = \"static\"", "type = \"explicit\""), "fabric.toml");
  ASSERT_EQ(m.steps.size(), 1u);
  EXPECT_EQ(m.steps[0].type, StepType::Explicit);
  EXPECT_DOUBLE_EQ(m.steps[0].mass_scaling_dt, 1.0 / 50000); // loading_time / 50 000
  EXPECT_EQ(m.steps[0].dt_initial, m.steps[0].mass_scaling_dt);
  EXPECT_EQ(m.steps[0].output_every, 250); // about 200 outputs
  EXPECT_EQ(m.steps[0].stable_dt_every, 100);
  m = read_deck_string(with("type = \"static\"", R"(type = "explicit"
loading_time = 0.5
explicit = { mass_scaling_dt = 1e-4, dt = 5e-5, safety_factor = 0.5, stable_dt_every = 20, output_every = 7, energy_monitor = false })"),
                       "fabric.toml");
  EXPECT_EQ(m.steps[0].end_time, 0.5);
  EXPECT_EQ(m.steps[0].mass_scaling_dt, 1e-4);
  EXPECT_EQ(m.steps[0].dt_initial, 5e-5);
  EXPECT_EQ(m.steps[0].safety_factor, 0.5);
  EXPECT_EQ(m.steps[0].stable_dt_every, 20);
  EXPECT_EQ(m.steps[0].output_every, 7);
  EXPECT_FALSE(m.steps[0].energy_monitor);
  // The table may come with an implicit test (a study runs it on both paths): unused there.
  m = read_deck_string(with("type = \"static\"", "type = \"dynamic\"\nexplicit = { dt = 1e-5 }"),
                       "fabric.toml");
  EXPECT_EQ(m.steps[0].type, StepType::Dynamic);
  EXPECT_EQ(m.steps[0].dt_initial, 0.01);
}

TEST(FabricDeck, TensionTestsAreStabilisedByDefaultAndTakeTheirRayleighTable) {
  // Dynamic tension tests get the stabilising mass-proportional damping (loading.hpp); static
  // and explicit ones none; a deck's table overrides it.
  Model m = read_deck_string(with("type = \"static\"", "type = \"dynamic\""), "fabric.toml");
  EXPECT_EQ(m.steps[0].rayleigh_mass, textile::kStabilisingDamping);
  EXPECT_EQ(m.steps[0].rayleigh_stiffness, 0.0);
  m = read_deck_string(kValid, "fabric.toml");
  EXPECT_EQ(m.steps[0].rayleigh_mass, 0.0);
  m = read_deck_string(with("type = \"static\"", "type = \"explicit\""), "fabric.toml");
  EXPECT_EQ(m.steps[0].rayleigh_mass, 0.0);
  m = read_deck_string(with("type = \"static\"", "type = \"dynamic\"\nrayleigh = { mass = 0.0 }"),
                       "fabric.toml");
  EXPECT_EQ(m.steps[0].rayleigh_mass, 0.0);
  m = read_deck_string(with("type = \"static\"",
                            "type = \"explicit\"\nrayleigh = { mass = 50.0, stiffness = 1e-7 }"),
                       "fabric.toml");
  EXPECT_EQ(m.steps[0].rayleigh_mass, 50.0);
  EXPECT_EQ(m.steps[0].rayleigh_stiffness, 1e-7);
  auto e = errors_of(with("type = \"static\"", "type = \"static\"\nrayleigh = { mass = -1.0 }"));
  ASSERT_EQ(e.size(), 2u) << joined(e);
  EXPECT_EQ(e[0], "fabric.toml:20:12: biaxial.rayleigh: 'rayleigh' damping applies only to dynamic "
                  "and explicit tests; this test is \"static\"");
  EXPECT_EQ(e[1], "fabric.toml:20:21: biaxial.rayleigh.mass: expected a number >= 0, found -1.0");
  // The out-of-plane damping: none by default on a tension test, the deck's on a dynamic one, an
  // error on an explicit one.
  EXPECT_EQ(m.steps[0].rayleigh_out_of_plane, 0.0);
  m = read_deck_string(
      with("type = \"static\"", "type = \"dynamic\"\nrayleigh = { out_of_plane = 3e4 }"),
      "fabric.toml");
  EXPECT_EQ(m.steps[0].rayleigh_out_of_plane, 3e4);
  EXPECT_EQ(m.steps[0].rayleigh_mass, textile::kStabilisingDamping);
  e = errors_of(
      with("type = \"static\"", "type = \"explicit\"\nrayleigh = { out_of_plane = 3e4 }"));
  ASSERT_EQ(e.size(), 1u) << joined(e);
  EXPECT_EQ(e[0], "fabric.toml:20:29: biaxial.rayleigh.out_of_plane: 'out_of_plane' damping "
                  "applies only to dynamic (Newmark) tests; this test is \"explicit\"");
}

TEST(FabricDeck, ImplicitKeysOnAnExplicitTestAndBadExplicitValuesAreReported) {
  auto e = errors_of(with("type = \"static\"", R"(type = "explicit"
dt = 1e-5
newmark = { beta = 0.25 }
ramp = "smoth"
explicit = { safety_factor = 1.5, mass_scaling_dt = 0.0 })"));
  ASSERT_EQ(e.size(), 5u) << joined(e);
  EXPECT_EQ(e[0], "fabric.toml:20:6: biaxial.dt: 'dt' applies only to implicit (static, dynamic) "
                  "tests; this test is \"explicit\": its step is set in [biaxial.explicit]");
  EXPECT_EQ(e[1], "fabric.toml:21:11: biaxial.newmark: 'newmark' applies only to implicit (static, "
                  "dynamic) tests; this test is \"explicit\": its step is set in "
                  "[biaxial.explicit]");
  EXPECT_EQ(e[2], "fabric.toml:22:8: biaxial.ramp: expected \"linear\" or \"smooth\", found "
                  "\"smoth\"; did you mean \"smooth\"?");
  EXPECT_EQ(e[3], "fabric.toml:23:30: biaxial.explicit.safety_factor: expected a number in (0, 1], "
                  "found 1.5");
  EXPECT_EQ(e[4], "fabric.toml:23:53: biaxial.explicit.mass_scaling_dt: without mass scaling "
                  "(mass_scaling_dt = 0) give the time step 'dt', below the stable limit");
}

TEST(FabricDeck, SmoothRampStartsAndEndsAtRest) {
  const Model lin = read_deck_string(kValid, "fabric.toml");
  const Model smooth = read_deck_string(
      with("type = \"static\"", "type = \"static\"\nramp = \"smooth\""), "fabric.toml");
  ASSERT_EQ(lin.prescribed.size(), smooth.prescribed.size());
  int moving = 0;
  for (std::size_t n = 0; n < lin.prescribed.size(); ++n)
    for (std::size_t c = 0; c < 3; ++c) {
      const TimeTable& a = *lin.prescribed[n].displacement[c];
      const TimeTable& b = *smooth.prescribed[n].displacement[c];
      const double u = a.at(1.0);
      EXPECT_EQ(b.at(1.0), u);
      EXPECT_EQ(b.at(0.0), 0.0);
      if (u == 0)
        continue;
      ++moving;
      EXPECT_NEAR(b.at(0.5), 0.5 * u, 1e-15); // s(1/2) = 1/2
      EXPECT_NEAR(b.at(0.25), (10 - 15 * 0.25 + 6 * 0.0625) * 0.015625 * u, 1e-15);
      // Rates over the first and last 1/400: the tabulated smooth step starts and ends at rest.
      EXPECT_LT(std::abs(b.at(1.0 / 400)), 1e-6 * std::abs(u));
      EXPECT_LT(std::abs(u - b.at(1 - 1.0 / 400)), 1e-6 * std::abs(u));
    }
  EXPECT_GT(moving, 0);
}

TEST(FabricDeck, MissingAndInconsistentValuesAreReported) {
  auto e = errors_of(with("E = 3.7e10\n", ""));
  ASSERT_EQ(e.size(), 1u) << joined(e);
  EXPECT_EQ(e[0], "fabric.toml:2:1: fabric: missing required key 'E' or 'EA' (a number > 0, Pa "
                  "or N)");
  e = errors_of(with("length_warp = 25e-3", "length_warp = 10e-3"));
  ASSERT_EQ(e.size(), 1u) << joined(e);
  EXPECT_NE(e[0].find("fabric.toml:8:15: fabric.length_warp: expected length_warp >= (n_weft - "
                      "1) spacing_weft = 0.015"),
            std::string::npos)
      << e[0];
  e = errors_of(with("b = 0.3e-3", "b = 0.3e-3\ncontact_radius = 0.4e-3"));
  ASSERT_EQ(e.size(), 1u) << joined(e);
  EXPECT_NE(e[0].find("fabric.contact_radius: expected contact_radius <= b + gap / 2"),
            std::string::npos)
      << e[0];
  e = errors_of(with("[biaxial]\n", "[biaxial]\ndt = 2.0\n"));
  ASSERT_EQ(e.size(), 1u) << joined(e);
  EXPECT_NE(e[0].find("biaxial.dt: expected a time step <= loading_time (1)"), std::string::npos)
      << e[0];
  // An ordinary-deck block in a fabric deck.
  e = errors_of(std::string(kValid) + "[[steps]]\ntype = \"static\"\nend_time = 1.0\ndt = 0.1\n");
  ASSERT_EQ(e.size(), 1u) << joined(e);
  EXPECT_NE(e[0].find("fabric.toml:20:3: steps: unknown key 'steps' in the top level of a fabric "
                      "deck"),
            std::string::npos)
      << e[0];
  e = errors_of(std::string(kValid) + "[contact]\nlaw = \"power\"\npenalty = 1e6\n");
  ASSERT_EQ(e.size(), 1u) << joined(e);
  EXPECT_NE(e[0].find("missing required key 'exponent'"), std::string::npos) << e[0];
  e = errors_of(std::string(kValid) +
                "[contact]\nlaw = \"power\"\nexponent = 2.0\nregularisation = 1e-6\n");
  ASSERT_EQ(e.size(), 1u) << joined(e);
  EXPECT_NE(e[0].find("contact.regularisation: 'regularisation' applies only to law = "
                      "\"linear\""),
            std::string::npos)
      << e[0];
  // [contact] is checked even when [fabric] has errors of its own.
  e = errors_of(with("a = 1e-3", "a = -1e-3") + "[contact]\nlaw = \"lineer\"\n");
  ASSERT_EQ(e.size(), 2u) << joined(e);
  EXPECT_NE(e[0].find("fabric.a: expected a number > 0, found -0.001"), std::string::npos) << e[0];
  EXPECT_NE(e[1].find("contact.law: expected \"linear\" or \"power\", found \"lineer\"; did you "
                      "mean \"linear\"?"),
            std::string::npos)
      << e[1];
}

} // namespace
} // namespace yarnsim
