#!/usr/bin/env bash
# The monitor and curve files a user compares: every CSV of a run starts with the initial state
# (t = 0, increment 0) before the first increment; contact.csv carries the summed normal force of
# the active contact points, and contact_points.csv a row per active point (definition, the two
# splines and segments, position, gap, force, normal), the same on 1 and 2 threads.
# Cases: the crossing beams (spline contact, touching at the start), a 3 x 3 biaxial weave
# (curves.csv, several contacts per increment), the explicit flying beam (energy.csv), and the
# stage times of --timings (also of a run stopped early, and of an explicit run).
# Usage: monitors.sh YARNSIM REPO WORKDIR
set -u
yarnsim="$1"; repo="$2"; work="$3"
source "$(dirname "${BASH_SOURCE[0]}")/lib/results.sh"
require_tools h5ls h5dump xmllint
rm -rf "$work"; mkdir -p "$work"; cd "$work"
fail=0
steps=-1

# The data row (1 = first after the header) of a CSV.
csv_row() { sed -n "$(($2 + 1))p" "$1"; }

# The values of row $2 of CSV $1 equal those given (as numbers, exactly).
row_is() { # label file row value...
  local label="$1" file="$2" row="$3"; shift 3
  local got
  got=$(csv_row "$file" "$row")
  awk -F, -v want="$*" 'BEGIN { n = split(want, w, " ") }
    { if (NF != n) exit 1; for (i = 1; i <= n; ++i) if ($i + 0 != w[i] + 0) exit 1 }' <<< "$got" ||
    { echo "FAIL $label: row $row of $(basename "$file") is '$got', expected '$*'"; fail=1; }
}

# 1. Crossing beams, touching at the start: 4 increments, contact from t = 0.
expect crossing 0 run "$repo/examples/crossing-beams.toml" -o crossing -q --threads 1
check_results crossing crossing completed
[ "$steps" -eq 4 ] || { echo "FAIL crossing: $steps steps, expected 4"; fail=1; }
# Node 32 (mid-span of the top beam) at its reference position (0, 0, 0.02), nothing moved.
row_is "crossing initial node" crossing/load-point.csv 1 0 0 0 0.02 0 0 0 0 0 0
row_is "crossing initial reactions" crossing/supports.csv 1 0 0 0 0 0 0 0 0 0 0.01
head -1 crossing/contact.csv | grep -qx 'time \[s\],candidates \[-\],active \[-\],max_penetration \[m\],max_force \[N\],total_force \[N\]' ||
  { echo "FAIL crossing: contact.csv header $(head -1 crossing/contact.csv)"; fail=1; }
head -1 crossing/contact_points.csv | grep -qx 'increment \[-\],time \[s\],contact,a,a_segment \[-\],b,b_segment \[-\],x \[m\],y \[m\],z \[m\],gap \[m\],force \[N\],nx \[-\],ny \[-\],nz \[-\]' ||
  { echo "FAIL crossing: contact_points.csv header $(head -1 crossing/contact_points.csv)"; fail=1; }
# Per row of contact.csv (increment k = row - 1, every increment written): the active count is
# the number of points of increment k, and total_force their summed force (same order: the same
# double). Sets $most to the largest number of points of an increment.
points_match_contact() { # label dir steps
  local label="$1" dir="$2" n="$3" k active total count sum
  most=0
  for ((k = 0; k <= n; ++k)); do
    read -r active total < <(csv_row "$dir/contact.csv" $((k + 1)) | awk -F, '{ print $3, $6 }')
    read -r count sum < <(awk -F, -v k="$k" 'NR > 1 && $1 == k { ++n; s += $12 } END { printf "%d %.17g\n", n, s }' "$dir/contact_points.csv")
    [ "$active" = "$count" ] || { echo "FAIL $label: increment $k: contact.csv says $active active, contact_points.csv has $count rows"; fail=1; }
    awk -v a="$total" -v b="$sum" 'BEGIN { exit !(a + 0 == b + 0) }' ||
      { echo "FAIL $label: increment $k: total_force $total, the points sum to $sum"; fail=1; }
    [ "$count" -gt "$most" ] && most=$count
  done
}
points_match_contact crossing crossing "$steps"
# The beams touch at the start (the contact sees them at t = 0, with a round-off force before the
# load) and carry F_c close to P / (2 + k / eps) = 0.499059 N at the end (0.5008 N with these
# 10 elements per beam and both ends held axially).
[ "$(awk -F, 'NR > 1 && $1 == 0' crossing/contact_points.csv | wc -l)" -ge 1 ] ||
  { echo "FAIL crossing: no contact point at increment 0 (the beams touch)"; fail=1; }
