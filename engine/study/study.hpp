#pragma once
// A study: several runs (cases) of fabric decks, then the curves of all of them side by side and
// the pictures a user compares with the paper: one force-strain plot per strain ratio k (warp
// and weft, every formulation; the paper's Fig. 3) and the normal contact forces over the fabric
// (Fig. 4). Cases of the uniaxial and shear tests get their own curves, summaries and plots, and
// the shear tests the deformed specimen coloured by the local shear angle (test_outputs.hpp).
// Deck format: docs/input.md, "Study decks".

#include "engine/solver/linear_solver.hpp"

#include <atomic>
#include <filesystem>
#include <string>
#include <vector>

namespace yarnsim {

/// The test a case's fabric deck runs: its test block.
enum class StudyTest {
  Biaxial,       ///< [biaxial]
  Uniaxial,      ///< [uniaxial]
  PictureFrame,  ///< [picture_frame]
  BiasExtension, ///< [bias_extension]
};

/// The test block's name ("biaxial", "uniaxial", "picture_frame", "bias_extension"), which names
/// the study's files of that test.
const char* test_name(StudyTest test);

/// The integration path a case runs on.
enum class StudyPath {
  Deck,     ///< as the deck says ([biaxial] type)
  Implicit, ///< the deck's static or dynamic step; "dynamic" (Newmark) for an explicit deck
  Explicit, ///< central difference with [biaxial.explicit]'s settings
};

struct StudyCase {
  std::string name;  ///< folder name of its results
  std::string label; ///< legend label, e.g. "Spline"
  std::filesystem::path deck;
  StudyTest test = StudyTest::Biaxial; ///< the deck's test block
  /// One run per entry; {Deck} without a `paths` key. With several paths the runs go to
  /// DIR/<name>/<path>/ and are labelled "<label>, <path>".
  std::vector<StudyPath> paths{StudyPath::Deck};
};

struct Study {
  std::string title;
  std::vector<StudyCase> cases;
  /// Cases whose final normal contact forces are drawn over the fabric.
  std::vector<std::string> contact_maps;
};

/// Reads a study deck; deck paths are relative to the study file. Each case's deck is parsed to
/// find its test block (the deck is read whole when the case runs). Throws InputError listing
/// every problem: a deck that is missing, does not parse, or has not exactly one test block.
Study read_study(const std::filesystem::path& file);

struct StudyOptions {
  std::filesystem::path output_dir;
  int threads = 1;
  LinearSolverKind linear_solver = LinearSolverKind::Auto;
  bool progress = true;
  const std::atomic<bool>* stop_requested = nullptr;
};

struct StudyOutcome {
  int completed = 0;
  std::vector<std::string> failures; ///< "case: why" for cases that stopped
  std::vector<std::filesystem::path> plots;
  /// The long-format curve files written: curves.csv (biaxial), curves-<test>.csv (the others).
  std::vector<std::filesystem::path> curves;
};

/// Runs every case (on each of its paths) into output_dir/<case> (output_dir/<case>/<path> for a
/// case with `paths`), then writes, for the biaxial runs, output_dir/curves.csv, output_dir/
/// summary.csv (wall time, increments, mass scaling, kinetic/internal energy and the difference to
/// the implicit run of the same case, per run) and force-strain-k<k>.png per strain ratio; for the
/// runs of each other test, write_test_outputs' files (test_outputs.hpp); and
/// contact-forces-<case>.png for the cases of contact_maps. A run that fails is reported and the
/// others go on; Interrupted stops the study.
StudyOutcome run_study(const Study& study, const StudyOptions& options);

} // namespace yarnsim
