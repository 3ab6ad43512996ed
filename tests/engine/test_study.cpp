// Study decks (engine/study/study.hpp): the examples read, `paths` gives one run per integration
// path, bad paths are reported all at once. Running a biaxial study (plots, summary.csv) is
// checked end to end by tests/cli/study.sh; a small study of a picture frame and a uniaxial
// tension runs here: its curve files, summaries, plots and the local shear angles of the deformed
// specimen's picture (engine/study/test_outputs.hpp, shear_stages.hpp).
#include "engine/input/read_deck.hpp"
#include "engine/model/deck.hpp"
#include "engine/study/plots.hpp"
#include "engine/study/shear_stages.hpp"
#include "engine/study/study.hpp"
#include "engine/study/test_outputs.hpp"
#include "engine/textile/shear_tests.hpp"

#include <cmath>
#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <gtest/gtest.h>
#include <limits>
#include <map>
#include <numbers>
#include <sstream>
#include <unistd.h>

namespace yarnsim {
namespace {

const std::filesystem::path kExamples = std::filesystem::path(YARNSIM_SOURCE_DIR) / "examples";

TEST(Study, ExampleStudiesRead) {
  for (const char* file : {"biaxial-study.toml", "biaxial-k1-study.toml",
                           "biaxial-k1-explicit-study.toml", "shear-study.toml"}) {
    const Study s = read_study(kExamples / file);
    ASSERT_FALSE(s.cases.empty()) << file;
    for (const StudyCase& c : s.cases)
      EXPECT_TRUE(std::filesystem::exists(c.deck)) << file << ": " << c.deck;
  }
  const Study plain = read_study(kExamples / "biaxial-k1-study.toml");
  EXPECT_EQ(plain.cases[0].paths, std::vector<StudyPath>{StudyPath::Deck});
  const Study both = read_study(kExamples / "biaxial-k1-explicit-study.toml");
  ASSERT_EQ(both.cases.size(), 1u);
  EXPECT_EQ(both.cases[0].paths,
            (std::vector<StudyPath>{StudyPath::Implicit, StudyPath::Explicit}));
  EXPECT_EQ(both.cases[0].deck.filename(), "biaxial-k1-explicit.toml");
  EXPECT_EQ(plain.cases[0].test, StudyTest::Biaxial);
  EXPECT_EQ(plain.title, "Plain-woven glass fabric");
  // Each case's test is its deck's test block.
  const Study shear = read_study(kExamples / "shear-study.toml");
  ASSERT_EQ(shear.cases.size(), 3u);
  EXPECT_EQ(shear.cases[0].test, StudyTest::PictureFrame);
  EXPECT_EQ(shear.cases[1].test, StudyTest::Uniaxial);
  EXPECT_EQ(shear.cases[2].test, StudyTest::BiasExtension);
}

TEST(Study, PathsAreCheckedAllAtOnce) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "yarnsim-test-study";
  std::filesystem::create_directories(dir);
  const std::filesystem::path file = dir / "study.toml";
  { // Absolute deck paths: the study file's folder / an absolute path is that path.
    std::ofstream out(file);
    out << "[[cases]]\nname = \"a\"\ndeck = \"" << (kExamples / "biaxial-k1.toml").string()
        << "\"\npaths = \"explicit\"\n\n[[cases]]\nname = \"b\"\ndeck = \""
        << (kExamples / "biaxial-k1.toml").string()
        << "\"\npaths = [\"implicit\", \"implict\", \"implicit\"]\n\n[[cases]]\nname = \"c\"\n"
           "deck = \""
        << (kExamples / "biaxial-k1.toml").string() << "\"\npaths = []\n";
  }
  try {
    read_study(file);
    FAIL() << "bad paths accepted";
  } catch (const InputError& e) {
    ASSERT_EQ(e.messages().size(), 3u) << e.what();
    EXPECT_NE(e.messages()[0].find("cases[1].paths[1]: expected \"implicit\" or \"explicit\", "
                                   "found \"implict\""),
              std::string::npos)
        << e.messages()[0];
    EXPECT_NE(e.messages()[1].find("cases[1].paths[2]: \"implicit\" is listed twice"),
              std::string::npos)
        << e.messages()[1];
    EXPECT_NE(e.messages()[2].find("cases[2].paths: expected a string or an array of strings, "
                                   "found an empty array"),
              std::string::npos)
        << e.messages()[2];
  }
  std::filesystem::remove_all(dir);
}

TEST(Study, CaseDecksWithoutOneTestBlockAreReportedWhenTheStudyIsRead) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / "yarnsim-test-study-decks";
  std::filesystem::create_directories(dir);
  { // A model deck (no [fabric], no test), a fabric deck with two tests, a syntax error.
    std::ofstream(dir / "model.toml") << "title = \"beams\"\n";
    std::ofstream(dir / "two.toml") << "[fabric]\n[biaxial]\nstrain_ratio = 1\n[uniaxial]\n";
    std::ofstream(dir / "broken.toml") << "[fabric\n";
    std::ofstream(dir / "study.toml")
        << "[[cases]]\nname = \"a\"\ndeck = \"model.toml\"\n\n[[cases]]\nname = \"b\"\ndeck = "
           "\"two.toml\"\n\n[[cases]]\nname = \"c\"\ndeck = \"broken.toml\"\n";
  }
  try {
    read_study(dir / "study.toml");
    FAIL() << "decks without one test block accepted";
  } catch (const InputError& e) {
    ASSERT_EQ(e.messages().size(), 3u) << e.what();
    EXPECT_NE(e.messages()[0].find("cases[0].deck: expected a fabric deck with a test block "
                                   "([biaxial], [uniaxial], [picture_frame] or "
                                   "[bias_extension]), found none in "),
              std::string::npos)
        << e.messages()[0];
    EXPECT_NE(e.messages()[1].find("cases[1].deck: expected a fabric deck with one test block, "
                                   "found [biaxial] and [uniaxial] in "),
              std::string::npos)
        << e.messages()[1];
    EXPECT_NE(e.messages()[2].find("cases[2].deck: cannot read the case's deck: "),
              std::string::npos)
        << e.messages()[2];
    EXPECT_NE(e.messages()[2].find("broken.toml:1:"), std::string::npos) << e.messages()[2];
  }
  std::filesystem::remove_all(dir);
}