awk -F, -v n="$steps" 'NR > 1 && $1 == n { s += $12; ok = ok && $3 == "crossing" && $4 == "bottom" && $6 == "top" }
  BEGIN { ok = 1 } END { exit !(ok && s > 0.495 && s < 0.505) }' crossing/contact_points.csv ||
  { echo "FAIL crossing: the last increment's points are not the crossing of bottom and top with 0.499 N:"; grep "^$steps," crossing/contact_points.csv; fail=1; }
# Mid-span: segment numbers of the 10-element lines' splines (21 control points, 19 segments)
# near the middle, the point near the origin.
awk -F, -v n="$steps" 'NR > 1 && $1 == n && ($5 < 8 || $5 > 12 || $7 < 8 || $7 > 12 || $8 * $8 + $9 * $9 > 1e-6) { exit 1 }' crossing/contact_points.csv ||
  { echo "FAIL crossing: contact points away from the mid-spans:"; grep "^$steps," crossing/contact_points.csv; fail=1; }
# Same files on 2 threads.
expect crossing-2 0 run "$repo/examples/crossing-beams.toml" -o crossing-2 -q --threads 2
for f in contact.csv contact_points.csv load-point.csv supports.csv bottom-mid.csv; do
  cmp -s "crossing/$f" "crossing-2/$f" || { echo "FAIL crossing: $f differs between 1 and 2 threads"; fail=1; }
done

# 2. A 3 x 3 plain weave, 10 dynamic increments: curves.csv from the undeformed state.
sed -e 's/^n_warp = .*/n_warp = 3/; s/^n_weft = .*/n_weft = 3/' \
  -e 's/^length_warp = .*/length_warp = 18.18182e-3/; s/^length_weft = .*/length_weft = 18.18182e-3/' \
  -e 's/^elements_per_spacing = .*/elements_per_spacing = 2/' \
  -e 's/^max_strain = .*/max_strain = 0.003/; s/^loading_time = .*/loading_time = 0.1/' \
  "$repo/examples/biaxial-k1.toml" > biaxial.toml
expect biaxial 0 run biaxial.toml -o biaxial -q --threads 2
check_results biaxial biaxial completed
# Time, strains and forces 0; the crimps (last two columns) those of the woven yarns: equal in a
# balanced weave, and positive.
initial=$(csv_row biaxial/curves.csv 1)
row_is "biaxial initial curves" <(echo header; echo "$initial" | cut -d, -f1-11) 1 0 0 0 0 0 0 0 0 0 0 0
awk -F, '{ exit !(NF == 13 && $12 > 0 && $12 < 0.05 && $12 == $13) }' <<< "$initial" ||
  { echo "FAIL biaxial initial crimps: '$initial' (expected two equal crimps in (0, 0.05))"; fail=1; }
points_match_contact biaxial biaxial "$steps"
[ "$most" -ge 4 ] || { echo "FAIL biaxial: at most $most contact points in an increment, expected several"; fail=1; }
expect biaxial-1 0 run biaxial.toml -o biaxial-1 -q --threads 1
for f in contact.csv contact_points.csv curves.csv; do
  cmp -s "biaxial/$f" "biaxial-1/$f" || { echo "FAIL biaxial: $f differs between 1 and 2 threads"; fail=1; }
done
awk -F, 'NR == 3 { exit !($2 > 0 && $3 > 0) }' biaxial/curves.csv ||
  { echo "FAIL biaxial: the first increment's strains are not positive: $(csv_row biaxial/curves.csv 2)"; fail=1; }

