#!/usr/bin/env bash
# An MPI run behaves as a one-process run when it stops: SIGINT to mpirun in the middle of a
# 12 x 12 weave's run over 2 processes ends it within 3 s (2 of them mpirun's), results.h5 opens with
# status "interrupted" and every completed increment; a restart over 2 processes from its
# checkpoint (and one over 3) completes and gives the uninterrupted run's results within 1e-10.
# A deck with errors exits 2 with the errors said once; a run that cannot converge exits 3; a
# failure of the leader alone (an output folder it cannot make) ends every process with exit 1.
# Usage: interrupt_restart.sh YARNSIM REPO WORKDIR
set -u
yarnsim="$1"; repo="$2"; work="$3"
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
compare="$(dirname "${BASH_SOURCE[0]}")/compare_runs.py"
python=/usr/bin/python3 # Debian's, with python3-h5py (scripts/test installs it)
require_tools mpirun h5ls h5dump
rm -rf "$work"; mkdir -p "$work"; cd "$work"
fail=0
steps=-1
weave_deck 12 w12.toml

# The uninterrupted run.
mpi 2 run w12.toml -o straight -q > straight.log 2>&1 || { echo "FAIL: the straight run failed"; cat straight.log; fail=1; }

# Interrupted once curves.csv holds 8 increments (its header and the row of t = 0 first), as a
# user's Ctrl-C does it: SIGINT to mpirun (started with SIGINT's default action, which a shell
# takes away from the commands it starts in the background). OpenMPI's mpirun ends the job
# itself on SIGINT and SIGTERM (it cannot forward them): it sends the processes SIGTERM, which
# they take as the stop request, and exits 1 whatever they exit with (docs/input.md, "Runs over
# MPI"); the processes' own exit code, 130, is checked below with --stop-after. The signal goes
# to mpirun's process group, as a terminal sends it (OpenMPI puts each process in its own group).
"$python" -c 'import os, signal, sys; os.setsid(); signal.signal(signal.SIGINT, signal.SIG_DFL); os.execvp(sys.argv[1], sys.argv[1:])' \
  mpirun -np 2 "$yarnsim" run w12.toml -o stopped > stopped.log 2>&1 &
pid=$!
start=$(now)
while kill -0 "$pid" 2> /dev/null && [ "$(cat stopped/curves.csv 2> /dev/null | wc -l)" -lt 10 ] &&
  awk -v t="$(elapsed "$start")" 'BEGIN { exit !(t < 60) }'; do
  sleep 0.05
done
sent=$(now)
kill -INT -- -"$pid"
wait "$pid"
code=$?
took=$(elapsed "$sent")
[ "$code" -ne 0 ] || { echo "FAIL: the interrupted run exited 0"; cat stopped.log; fail=1; }
# mpirun sends SIGCONT, waits odls_base_sigkill_timeout (1 s), sends SIGTERM and waits again
# before it reads the processes' last output and exits: about 2 s of its own. The processes stop
# within their Newton iteration.
awk -v t="$took" 'BEGIN { exit !(t <= 3) }' || { echo "FAIL: the run took $took s to stop (at most 3)"; fail=1; }
grep -q "interrupted at t = " stopped.log || { echo "FAIL: the interrupted run does not say so"; cat stopped.log; fail=1; }
grep -q "mpirun -np 2 .*yarnsim run w12.toml --restart stopped" stopped.log ||
  { echo "FAIL: the interrupted run does not say how to restart it over MPI"; cat stopped.log; fail=1; }
check_results interrupted stopped interrupted
echo "interrupted after $steps steps (increment 0 included), stopped in $took s"

# Stopped by --stop-after: the processes exit 130, which mpirun passes on.
mpi 2 run w12.toml -o stop-after -q --stop-after 5 > stop-after.log 2>&1
code=$?
[ "$code" -eq 130 ] || { echo "FAIL: --stop-after over MPI exited $code, expected 130"; cat stop-after.log; fail=1; }
check_results stop-after stop-after interrupted

# The restart goes on in the same folder; the results are then the straight run's.
for n in 2 3; do
  rm -rf "restart$n"; cp -r stopped "restart$n"
  mpi "$n" run w12.toml --restart "restart$n" -q > "restart$n.log" 2>&1 ||
    { echo "FAIL: the restart over $n processes failed"; cat "restart$n.log"; fail=1; continue; }
  "$python" "$compare" straight "restart$n" 1e-10 || { echo "FAIL: the restart over $n processes differs from the straight run"; fail=1; }
done

# A deck with errors: exit 2, the errors said once (by rank 0).
sed -e 's/^n_warp = .*/n_warp = "twelve"/' -e 's/^penalty = .*/penalty = -1/' w12.toml > bad.toml
mpi 2 run bad.toml -o bad > bad.log 2>&1
code=$?
[ "$code" -eq 2 ] || { echo "FAIL bad deck: exit $code, expected 2"; cat bad.log; fail=1; }
[ "$(grep -c 'n_warp' bad.log)" -eq 1 ] && [ "$(grep -c 'penalty' bad.log)" -ge 1 ] ||
  { echo "FAIL bad deck: its errors are not each said once"; cat bad.log; fail=1; }

# A failure of the leader alone (its output folder cannot be made, after the processes started
# factorising together): every process ends, exit 1, the error said. Before, the leader waited
# in the solver's collective clean-up while unwinding, and the run hung.
mpi_start=$(now)
timeout 60 mpirun -np 2 "$yarnsim" run w12.toml -o /proc/no-such-folder -q > nofolder.log 2>&1
code=$?
[ "$code" -eq 1 ] || { echo "FAIL unwritable output: exit $code, expected 1 (124: it hung)"; cat nofolder.log; fail=1; }
grep -q "error: .*cannot create directory /proc/no-such-folder" nofolder.log ||
  { echo "FAIL unwritable output: the error is not said"; cat nofolder.log; fail=1; }
echo "unwritable output folder: ended in $(elapsed "$mpi_start") s"

# A run that cannot converge (a load jumping a hundredfold; applied moments: PETSc's LU): exit 3,
# results.h5 with status "failed" and every completed increment.
diverging_rollup_deck "$repo" static.toml
mpi 2 run static.toml -o static -q > static.log 2>&1
code=$?
[ "$code" -eq 3 ] || { echo "FAIL no convergence: exit $code, expected 3"; cat static.log; fail=1; }
grep -Eq 'no convergence in [0-9]+ iterations' static.log || { echo "FAIL no convergence: the message"; cat static.log; fail=1; }
check_results no-convergence static failed

[ "$fail" -eq 0 ] && echo "PASS: interrupted, restarted, refused and failed as on one process"
exit "$fail"