TEST(Study, StagesAreTheOutputStepsAtFractionsOfTheRun) {
  EXPECT_EQ(stage_step(0.25, 102), 25); // ceil(25.5) - 1
  EXPECT_EQ(stage_step(0.5, 102), 50);
  EXPECT_EQ(stage_step(0.75, 102), 76); // ceil(76.5) - 1
  EXPECT_EQ(stage_step(1.0, 102), 101); // the last
  EXPECT_EQ(stage_step(0.3, 10), 2);    // 0.3 x 10 is 3.0000000000000004
  for (const double f : kStages)
    EXPECT_EQ(stage_step(f, 1), 0);
  EXPECT_THROW(stage_step(0.0, 4), std::invalid_argument);
  EXPECT_THROW(stage_step(1.5, 4), std::invalid_argument);
  EXPECT_THROW(stage_step(0.5, 0), std::invalid_argument);
}

TEST(Study, LineGraphsLeaveOutPointsThatAreNotNumbers) {
  // The bias extension's normalised shear force is NaN at repeated angles: those rows are left
  // out of the data, and the line joins their neighbours.
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "yarnsim-test-plots";
  std::filesystem::create_directories(dir);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  plots::Graph g{"", "ideal angle [deg]", "normalised shear force [N/m]", {}, "y = x"};
  g.curves.push_back({"run", {0, 1, 1, 2, 3}, {nan, 5, nan, 7, 9}, 0, false, 2.5});
  plots::line_graphs({g}, "NaN rows", dir / "nan.png");
  EXPECT_TRUE(std::filesystem::file_size(dir / "nan.png") > 0);
  std::ifstream in(dir / "nan.dat");
  std::vector<std::string> data;
  for (std::string line; std::getline(in, line);)
    if (!line.empty() && line[0] != '#')
      data.push_back(line);
  // The curve's three finite points, then y = x over its x range.
  EXPECT_EQ(data, (std::vector<std::string>{"1 5", "2 7", "3 9", "1 1", "3 3"}));
  // A graph with nothing to draw is refused.
  plots::Graph empty{"", "x", "y", {{"run", {nan}, {1}, 0, false, 2.5}}, ""};
  EXPECT_THROW(plots::line_graphs({empty}, "nothing", dir / "empty.png"), std::invalid_argument);
  std::filesystem::remove_all(dir);
}

