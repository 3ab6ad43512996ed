#pragma once
// What a study writes for its cases of the uniaxial and shear tests ([uniaxial], [picture_frame],
// [bias_extension]; docs/input.md, "Study decks"), beside the biaxial cases' curves.csv and
// summary.csv: per test, the curves of all its runs in one long-format file, a summary, the plots
// of its curves and, for the shear tests, each run's deformed specimen coloured by the local shear
// angle at every crossing at four stages.

#include "engine/model/model.hpp"
#include "engine/run/run.hpp"
#include "engine/study/study.hpp"

#include <filesystem>
#include <string>
#include <vector>

namespace yarnsim {

/// A run of a case of one of these tests, as the study collected it.
struct TestRun {
  std::string case_name;
  std::string case_label;
  std::string path;   ///< "implicit" or "explicit": the step the run took
  std::string folder; ///< its output folder, under the study's
  std::string label;  ///< legend: the case's label, "<label>, <path>" for a case with `paths`
  StudyTest test = StudyTest::Uniaxial;
  Model model;
  RunSummary summary;
  /// Empty for a completed run; else the run stopped early (no convergence): its curve is drawn
  /// as far as it got, and it is left out of the summary.
  std::string stopped;
};

/// The columns of `test`'s long-format curves file (not Biaxial) after `case, label, path`
/// (`direction` for Uniaxial) and `time [s]`: the columns of the runs' own curves.csv that every
/// run of the test writes, then those that only some runs write (with side-by-side contact or
/// friction; empty cells for the others). The uniaxial test's per-yarn forces are left out (their
/// number depends on the fabric).
std::vector<std::string> test_curve_columns(StudyTest test);

/// The fractions of a run's completed output steps at which deformed-<case>.png shows it.
inline constexpr double kStages[] = {0.25, 0.5, 0.75, 1.0};

/// The files write_test_outputs wrote.
struct TestOutputs {
  std::filesystem::path curves;             ///< curves-<test>.csv
  std::filesystem::path summary;            ///< summary-<test>.csv
  std::vector<std::filesystem::path> plots; ///< the pictures
};

/// Writes into dir, for the runs of `test` (Uniaxial, PictureFrame or BiasExtension; each run's
/// output in dir/<run.folder>/):
/// - curves-<test>.csv: every run's curves.csv rows, long format, `case, label, path,`
///   (uniaxial: `direction,`) `time [s],` then test_curve_columns(test), the cells as the run
///   wrote them;
/// - summary-<test>.csv: a row per completed run (cost, the end of its curve, and for the shear
///   tests the largest |measured - frame (or ideal) angle| up to 30 degrees), also printed;
/// - uniaxial.png: the pulled direction's force, and both crimps, against its strain;
/// - force-displacement-<test>.png, shear-<test>.png (normalised shear force against the frame or
///   ideal angle, solid, and the measured angle, dashed), angle-<test>.png (measured against frame
///   or ideal angle, with y = x), and per run deformed-<case>.png (deformed-<case>-<path>.png for
///   a case with `paths`) at kStages of its output steps, read from its results.h5.
/// `title` heads the plots. Throws std::invalid_argument for Biaxial, std::runtime_error when a
/// run's files cannot be read or gnuplot fails.
TestOutputs write_test_outputs(StudyTest test, const std::vector<const TestRun*>& runs,
                               const std::string& title, const std::filesystem::path& dir);

} // namespace yarnsim
