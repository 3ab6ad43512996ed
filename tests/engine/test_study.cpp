// Study decks (engine/study/study.hpp): the examples read, `paths` gives one run per integration
// path, bad paths are reported all at once. Running a study (plots, summary.csv) is checked end to
// end by tests/cli/study.sh.
#include "engine/model/deck.hpp"
#include "engine/study/study.hpp"

#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>

namespace yarnsim {
namespace {

const std::filesystem::path kExamples = std::filesystem::path(YARNSIM_SOURCE_DIR) / "examples";

TEST(Study, ExampleStudiesRead) {
  for (const char* file :
       {"biaxial-study.toml", "biaxial-k1-study.toml", "biaxial-k1-explicit-study.toml"}) {
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

} // namespace
} // namespace yarnsim