/// test_picture_frame.cpp's 4 x 4 frame (clamped, static) sheared to 10 degrees, and a 3 x 3
/// uniaxial tension of the same yarn to 0.5 %: each runs in about a second.
constexpr std::string_view kFrameDeck = R"(title = "frame"
[fabric]
n_warp = 4
n_weft = 4
spacing_warp = 4e-3
spacing_weft = 4e-3
length_warp = 20e-3
length_weft = 20e-3
gap = 0.1e-3
a = 1e-3
b = 0.3e-3
E = 3.7e10
nu = 0.2
density = 2540.0

[picture_frame]
max_angle = 10
ends = "clamped"
type = "static"
)";

constexpr std::string_view kUniaxialDeck = R"(title = "uniaxial"
[fabric]
n_warp = 3
n_weft = 3
spacing_warp = 4e-3
spacing_weft = 4e-3
length_warp = 12e-3
length_weft = 12e-3
gap = 0.1e-3
a = 1e-3
b = 0.3e-3
E = 3.7e10
nu = 0.2
density = 2540.0

[uniaxial]
direction = "warp"
max_strain = 0.005
type = "dynamic"
)";

/// A CSV file as text: header and rows of cells (no quoted commas: the labels below have none).
struct Csv {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
};

std::vector<std::string> cells_of(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream s(line);
  for (std::string c; std::getline(s, c, ',');)
    cells.push_back(c);
  if (!line.empty() && line.back() == ',')
    cells.emplace_back();
  return cells;
}

Csv read_csv(const std::filesystem::path& file) {
  std::ifstream in(file);
  Csv csv;
  std::string line;
  if (std::getline(in, line))
    csv.header = cells_of(line);
  while (std::getline(in, line))
    csv.rows.push_back(cells_of(line));
  return csv;
}

std::size_t column(const Csv& csv, const std::string& name) {
  const auto it = std::find(csv.header.begin(), csv.header.end(), name);
  EXPECT_NE(it, csv.header.end()) << name;
  return static_cast<std::size_t>(it - csv.header.begin());
}

/// The small study, run once for the tests below.
class ShearAndUniaxialStudy : public ::testing::Test {
protected:
  static void SetUpTestSuite() {
    // One folder per process: ctest runs each test of the suite in a process of its own, in
    // parallel.
    dir_ = std::filesystem::temp_directory_path() /
           fmt::format("yarnsim-test-shear-study-{}", ::getpid());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    std::ofstream(dir_ / "frame.toml") << kFrameDeck;
    std::ofstream(dir_ / "uniaxial.toml") << kUniaxialDeck;
    std::ofstream(dir_ / "study.toml")
        << "contact_maps = [\"frame\"]\n\n[[cases]]\nname = \"frame\"\nlabel = \"Frame\"\ndeck = "
           "\"frame.toml\"\n\n[[cases]]\nname = \"warp\"\nlabel = \"Warp pulled\"\ndeck = "
           "\"uniaxial.toml\"\n";
    study_ = read_study(dir_ / "study.toml");
    StudyOptions options;
    options.output_dir = dir_ / "out";
    options.progress = false;
    outcome_ = run_study(study_, options);
  }
  static void TearDownTestSuite() { std::filesystem::remove_all(dir_); }

  static std::filesystem::path out(const std::string& file) { return dir_ / "out" / file; }

  static inline std::filesystem::path dir_;
  static inline Study study_;
  static inline StudyOutcome outcome_;
};

