#!/usr/bin/env bash
# The monitor and curve files a user compares: every CSV of a run starts with the initial state
# (t = 0, increment 0) before the first increment.
# Cases: the crossing beams (spline contact, touching at the start), a 3 x 3 biaxial weave
# (curves.csv), the explicit flying beam (energy.csv).
# Usage: monitors.sh YARNSIM REPO WORKDIR
set -u
yarnsim="$1"; repo="$2"; work="$3"
source "$(dirname "${BASH_SOURCE[0]}")/lib/results.sh"
require_tools h5ls h5dump xmllint
rm -rf "$work"; mkdir -p "$work"; cd "$work"
fail=0
steps=-1

expect() { # label expected-code args...
  local label="$1" code="$2"; shift 2
  "$yarnsim" "$@" > "$label.log" 2>&1
  local got=$?
  [ "$got" -eq "$code" ] || { echo "FAIL $label: exit $got, expected $code"; cat "$label.log"; fail=1; }
}

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
# The beams touch at the start: the contact sees them at t = 0.
[ "$(csv_row crossing/contact.csv 1 | cut -d, -f3)" = 1 ] ||
  { echo "FAIL crossing: no active contact at t = 0 (the beams touch): $(csv_row crossing/contact.csv 1)"; fail=1; }

# 2. A 3 x 3 plain weave, 10 dynamic increments: curves.csv from the undeformed state.
sed -e 's/^n_warp = .*/n_warp = 3/; s/^n_weft = .*/n_weft = 3/' \
  -e 's/^length_warp = .*/length_warp = 18.18182e-3/; s/^length_weft = .*/length_weft = 18.18182e-3/' \
  -e 's/^elements_per_spacing = .*/elements_per_spacing = 2/' \
  -e 's/^max_strain = .*/max_strain = 0.003/; s/^loading_time = .*/loading_time = 0.1/' \
  "$repo/examples/biaxial-k1.toml" > biaxial.toml
expect biaxial 0 run biaxial.toml -o biaxial -q --threads 2
check_results biaxial biaxial completed
row_is "biaxial initial curves" biaxial/curves.csv 1 0 0 0 0 0 0 0 0 0 0 0
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

if [ "$fail" -eq 0 ]; then echo "monitors: all checks passed"; fi
exit "$fail"
