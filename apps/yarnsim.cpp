// yarnsim: the command line. Thin: parse, read the deck, run, map exceptions to exit codes
// (README: 0 success, 1 other failure, 2 bad input or usage, 3 no convergence, 130 interrupted).

#include "engine/input/read_deck.hpp"
#include "engine/output/checkpoint_file.hpp"
#include "engine/run/check.hpp"
#include "engine/run/run.hpp"
#include "engine/solver/distributed.hpp"
#include "engine/solver/petsc_solver.hpp"
#include "engine/solver/simulation.hpp"
#include "engine/study/study.hpp"
#include "yarnsim/version.hpp"

#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <fmt/format.h>
#include <fstream>
#include <sstream>
#include <tbb/global_control.h>
#include <thread>
#include <unistd.h>
#ifdef YARNSIM_HAVE_PETSC
#include <mpi.h>
#include <petscsys.h>
#endif

namespace {

enum ExitCode : int {
  kSuccess = 0,
  kFailure = 1,
  kBadInput = 2,
  kNoConvergence = 3,
  kInterrupted = 130
};

std::atomic<bool> g_stop{false};

// OpenBLAS (behind UMFPACK) keeps its own thread pool. UMFPACK's dense blocks are small on
// yarn models, where OpenBLAS's threads only spin: the paper's k = 1 case took 13.5 s with two
// BLAS threads against 5.7 s with one. So BLAS runs on one thread, within the --threads limit,
// and the parallelism is TBB's (assembly, contact).
extern "C" void openblas_set_num_threads(int) __attribute__((weak));

// The first SIGINT or SIGTERM asks the run to stop: the solver looks at the flag between Newton
// iterations and stages and drops the attempt in progress, and the files keep every completed
// increment (exit 130). A second signal ends the process at once (_exit is async-signal-safe):
// what the writer thread had flushed stays on disk, the rest is lost.
extern "C" void on_signal(int) {
  if (g_stop.exchange(true))
    _exit(130);
}

/// The MPI build: MPI (calls from the main thread only, oneTBB's workers never call it) and
/// PETSc for the length of the program. PETSc reads its options from PETSC_OPTIONS (the command
/// line is this program's); its signal handlers are left out (the run's own handle SIGINT and
/// SIGTERM; a crash stays a crash). Nothing in the oneTBB build.
class MpiSession {
public:
  MpiSession(int argc, char** argv) {
#ifdef YARNSIM_HAVE_PETSC
    int provided = 0;
    MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
    if (provided < MPI_THREAD_FUNNELED) { // oneTBB's workers run beside the main thread's calls
      fmt::print(stderr, "error: this MPI library gives no MPI_THREAD_FUNNELED support\n");
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
    PetscOptionsSetValue(nullptr, "-no_signal_handler", nullptr);
    int one = 1;
    char* args[] = {argv[0], nullptr};
    char** arg = args;
    if (PetscInitialize(&one, &arg, nullptr, nullptr) != 0) {
      fmt::print(stderr, "error: PETSc could not start\n");
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
    PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);
#else
    (void)argc;
    (void)argv;
#endif
  }
  ~MpiSession() {
#ifdef YARNSIM_HAVE_PETSC
    PetscFinalize();
    MPI_Finalize();
#endif
  }
  /// Ends every process of the run at once with `code`: a failure the others may not share (the
  /// leader's files), after which they would wait for it forever.
  [[noreturn]] static void abort(int code) {
#ifdef YARNSIM_HAVE_PETSC
    MPI_Abort(MPI_COMM_WORLD, code);
#endif
    std::exit(code);
  }
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
};

std::string read_text(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

} // namespace

int main(int argc, char** argv) {
  const MpiSession mpi(argc, argv);
  const int rank = yarnsim::distributed::rank(), ranks = yarnsim::distributed::size();
  // Over MPI the leader (rank 0) speaks and writes; the followers keep the same steps silently,
  // keeping their own stderr (own_stderr) for a failure only they may meet.
  FILE* own_stderr = stderr;
  if (rank > 0) {
    const int fd = dup(fileno(stderr));
    own_stderr = fd >= 0 ? fdopen(fd, "w") : nullptr;
    if (!own_stderr || !std::freopen("/dev/null", "w", stdout) ||
        !std::freopen("/dev/null", "w", stderr))
      MpiSession::abort(kFailure);
  }
  CLI::App app{"yarnsim: yarn-scale simulation of dry woven textiles with geometrically exact "
               "beams and contact"};
  app.set_version_flag("--version", std::string("yarnsim ") + yarnsim::kVersion);
  app.require_subcommand(1);

  std::string deck;
  std::string output;
  // Over MPI, the machine's cores shared among its processes.
  int threads = std::max(1, static_cast<int>(std::thread::hardware_concurrency()) /
                                yarnsim::distributed::ranks_on_this_machine());
  std::string solver = "auto";
  bool quiet = false;
  bool timings = false;
  CLI::App* run = app.add_subcommand("run", "Run a model deck (TOML); see docs/input.md");
  run->add_option("deck", deck, "Model deck (.toml)")->required();
  run->add_option("--output,-o", output,
                  "Output folder (default: results/<deck name> in the current folder; with "
                  "--restart, the folder it restarts from)");
  run->add_option("--threads,-t", threads, "Number of threads")->check(CLI::Range(1, 1024));
  run->add_option("--linear-solver", solver,
                  "Linear solver: auto (default: mumps, else lu, with applied moments or "
                  "friction; ldlt-gmres with surface contact; otherwise ldlt, or mumps from "
                  "500 000 equations; mumps on several processes), lu "
                  "(UMFPACK), ldlt (the symmetric part), ldlt-gmres (the full tangent by GMRES "
                  "on the symmetric part's LDL^T, lu where that does not converge), mumps (MUMPS, "
                  "multifrontal: LDL^T of the symmetric part, or LU where auto takes lu or "
                  "ldlt-gmres) or petsc (the MPI build: the "
                  "processes of an MPI run factorise together, MUMPS by default, or the solver "
                  "PETSC_OPTIONS names)")
      ->check(CLI::IsMember({"auto", "lu", "ldlt", "ldlt-gmres", "mumps", "petsc"}));
  run->add_flag("--quiet,-q", quiet, "No progress line");
  run->add_flag("--timings", timings,
                "At the end (also of a run that stops early), the wall time of each stage of "
                "the Newton iterations (broad and narrow phase, assembly, factorisation, solve) "
                "and of the explicit increments");
  std::string restart;
  int stop_after = 0;
  run->add_option("--restart", restart,
                  "Continue the run of this deck whose output folder is DIR from its last "
                  "completed increment (DIR/checkpoint.h5); the output folder then holds the "
                  "whole history")
      ->type_name("DIR");
  run->add_option("--stop-after", stop_after,
                  "Stop (exit 130, as interrupted) after the first increment written at or "
                  "beyond increment N of the run")
      ->type_name("N")
      ->check(CLI::PositiveNumber);

  std::string study_deck;
  CLI::App* study = app.add_subcommand(
      "study", "Run every case of a study deck, then plot the curves of each test (biaxial "
               "force-strain; uniaxial; picture frame and bias extension: force, shear force, "
               "angles and the deformed specimen) and the contact forces (docs/input.md, \"Study "
               "decks\")");
  study->add_option("study", study_deck, "Study deck (.toml)")->required();
  study->add_option("--output,-o", output,
                    "Output folder (default: results/<study name> in the current folder)");
  study->add_option("--threads,-t", threads, "Number of threads")->check(CLI::Range(1, 1024));
  study
      ->add_option("--linear-solver", solver,
                   "Linear solver: auto, lu, ldlt, ldlt-gmres or mumps, as for 'run'")
      ->check(CLI::IsMember({"auto", "lu", "ldlt", "ldlt-gmres", "mumps"}));
  study->add_flag("--quiet,-q", quiet, "No progress line");

  std::string check_deck;
  CLI::App* check = app.add_subcommand(
      "check", "Read and check a deck (model or fabric deck) without running it, and print what "
               "its model holds: size, contact definitions and candidate pairs at the initial "
               "configuration, clearance, stable explicit step, steps");
  check->add_option("deck", check_deck, "Deck (.toml)")->required();
  check->add_option("--threads,-t", threads, "Number of threads")->check(CLI::Range(1, 1024));

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e); // prints help, version or the usage error
    return code == 0 ? kSuccess : kBadInput;
  }