TEST_F(ShearAndUniaxialStudy, WritesTheFilesOfEachTestAndNoBiaxialOnes) {
  EXPECT_EQ(study_.title, "Fabric study"); // none given, and not only biaxial cases
  EXPECT_EQ(outcome_.completed, 2);
  EXPECT_TRUE(outcome_.failures.empty());
  for (const char* f :
       {"curves-picture_frame.csv", "summary-picture_frame.csv",
        "force-displacement-picture_frame.png", "force-displacement-picture_frame.gp",
        "shear-picture_frame.png", "angle-picture_frame.png", "deformed-frame.png",
        "deformed-frame.gp", "contact-forces-frame.png", "curves-uniaxial.csv",
        "summary-uniaxial.csv", "uniaxial.png", "uniaxial.gp"}) {
    ASSERT_TRUE(std::filesystem::exists(out(f))) << f;
    EXPECT_GT(std::filesystem::file_size(out(f)), 0u) << f;
  }
  // The biaxial files only come with biaxial cases.
  EXPECT_FALSE(std::filesystem::exists(out("curves.csv")));
  EXPECT_FALSE(std::filesystem::exists(out("summary.csv")));
  EXPECT_EQ(outcome_.curves, (std::vector<std::filesystem::path>{out("curves-picture_frame.csv"),
                                                                 out("curves-uniaxial.csv")}));
  EXPECT_EQ(outcome_.plots.size(), 6u); // four of the frame, the uniaxial one, the contact map
  // Legends: label, wall time and increments; against the measured angle dashed.
  std::ifstream gp(out("shear-picture_frame.gp"));
  const std::string script((std::istreambuf_iterator<char>(gp)), std::istreambuf_iterator<char>());
  EXPECT_NE(script.find("increments), against the frame angle\""), std::string::npos) << script;
  EXPECT_NE(script.find("dt 2 lc rgb '#1f77b4' title \"Frame ("), std::string::npos) << script;
}

TEST_F(ShearAndUniaxialStudy, LongFormatCurvesHoldEveryRowOfEachRunWithTheTestsColumns) {
  struct Expected {
    std::string file, case_name, run_curves, lead;
    StudyTest test;
  };
  for (const Expected& e : {Expected{"curves-picture_frame.csv", "frame", "frame/curves.csv",
                                     "case,label,path", StudyTest::PictureFrame},
                            Expected{"curves-uniaxial.csv", "warp", "warp/curves.csv",
                                     "case,label,path,direction", StudyTest::Uniaxial}}) {
    const Csv all = read_csv(out(e.file));
    std::vector<std::string> header = cells_of(e.lead + ",time [s]");
    for (const std::string& c : test_curve_columns(e.test))
      header.push_back(c);
    EXPECT_EQ(all.header, header) << e.file;
    // One row per increment and the initial one, each cell as the run wrote it.
    const Csv run = read_csv(out(e.run_curves));
    const Csv summary = read_csv(out(
        e.file == "curves-uniaxial.csv" ? "summary-uniaxial.csv" : "summary-picture_frame.csv"));
    ASSERT_EQ(summary.rows.size(), 1u);
    const int increments = std::stoi(summary.rows[0][column(summary, "increments [-]")]);
    EXPECT_GT(increments, 10);
    ASSERT_EQ(all.rows.size(), static_cast<std::size_t>(increments) + 1) << e.file;
    ASSERT_EQ(run.rows.size(), all.rows.size());
    const std::size_t lead = cells_of(e.lead).size();
    for (std::size_t r = 0; r < all.rows.size(); ++r) {
      ASSERT_EQ(all.rows[r].size(), header.size()) << e.file << " row " << r + 1;
      EXPECT_EQ(all.rows[r][0], e.case_name);
      EXPECT_EQ(all.rows[r][2], "implicit");
      for (std::size_t c = lead; c < header.size(); ++c) {
        const auto it = std::find(run.header.begin(), run.header.end(), header[c]);
        // A column this run does not write (friction) is empty.
        const std::string expected =
            it == run.header.end() ? ""
                                   : run.rows[r][static_cast<std::size_t>(it - run.header.begin())];
        EXPECT_EQ(all.rows[r][c], expected) << e.file << " row " << r + 1 << ", " << header[c];
      }
    }
    if (e.test == StudyTest::Uniaxial) {
      EXPECT_EQ(all.rows[0][3], "warp");
    }
  }
  // The uniaxial summary: the pulled direction's strain at the end, the free one contracted.
  const Csv summary = read_csv(out("summary-uniaxial.csv"));
  EXPECT_NEAR(std::stod(summary.rows[0][column(summary, "strain_end [-]")]), 0.005, 1e-9);
  EXPECT_LT(std::stod(summary.rows[0][column(summary, "strain_free_end [-]")]), 0);
  // The frame's summary: the frame angle at the end, the deviation up to 30 degrees is the
  // largest of its curve.
  const Csv frame = read_csv(out("summary-picture_frame.csv"));
  EXPECT_NEAR(std::stod(frame.rows[0][column(frame, "frame_angle_end [deg]")]), 10, 1e-9);
  const Csv curves = read_csv(out("curves-picture_frame.csv"));
  double deviation = 0;
  for (const auto& row : curves.rows)
    deviation =
        std::max(deviation, std::abs(std::stod(row[column(curves, "measured_angle [deg]")]) -
                                     std::stod(row[column(curves, "frame_angle [deg]")])));
  EXPECT_NEAR(std::stod(frame.rows[0][column(frame, "max_angle_deviation_to_30deg [deg]")]),
              deviation, 1e-5 * deviation);
}