# 3. The explicit flying beam to 0.2 s (100 increments, output every 50): energy.csv at rest.
sed -e 's/^end_time = .*/end_time = 0.2/' "$repo/examples/flying-beam-explicit.toml" > flying.toml
expect flying 0 run flying.toml -o flying -q --threads 1
check_results flying flying completed
# At rest, no work done, no balance error; the strain energy of the reference configuration is
# round-off (1.7e-25 J).
csv_row flying/energy.csv 1 | awk -F, '{ exit !(NF == 9 && $1 == 0 && $2 == 0 && $3 >= 0 && $3 < 1e-20 &&
                                                $4 == 0 && $5 == 0 && $6 == 0 && $7 == 0 && $8 == 0 && $9 == 0) }' ||
  { echo "FAIL flying: the first row of energy.csv is not the state at rest: $(csv_row flying/energy.csv 1)"; fail=1; }
[ "$(wc -l < flying/energy.csv)" -eq 4 ] || { echo "FAIL flying: energy.csv has $(($(wc -l < flying/energy.csv) - 1)) rows, expected 3"; fail=1; }

# 4. --timings: a table of the stage times at the end, over the run's Newton iterations.
"$yarnsim" run "$repo/examples/crossing-beams.toml" -o timings -q --threads 1 --timings 2> timings.txt ||
  { echo "FAIL timings: exit $?"; fail=1; }
iterations=$(sed -n 's/^done: [0-9]* increments, \([0-9]*\) Newton iterations.*/\1/p' timings.txt)
grep -q "^stage times over ${iterations:-none} Newton iterations (wall):$" timings.txt ||
  { echo "FAIL timings: no stage table over the run's ${iterations:-?} iterations: $(cat timings.txt)"; fail=1; }
for stage in "broad phase" "narrow phase" "beam assembly" "factorisation" "solve"; do
  grep -Eq "^  $stage.* [0-9]+\.[0-9]{3} s +[0-9]+\.[0-9]{3} ms/iteration$" timings.txt ||
    { echo "FAIL timings: no row '$stage'"; fail=1; }
done
# ... also of a run that stops early (here by --stop-after, exit 130): over its iterations so far.
"$yarnsim" run "$repo/examples/crossing-beams.toml" -o timings-stopped -q --threads 1 --timings \
  --stop-after 2 2> timings-stopped.txt
code=$?
[ "$code" -eq 130 ] || { echo "FAIL timings of a stopped run: exit $code, expected 130"; fail=1; }
grep -Eq "^stage times over [1-9][0-9]* Newton iterations \(wall\):$" timings-stopped.txt ||
  { echo "FAIL timings of a stopped run: no stage table: $(cat timings-stopped.txt)"; fail=1; }
# ... and of an explicit run: over its increments, the explicit stages alone.
"$yarnsim" run "$repo/examples/flying-beam-explicit.toml" -o timings-explicit -q --threads 1 \
  --timings 2> timings-explicit.txt || { echo "FAIL timings of an explicit run: exit $?"; fail=1; }
increments=$(sed -n 's/^done: \([0-9]*\) increments, 0 Newton iterations.*/\1/p' timings-explicit.txt)
grep -q "^stage times over ${increments:-none} explicit increments (wall):$" timings-explicit.txt ||
  { echo "FAIL timings of an explicit run: no table over its ${increments:-?} increments: $(cat timings-explicit.txt)"; fail=1; }
for stage in "contact search" "beam forces" "kicks, drift and commit" "stable step"; do
  grep -Eq "^  $stage.* [0-9]+\.[0-9]{3} s +[0-9]+\.[0-9]{4} ms/increment$" timings-explicit.txt ||
    { echo "FAIL timings of an explicit run: no row '$stage'"; fail=1; }
done
! grep -q "Newton iterations (wall)" timings-explicit.txt ||
  { echo "FAIL timings of an explicit run: a table of Newton iterations it did not take"; fail=1; }

if [ "$fail" -eq 0 ]; then echo "monitors: all checks passed"; fi
exit "$fail"
