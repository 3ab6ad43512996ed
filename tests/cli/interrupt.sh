#!/usr/bin/env bash
# SIGINT and SIGTERM stop a run after its last completed increment: exit code 130 within a few
# seconds, results.h5 opens with status "interrupted" and every completed increment, results.xdmf
# is complete XML listing the same steps, the monitor CSVs hold complete rows of the same times.
# Usage: interrupt.sh YARNSIM REPO WORKDIR
set -u
yarnsim="$1"; repo="$2"; work="$3"
source "$(dirname "${BASH_SOURCE[0]}")/lib/results.sh"
require_tools h5ls h5dump xmllint
rm -rf "$work"; mkdir -p "$work"; cd "$work"
fail=0
steps=-1

# The cantilever vibration made 50 times longer (100000 increments, minutes of work), with a
# monitor of each kind.
sed -e 's/^end_time = .*/end_time = 1000.0/' "$repo/examples/cantilever-vibration.toml" > long.toml
cat >> long.toml << 'EOF'

[[monitors]]
name = "clamp"
node_set = "beam.start"

[[monitors]]
name = "element1"
element = 1
EOF


interrupt() { # signal
  local sig="$1" name="sig${1,,}"
  local out="out-$name" log="$name.log"
  "$yarnsim" run long.toml -o "$out" --threads 2 > "$log" 2>&1 &
  local pid=$!
  # Wait until results.h5 holds a few steps (at most 20 s). Watched through tip.csv: a run writes
  # an increment's monitor rows, then its step, so 6 rows after the one at t = 0 mean at least 5
  # steps in results.h5.
  # (Polling the .h5 itself works too, but h5ls fails now and then on a file being written and
  # the run may be thousands of increments further when it succeeds.)
  local start n
  start=$(now)
  while :; do
    n=$(($(cat "$out/tip.csv" 2> /dev/null | wc -l) - 3))
    [ "$n" -ge 5 ] && break
    if ! kill -0 "$pid" 2> /dev/null; then
      echo "FAIL $name: the run ended before it was signalled"; cat "$log"; fail=1; return
    fi
    if awk -v t="$(elapsed "$start")" 'BEGIN { exit !(t > 20) }'; then
      echo "FAIL $name: results.h5 holds $n steps after 20 s"; kill -KILL "$pid"; wait "$pid"; fail=1; return
    fi
    sleep 0.1
  done
  kill -"$sig" "$pid"
  local signalled
  signalled=$(now)
  # It must end within 5 s.
  while kill -0 "$pid" 2> /dev/null; do
    if awk -v t="$(elapsed "$signalled")" 'BEGIN { exit !(t > 5) }'; then
      echo "FAIL $name: still running 5 s after SIG$sig"; kill -KILL "$pid"; fail=1; break
    fi
    sleep 0.05
  done
  wait "$pid"
  local code=$?
  local took
  took=$(elapsed "$signalled")
  [ "$code" -eq 130 ] || { echo "FAIL $name: exit $code, expected 130"; cat "$log"; fail=1; }
  grep -q "interrupted at t = " "$log" || { echo "FAIL $name: no 'interrupted at t = ...' message"; cat "$log"; fail=1; }
  grep -q "hold every completed increment" "$log" || { echo "FAIL $name: the message does not say what the results hold"; fail=1; }
  check_results "$name" "$out" "interrupted"
  # "interrupted at t = T s after increment N": N steps (all written, output_every = 1) up to T.
  local said_t said_n last
  said_t=$(sed -n 's/.*interrupted at t = \([^ ]*\) s after increment \([0-9]*\).*/\1/p' "$log" | head -1)
  said_n=$(sed -n 's/.*interrupted at t = \([^ ]*\) s after increment \([0-9]*\).*/\2/p' "$log" | head -1)
  last=$(h5_step_times "$out/results.h5" | tail -1)
  [ "$said_n" = "$steps" ] || { echo "FAIL $name: stopped after increment '$said_n', results.h5 holds $steps steps"; fail=1; }
  awk -v a="$said_t" -v b="$last" 'BEGIN { d = a - b; if (d < 0) d = -d; exit !(a != "" && d <= 1e-6 * (a < 0 ? -a : a)) }' ||
    { echo "FAIL $name: stopped at t = '$said_t' s, the last step of results.h5 is at t = '$last' s"; fail=1; }
  echo "SIG$sig: exit $code after $took s, $steps steps kept"
}

interrupt INT
interrupt TERM

if [ "$fail" -eq 0 ]; then echo "interrupt: all checks passed"; fi
exit "$fail"