TEST_F(ShearAndUniaxialStudy, DeformedPictureColoursTheLocalAnglesWhoseCentralMeanIsMeasured) {
  const Model model = read_deck(dir_ / "frame.toml");
  const PictureFrameTest& frame = *model.picture_frame;
  // Every crossing of the 4 x 4 fabric; the central ones among them.
  ASSERT_EQ(frame.all.size(), 16u);
  ASSERT_FALSE(frame.central.empty());
  std::vector<std::size_t> central;
  for (const CrossingNodes& c : frame.central) {
    const auto it = std::find_if(frame.all.begin(), frame.all.end(), [&](const CrossingNodes& a) {
      return a.warp == c.warp && a.weft == c.weft;
    });
    ASSERT_NE(it, frame.all.end());
    central.push_back(static_cast<std::size_t>(it - frame.all.begin()));
  }
  const std::vector<ShearStage> stages = read_shear_stages(model, out("frame/results.h5"), kStages);
  ASSERT_EQ(stages.size(), 4u);
  // The run's curves, by time: measured_angle as the run wrote it.
  const Csv curves = read_csv(out("frame/curves.csv"));
  std::map<std::string, std::string> measured_at;
  for (const auto& row : curves.rows)
    measured_at[row[column(curves, "time [s]")]] = row[column(curves, "measured_angle [deg]")];
  const int steps = static_cast<int>(curves.rows.size()) - 1; // an output step per increment
  for (const ShearStage& s : stages) {
    EXPECT_EQ(s.step, stage_step(s.fraction, steps));
    EXPECT_EQ(s.increment, s.step + 1);
    ASSERT_EQ(s.shear.size(), frame.all.size());
    ASSERT_EQ(s.crossings.cols(), 16);
    // The mean of the local angles over the central crossings is measure_shear's, bit for bit,
    // and the measured_angle of curves.csv at that time.
    double sum = 0;
    for (const std::size_t k : central)
      sum += s.shear[k];
    const double mean = sum / static_cast<double>(central.size());
    EXPECT_EQ(mean, textile::measure_shear(frame.central, s.positions).mean);
    EXPECT_EQ(mean, s.measured);
    const auto it = measured_at.find(fmt::format("{}", s.time));
    ASSERT_NE(it, measured_at.end()) << s.time;
    EXPECT_EQ(mean, std::stod(it->second)) << s.time;
    // The frame angle of the step, in degrees.
    EXPECT_NEAR(s.test_angle, frame.angle.at(s.time) * 180 / std::numbers::pi, 1e-9);
  }
  // At the end the frame is sheared: the central crossings closed by more than half of it.
  EXPECT_GT(stages.back().measured, 5);
  // The picture's data: a block of 16 crossings per stage, coloured by those angles.
  std::ifstream in(out("deformed-frame-points.dat"));
  std::vector<std::vector<double>> blocks(1);
  int blank = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.empty()) {
      if (++blank == 2 && !blocks.back().empty())
        blocks.emplace_back();
      continue;
    }
    blank = 0;
    if (line[0] == '#')
      continue;
    double x = 0, y = 0, value = 0;
    std::istringstream(line) >> x >> y >> value;
    blocks.back().push_back(value);
  }
  if (blocks.back().empty())
    blocks.pop_back();
  ASSERT_EQ(blocks.size(), 4u);
  for (std::size_t k = 0; k < 4; ++k) {
    ASSERT_EQ(blocks[k].size(), 16u);
    for (std::size_t i = 0; i < 16; ++i)
      EXPECT_NEAR(blocks[k][i], stages[k].shear[i], 1e-8 * (1 + std::abs(stages[k].shear[i])));
  }
}

} // namespace
} // namespace yarnsim
