#!/usr/bin/env bash
# Runs that cannot converge exit with code 3, name the time, the step, the worst node and DOF and
# what failed, and leave results.h5 (status "failed: ...", every completed increment), a complete
# results.xdmf and complete monitor CSV rows. An output folder that cannot be made exits with 1.
# Usage: failures.sh YARNSIM REPO WORKDIR
set -u
yarnsim="$1"; repo="$2"; work="$3"
source "$(dirname "${BASH_SOURCE[0]}")/lib/results.sh"
source "$(dirname "${BASH_SOURCE[0]}")/lib/decks.sh"
require_tools h5ls h5dump xmllint
rm -rf "$work"; mkdir -p "$work"; cd "$work"
fail=0
steps=-1

# Runs deck NAME.toml; checks the exit code and that the message matches every pattern (grep -E).
run() { # name expected-code pattern...
  local name="$1" code="$2"; shift 2
  "$yarnsim" run "$name.toml" -o "out-$name" -q --threads 2 > "$name.log" 2>&1
  local got=$?
  if [ "$got" -ne "$code" ]; then echo "FAIL $name: exit $got, expected $code"; cat "$name.log"; fail=1; fi
  local pattern
  for pattern in "$@"; do
    grep -Eq -- "$pattern" "$name.log" || { echo "FAIL $name: message lacks '$pattern'"; cat "$name.log"; fail=1; }
  done
}

# The failed increment's start time from the message equals the time of the last stored step.
check_stop_time() { # name
  local name="$1" said last
  said=$(sed -n 's/.* stopped at t = \([^ ]*\) s.*/\1/p' "$name.log" | head -1)
  last=$(h5_step_times "out-$name/results.h5" | tail -1)
  awk -v a="$said" -v b="$last" 'BEGIN { d = a - b; if (d < 0) d = -d; exit !(d <= 1e-6 * (a < 0 ? -a : a)) }' ||
    { echo "FAIL $name: stopped at t = '$said' s, but the last step in results.h5 is at t = '$last' s"; fail=1; }
}

# The status in results.h5 carries the message printed.
check_status_message() { # name
  local name="$1" status
  status=$(h5_root_attribute "out-$name/results.h5" status)
  grep -qF -- "${status#failed: }" "$name.log" || { echo "FAIL $name: status '$status' differs from the message"; fail=1; }
}

no_convergence='no convergence in [0-9]+ iterations'
worst='worst: node [0-9]+ DOF (ux|uy|uz|rx|ry|rz)'

# 1. The roll-up deck that cannot converge (lib/decks.sh): static, two steps, the first completes,
# the second meets a load jumping a hundredfold; with monitors.
diverging_rollup_deck "$repo" static.toml
cat >> static.toml << 'EOF'

[[monitors]]
name = "tip"
node = 33

[[monitors]]
name = "clamp"
node_set = "beam.start"

[[monitors]]
name = "element1"
element = 1
EOF
run static 3 "step 2 stopped at t = 0.25 s" "fell below the minimum" "$no_convergence" "$worst" \
  "results in out-static hold every completed increment"
check_results static out-static "failed: "
[ "$steps" -eq 5 ] || { echo "FAIL static: $steps steps in results.h5, expected 5"; fail=1; }
check_stop_time static
check_status_message static

# 2. Dynamic (Newmark): the tip load jumps by 1e5 at t = 0.11 s.
sed -e 's/^table = .*/table = [[0.0, 0.0], [0.05, 1.0], [0.1, 1.0], [0.11, 1e5], [20.0, 1e5]]/' \
  -e 's/^end_time = .*/end_time = 1.0/' \
  -e 's/^dt_max = .*/dt_max = 0.01\ndt_min = 0.002\nmax_iterations = 5/' \
  "$repo/examples/cantilever-vibration.toml" > dynamic.toml
# It stops after the last increment it completes before the jump (where, depends on how the
# step grew on the way: 0.1025 s today), having stored every one of them (10 or more).
run dynamic 3 "step 1 stopped at t = 0\.10[0-9]* s" "$no_convergence" "$worst"
check_results dynamic out-dynamic "failed: "
[ "$steps" -ge 10 ] || { echo "FAIL dynamic: $steps steps in results.h5, expected 10 or more"; fail=1; }
check_stop_time dynamic
check_status_message dynamic

# 3. A load of 1e300 N overflows the residual in the first increment: nothing completes, the
# files are still there and valid, the CSVs hold their header only.
sed -e 's/^moment = .*/force = [0.0, 1e300, 0.0]/' "$repo/examples/rollup.toml" > overflow.toml
run overflow 3 "step 1 stopped at t = 0 s" "residual is not finite at node [0-9]+ DOF (ux|uy|uz|rx|ry|rz)"
check_results overflow out-overflow "failed: "
[ "$steps" -eq 0 ] || { echo "FAIL overflow: $steps steps in results.h5, expected 0"; fail=1; }
check_status_message overflow

# 4. The output folder cannot be made (its parent is a file): exit 1, naming the folder.
cp "$repo/examples/rollup.toml" io.toml
touch not-a-folder
"$yarnsim" run io.toml -o not-a-folder/out -q > io.log 2>&1
got=$?
[ "$got" -eq 1 ] || { echo "FAIL io: exit $got, expected 1"; cat io.log; fail=1; }
grep -q "not-a-folder/out" io.log || { echo "FAIL io: message lacks the folder"; cat io.log; fail=1; }

if [ "$fail" -eq 0 ]; then echo "failures: all checks passed"; fi
exit "$fail"
