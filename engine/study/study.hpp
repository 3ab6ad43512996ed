#pragma once
// A study: several runs (cases) of fabric decks, then the curves of all of them side by side and
// the pictures a user compares with the paper: one force-strain plot per strain ratio k (warp
// and weft, every formulation; the paper's Fig. 3) and the normal contact forces over the fabric
// (Fig. 4). Deck format: docs/input.md, "Study decks".

#include "engine/solver/linear_solver.hpp"

#include <atomic>
#include <filesystem>
#include <string>
#include <vector>

namespace yarnsim {

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

/// Reads a study deck; deck paths are relative to the study file. Throws InputError.
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
};

/// Runs every case (on each of its paths) into output_dir/<case> (output_dir/<case>/<path> for a
/// case with `paths`), then writes output_dir/curves.csv (all runs), output_dir/summary.csv (wall
/// time, increments, mass scaling, kinetic/internal energy and the difference to the implicit run
/// of the same case, per run), force-strain-k<k>.png per strain ratio and
/// contact-forces-<case>.png. A run that fails is reported and the others go on; Interrupted
/// stops the study.
StudyOutcome run_study(const Study& study, const StudyOptions& options);

} // namespace yarnsim