  if (solver == "petsc" && !yarnsim::petsc_available()) {
    fmt::print(stderr, "error: --linear-solver petsc: this build of yarnsim was made without MPI "
                       "and PETSc (the MPI build: cmake -DYARNSIM_MPI=ON, scripts/test builds it "
                       "in build-mpi/)\n");
    return kBadInput;
  }

  // One limit for every parallel part of the run (oneTBB; the solvers use no other pool).
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(threads));
  if (openblas_set_num_threads)
    openblas_set_num_threads(1);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);

  if (ranks > 1 && !run->parsed()) {
    fmt::print(stderr,
               "error: 'yarnsim {}' runs on one process; only 'yarnsim run' runs over MPI "
               "(start it without mpirun)\n",
               study->parsed() ? "study" : "check");
    return kBadInput;
  }

  if (study->parsed()) {
    const std::filesystem::path path(study_deck);
    const std::filesystem::path dir = output.empty()
                                          ? std::filesystem::path("results") / path.stem()
                                          : std::filesystem::path(output);
    try {
      const yarnsim::Study s = yarnsim::read_study(path);
      yarnsim::StudyOptions options;
      options.output_dir = dir;
      options.threads = threads;
      options.linear_solver = yarnsim::linear_solver_kind_from(solver);
      options.progress = !quiet;
      options.stop_requested = &g_stop;
      fmt::print(stderr, "yarnsim {}: study {} ({} cases), {} thread(s), output in {}\n",
                 yarnsim::kVersion, s.title, s.cases.size(), threads, dir.string());
      const yarnsim::StudyOutcome outcome = yarnsim::run_study(s, options);
      for (const auto& plot : outcome.plots)
        fmt::print(stderr, "plot: {}\n", plot.string());
      if (outcome.curves.size() == 1)
        fmt::print(stderr, "curves of all cases: {}\n", outcome.curves.front().string());
      else
        for (const auto& curves : outcome.curves)
          fmt::print(stderr, "curves: {}\n", curves.string());
      if (!outcome.failures.empty()) {
        for (const auto& f : outcome.failures)
          fmt::print(stderr, "error: case {}\n", f);
        return kNoConvergence;
      }
      return kSuccess;
    } catch (const yarnsim::InputError& e) {
      fmt::print(stderr, "{}\nerror: {} problem(s); nothing was run\n", e.what(),
                 e.messages().size());
      return kBadInput;
    } catch (const yarnsim::Interrupted& e) {
      fmt::print(stderr, "{}\n", e.what());
      return kInterrupted;
    } catch (const std::exception& e) {
      fmt::print(stderr, "error: {}\n", e.what());
      return kFailure;
    }
  }

  if (check->parsed()) {
    const std::filesystem::path path(check_deck);
    try {
      const yarnsim::Model model = yarnsim::read_deck(path);
      fmt::print("deck: {}\ntitle: {}\n{}", path.string(), model.title,
                 yarnsim::check_report(model));
      fmt::print("the deck is fine: nothing was run\n");
      return kSuccess;
    } catch (const yarnsim::InputError& e) {
      fmt::print(stderr, "{}\nerror: the deck has {} problem(s)\n", e.what(), e.messages().size());
      return kBadInput;
    } catch (const std::exception& e) {
      fmt::print(stderr, "error: {}\n", e.what());
      return kFailure;
    }
  }

  const std::filesystem::path deck_path(deck);
  // A restart goes on in the folder it restarts from unless --output names another.
  std::filesystem::path out_dir = !output.empty() ? std::filesystem::path(output)
                                  : !restart.empty()
                                      ? std::filesystem::path(restart)
                                      : std::filesystem::path("results") / deck_path.stem();
  // What a run that stops early did: its stage times are printed with --timings.
  yarnsim::RunSummary stopped;
  const auto print_stopped_timings = [&] {
    if (timings && (stopped.iterations > 0 || stopped.stage_times.explicit_path.increments > 0))
      fmt::print(stderr, "{}",
                 yarnsim::stage_times_report(stopped.stage_times, stopped.iterations));
  };
  try {
    const yarnsim::Model model = yarnsim::read_deck(deck_path);
    yarnsim::RunOptions options;
    options.output_dir = out_dir;
    options.deck_text = read_text(deck_path);
    options.deck_path = deck_path.string();
    options.threads = threads;
    options.linear_solver = yarnsim::linear_solver_kind_from(solver);
    options.progress = !quiet;
    options.stop_requested = &g_stop;
    options.restart_from = restart;
    options.stop_after = stop_after;
    options.summary_on_stop = &stopped;
    fmt::print(stderr, "yarnsim {}: {} ({} nodes, {} elements), {}{} thread(s), output in {}\n",
               yarnsim::kVersion, model.title.empty() ? deck_path.filename().string() : model.title,
               model.nodes.size(), model.elements.size(),
               ranks > 1 ? fmt::format("{} processes of ", ranks) : "", threads, out_dir.string());
    const yarnsim::RunSummary s =
        rank == 0 ? yarnsim::run_model(model, options) : yarnsim::follow_model(model, options);
    fmt::print(stderr, "done: {} increments, {} Newton iterations{} in {:.2f} s; results in {}\n",
               s.increments, s.iterations,
               s.simplified_trials > 0
                   ? fmt::format(" (and {} damped point{} judged by one solve each)",
                                 s.simplified_trials, s.simplified_trials == 1 ? "" : "s")
                   : std::string(),
               s.wall_seconds, out_dir.string());
    if (s.damping_dissipation > 0)
      fmt::print(stderr,
                 "Rayleigh damping dissipated {:.4g} J, {:.3g} % of the {:.4g} J stored at the "
                 "end (strain and contact)\n",
                 s.damping_dissipation,
                 s.stored_energy > 0 ? 100 * s.damping_dissipation / s.stored_energy : 0.0,
                 s.stored_energy);
    if (timings)
      fmt::print(stderr, "{}", yarnsim::stage_times_report(s.stage_times, s.iterations));
    return kSuccess;
  } catch (const yarnsim::InputError& e) {
    fmt::print(stderr, "{}\nerror: the deck has {} problem(s); nothing was run\n", e.what(),
               e.messages().size());
    return kBadInput;
  } catch (const yarnsim::output::RestartError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    // Over MPI the leader alone copies the earlier run's files: its failure ends every process.
    if (ranks > 1)
      MpiSession::abort(kBadInput);
    return kBadInput;
  } catch (const yarnsim::ConvergenceError& e) {
    fmt::print(stderr, "error: {}\nThe results in {} hold every completed increment.\n", e.what(),
               out_dir.string());
    print_stopped_timings();
    return kNoConvergence;
  } catch (const yarnsim::Interrupted& e) {
    fmt::print(stderr,
               "{}\nThe results in {} hold every completed increment; continue with\n  {}yarnsim "
               "run {} --restart {}\n",
               e.what(), out_dir.string(), ranks > 1 ? fmt::format("mpirun -np {} ", ranks) : "",
               deck, out_dir.string());
    print_stopped_timings();
    return kInterrupted;
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    // Over MPI a failure of this kind may be one process's alone (the leader's files): said by
    // that process, then every process ends.
    if (ranks > 1) {
      if (rank > 0)
        fmt::print(own_stderr, "error (process {}): {}\n", rank, e.what());
      MpiSession::abort(kFailure);
    }
    return kFailure;
  }
}
