#!/usr/bin/env bash
# A run stopped half-way and continued with --restart gives the same results as a run straight
# through: every dataset and attribute under /steps and /mesh of results.h5 (h5diff, exact) and
# every CSV byte for byte. Cases: an implicit contact case (crossing beams, static), a short
# biaxial fabric (dynamic Newmark, contact, curves.csv) with spline and with surface contact, a
# picture frame past the locking of its yarns (the locking note carries over), a bias extension
# (its curves.csv marches over the rows so far), the explicit flying beam (stopped by --stop-after and by SIGINT). Restarts go into a new folder and into the stopped run's own
# folder. A restart refuses another deck and a folder without a checkpoint (exit 2).
# Usage: restart.sh YARNSIM REPO WORKDIR
set -u
yarnsim="$1"; repo="$2"; work="$3"
source "$(dirname "${BASH_SOURCE[0]}")/lib/results.sh"
require_tools h5ls h5dump h5diff xmllint
rm -rf "$work"; mkdir -p "$work"; cd "$work"
fail=0
steps=-1

# The restarted folder holds exactly what the straight run wrote.
same_results() { # label straight-dir restarted-dir
  local label="$1" a="$2" b="$3" f
  check_results "$label" "$b" "completed"
  for f in /steps /mesh; do
    h5diff "$a/results.h5" "$b/results.h5" "$f" "$f" > "$label.h5diff" 2>&1 ||
      { echo "FAIL $label: $f of results.h5 differs from the straight run:"; head -20 "$label.h5diff"; fail=1; }
  done
  for f in "$a"/*.csv; do
    cmp -s "$f" "$b/$(basename "$f")" ||
      { echo "FAIL $label: $(basename "$f") differs from the straight run"; diff "$f" "$b/$(basename "$f")" | head -5; fail=1; }
  done
  [ "$(cd "$a" && ls ./*.csv)" = "$(cd "$b" && ls ./*.csv)" ] || { echo "FAIL $label: other CSV files than the straight run"; fail=1; }
  [ "$steps" -gt 0 ] && echo "$label: $steps steps, every number as in the straight run"
}

# Straight run, a run stopped after increment N, then restarts into a new folder and in place.
restart_case() { # label deck N
  local label="$1" deck="$2" n="$3" part
  expect "$label-straight" 0 run "$deck" -o "straight-$label" -q --threads 2
  expect "$label-part" 130 run "$deck" -o "part-$label" -q --threads 2 --stop-after "$n"
  grep -q "after increment $n (--stop-after $n)" "$label-part.log" ||
    { echo "FAIL $label: no 'after increment $n (--stop-after $n)' message"; cat "$label-part.log"; fail=1; }
  grep -q -- "--restart part-$label" "$label-part.log" ||
    { echo "FAIL $label: the message does not say how to continue"; cat "$label-part.log"; fail=1; }
  check_results "$label-part" "part-$label" "interrupted"
  part=$steps
  [ -s "part-$label/checkpoint.h5" ] || { echo "FAIL $label: no checkpoint.h5 after the stop"; fail=1; }
  cp -r "part-$label" "inplace-$label"
  # A row written after the checkpoint (a run killed between the two) is dropped on restart.
  for f in "inplace-$label"/*.csv; do tail -n 1 "$f" >> "$f"; done
  expect "$label-restart" 0 run "$deck" --restart "part-$label" -o "restarted-$label" -q --threads 2
  grep -q "restarting from part-$label after increment" "$label-restart.log" ||
    { echo "FAIL $label: no 'restarting from ...' line"; cat "$label-restart.log"; fail=1; }
  same_results "$label (restart into a new folder)" "straight-$label" "restarted-$label"
  [ "$part" -gt 0 ] && [ "$part" -lt "$steps" ] || { echo "FAIL $label: the stopped run kept $part of $steps steps"; fail=1; }
  # In place without --output, as the stopped run's message says (and docs/robustness.md).
  expect "$label-inplace" 0 run "$deck" --restart "inplace-$label" -q --threads 2
  same_results "$label (restart in place)" "straight-$label" "inplace-$label"
  # The stopped run's folder is left as it was.
  check_results "$label-part-after" "part-$label" "interrupted"
  [ "$steps" -eq "$part" ] || { echo "FAIL $label: the restart changed the stopped run's folder"; fail=1; }
}

# 1. Crossing beams in 20 increments (contact opens a pattern and holds warm starts).
sed -e 's/^dt = 0.25/dt = 0.05/; s/^dt_max = 0.25/dt_max = 0.05/' "$repo/examples/crossing-beams.toml" > crossing.toml
restart_case crossing crossing.toml 7

# 2. A 3 x 3 plain weave, 10 dynamic increments with contact and the biaxial curves.
sed -e 's/^n_warp = .*/n_warp = 3/; s/^n_weft = .*/n_weft = 3/' \
  -e 's/^length_warp = .*/length_warp = 18.18182e-3/; s/^length_weft = .*/length_weft = 18.18182e-3/' \
  -e 's/^elements_per_spacing = .*/elements_per_spacing = 2/' \
  -e 's/^max_strain = .*/max_strain = 0.003/; s/^loading_time = .*/loading_time = 0.1/' \
  "$repo/examples/biaxial-k1.toml" > biaxial.toml
restart_case biaxial biaxial.toml 4

# 3. The same weave with surface contact: its warm starts, search boxes and candidates carry over.
sed -e 's/^n_warp = .*/n_warp = 3/; s/^n_weft = .*/n_weft = 3/' \
  -e 's/^length_warp = .*/length_warp = 18.18182e-3/; s/^length_weft = .*/length_weft = 18.18182e-3/' \
  -e 's/^elements_per_spacing = .*/elements_per_spacing = 2/' \
  -e 's/^max_strain = .*/max_strain = 0.003/; s/^loading_time = .*/loading_time = 0.1/' \
  "$repo/examples/biaxial-surface-k1.toml" > surface.toml
grep -q '^type = "surface"' surface.toml || { echo "FAIL surface: the deck has no surface contact"; fail=1; }
restart_case surface surface.toml 4

# 4. A 3 x 3 picture frame of yarns so wide that neighbouring ones lock near 16 degrees (row 119),
# stopped after increment 140: the restart reports the locking the first part found.
sed -e 's/^n_warp = .*/n_warp = 3/; s/^n_weft = .*/n_weft = 3/' \
  -e 's/^length_warp = .*/length_warp = 13.63635e-3/; s/^length_weft = .*/length_weft = 13.63635e-3/' \
  -e 's/^a = .*/a = 2.2e-3/; s/^max_angle = .*/max_angle = 20.0/' \
  -e 's/^elements_per_spacing = .*/elements_per_spacing = 2/' \
  "$repo/examples/picture-frame.toml" > frame.toml
restart_case frame frame.toml 140
# The straight run finds the locking near 16 degrees (the increments' path sets the last digits);
# the restarted runs report the same angle.
locking=$(grep -o "first touched at a frame angle of [0-9.]* degrees" frame-straight.log |
  grep -o "[0-9.]* degrees")
case "$locking" in
  15.[5-9]*" degrees" | 16.[0-4]*" degrees") ;;
  *) echo "FAIL frame: the straight run reports no locking near 16 degrees ('$locking')"
     cat frame-straight.log; fail=1 ;;
