#!/usr/bin/env bash
# A signal that arrives in the middle of a long increment is honoured there: the solver looks at
# the stop request between Newton iterations and their stages, drops the attempt in progress and
# exits 130 within 2 s, with results.h5, results.xdmf and the monitors holding every completed
# increment. A second signal ends the process at once (exit 130).
# Usage: interrupt_long_increment.sh YARNSIM REPO WORKDIR
set -u
yarnsim="$1"; repo="$2"; work="$3"
source "$(dirname "${BASH_SOURCE[0]}")/lib/results.sh"
require_tools h5ls h5dump xmllint
rm -rf "$work"; mkdir -p "$work"; cd "$work"
fail=0
steps=-1

# The roll-up of examples/rollup.toml on 40 000 elements (240 000 equations), to lambda = 0.5 in
# increments of 0.05: an increment takes 4 Newton iterations of about a second each (one LU
# factorisation each), so a signal sent a second after the first increment lands in the middle
# of the second.
# Built with AddressSanitizer (scripts/test --sanitize), every iteration is several times slower:
# the model is then a fifth as large, so that an iteration again takes about a second.
elements=40000
if built_with_sanitizers; then elements=8000; fi
sed -e "s/^elements = .*/elements = $elements/" \
    -e 's/^end_time = .*/end_time = 0.5/' \
    -e "s/^node = 33/node = $((2 * elements + 1))/" \
    "$repo/examples/rollup.toml" > long.toml


# Starts the run, waits until its first increment is on disk and the second has run for a
# second, then sends the signal(s); sets $code and $took (s from the first signal to the exit).
run_and_signal() { # name count
  local name="$1" count="$2"
  local out="out-$name" log="$name.log"
  "$yarnsim" run long.toml -o "$out" --threads 2 > "$log" 2>&1 &
  local pid=$!
  local start
  start=$(now)
  # tip.csv: a header, the row at t = 0, then a row per completed increment.
  while [ "$(($(cat "$out/tip.csv" 2> /dev/null | wc -l) - 2))" -lt 1 ]; do
    if ! kill -0 "$pid" 2> /dev/null; then
      echo "FAIL $name: the run ended before it was signalled"; cat "$log"; fail=1; code=-1; return
    fi
    if awk -v t="$(elapsed "$start")" 'BEGIN { exit !(t > 120) }'; then
      echo "FAIL $name: no increment completed in 120 s"; kill -KILL "$pid"; wait "$pid"; fail=1; code=-1; return
    fi
    sleep 0.05
  done
  sleep 1
  if ! kill -0 "$pid" 2> /dev/null; then
    echo "FAIL $name: the run ended before it was signalled (increments too short for this test)"
    cat "$log"; fail=1; code=-1; return
  fi
  local rows_before
  rows_before=$(($(wc -l < "$out/tip.csv") - 2))
  local signalled
  signalled=$(now)
  kill -INT "$pid"
  [ "$count" -ge 2 ] && { sleep 0.05; kill -INT "$pid"; }
  while kill -0 "$pid" 2> /dev/null; do
    if awk -v t="$(elapsed "$signalled")" 'BEGIN { exit !(t > 30) }'; then
      echo "FAIL $name: still running 30 s after the signal"; kill -KILL "$pid"; break
    fi
    sleep 0.02
  done
  wait "$pid"
  code=$?
  took=$(elapsed "$signalled")
  echo "$name: $rows_before increment(s) done when signalled, exit $code after $took s"
}

run_and_signal once 1
if [ "$code" -ge 0 ]; then
  [ "$code" -eq 130 ] || { echo "FAIL once: exit $code, expected 130"; cat once.log; fail=1; }
  awk -v t="$took" 'BEGIN { exit !(t <= 2) }' ||
    { echo "FAIL once: exited $took s after SIGINT, expected within 2 s"; fail=1; }
  grep -q "interrupted at t = " once.log || { echo "FAIL once: no 'interrupted at t = ...' message"; cat once.log; fail=1; }
  check_results once out-once "interrupted"
  said_n=$(sed -n 's/.*interrupted at t = \([^ ]*\) s after increment \([0-9]*\).*/\2/p' once.log | head -1)
  [ "$said_n" = "$steps" ] || { echo "FAIL once: stopped after increment '$said_n', results.h5 holds $steps steps"; fail=1; }
  [ "$steps" -ge 1 ] || { echo "FAIL once: results.h5 holds no completed increment"; fail=1; }
fi

run_and_signal twice 2
if [ "$code" -ge 0 ]; then
  [ "$code" -eq 130 ] || { echo "FAIL twice: exit $code, expected 130"; cat twice.log; fail=1; }
  awk -v t="$took" 'BEGIN { exit !(t <= 1) }' ||
    { echo "FAIL twice: exited $took s after two SIGINTs, expected at once"; fail=1; }
fi

if [ "$fail" -eq 0 ]; then echo "interrupt_long_increment: all checks passed"; fi
exit "$fail"