esac
for log in frame-restart.log frame-inplace.log; do
  grep -q "neighbouring parallel yarns first touched at a frame angle of $locking" "$log" ||
    { echo "FAIL frame: $log does not report the locking at $locking"; cat "$log"; fail=1; }
done

# 5. The explicit flying beam over 4 s (2000 increments, output every 50): stopped inside the
# explicit step, where the integrator's half-step velocities and momenta carry over.
sed -e 's/^end_time = .*/end_time = 4.0/' "$repo/examples/flying-beam-explicit.toml" > flying.toml
restart_case explicit flying.toml 900

# 6. SIGINT at some point of the explicit run made 50 times longer (75000 increments, output
# every 250), then a restart.
sed -e 's/^end_time = .*/end_time = 150.0/; s/^output_every = .*/output_every = 250/' \
  "$repo/examples/flying-beam-explicit.toml" > long.toml
expect long-straight 0 run long.toml -o straight-long -q --threads 2
"$yarnsim" run long.toml -o part-long -q --threads 2 > long-part.log 2>&1 &
pid=$!
# Wait for a few written increments (at most 60 s), then interrupt.
for ((i = 0; i < 600; ++i)); do
  [ "$(cat part-long/start.csv 2> /dev/null | wc -l)" -ge 7 ] && break
  kill -0 "$pid" 2> /dev/null || break
  sleep 0.1
done
kill -INT "$pid" 2> /dev/null
wait "$pid"
code=$?
if [ "$code" -ne 130 ]; then
  echo "FAIL long: exit $code after SIGINT, expected 130 (did the run end before the signal?)"
  cat long-part.log
  fail=1
else
  check_results long-part part-long "interrupted"
  part=$steps
  expect long-restart 0 run long.toml --restart part-long -o restarted-long -q --threads 2
  same_results "explicit, SIGINT after $part steps" straight-long restarted-long
fi

# 7. A bias extension (a 16 x 42 mm specimen pulled to an ideal 5 degrees, 36 dynamic
# increments; frictionless and without compaction it comes apart further on): its curves.csv
# carries the benchmark's energy-method force, marched over the rows so far, which the restart
# reads back from the rows the checkpoint kept.
cat > bias.toml << 'EOF_BIAS'
title = "bias"
[fabric]
pattern = "plain"
spacing_warp = 4e-3
spacing_weft = 4e-3
gap = 0.1e-3
a = 1e-3
b = 0.3e-3
E = 3.7e10
nu = 0.2
density = 2540.0
elements_per_spacing = 2
[bias_extension]
width = 16e-3
height = 42e-3
clamp_length = 5e-3
max_angle = 5
loading_time = 0.3
dt = 0.01
dt_max = 0.01
EOF_BIAS
restart_case bias bias.toml 12
awk -F, 'NR > 2 && $7 != "nan" && $7 != 0 { found = 1 } END { exit !found }' straight-bias/curves.csv ||
  { echo "FAIL bias: no energy-method force in curves.csv"; fail=1; }

# 8. Refusals: another deck, a folder without a checkpoint.
sed -e 's/^penalty = .*/penalty = 2e5/' crossing.toml > other.toml
expect other-deck 2 run other.toml --restart part-crossing -o other -q
grep -q "another deck" other-deck.log || { echo "FAIL other-deck: message lacks 'another deck'"; cat other-deck.log; fail=1; }
[ -e other ] && { echo "FAIL other-deck: an output folder was made"; fail=1; }
mkdir -p empty
expect no-checkpoint 2 run crossing.toml --restart empty -o none -q
grep -q "holds no checkpoint.h5" no-checkpoint.log || { echo "FAIL no-checkpoint: message lacks 'holds no checkpoint.h5'"; cat no-checkpoint.log; fail=1; }

if [ "$fail" -eq 0 ]; then echo "restart: all checks passed"; fi
exit "$fail"
