#!/usr/bin/env bash
# The Python recipe of docs/input.md ("Reading the results in Python", examples/read_results.py)
# reads what a run leaves: a 3 x 3 weave pulled to 0.3 % in 10 increments, then the recipe on its
# folder must print the final strain, the run's status and the contact points of the last step.
# Usage: read_results.sh YARNSIM REPO WORKDIR
set -u
yarnsim="$1"; repo="$2"; work="$3"
rm -rf "$work"; mkdir -p "$work"; cd "$work"
python=/usr/bin/python3 # Debian's, with python3-h5py (scripts/test installs it)
"$python" -c "import h5py, numpy" 2> /dev/null ||
  { echo "FAIL: $python cannot import h5py and numpy (scripts/test installs python3-h5py)"; exit 1; }
sed -e 's/^n_warp = .*/n_warp = 3/; s/^n_weft = .*/n_weft = 3/' \
  -e 's/^length_warp = .*/length_warp = 18.18182e-3/; s/^length_weft = .*/length_weft = 18.18182e-3/' \
  -e 's/^elements_per_spacing = .*/elements_per_spacing = 2/' \
  -e 's/^max_strain = .*/max_strain = 0.003/; s/^loading_time = .*/loading_time = 0.1/' \
  "$repo/examples/biaxial-k1.toml" > small.toml
"$yarnsim" run small.toml -o out -q --threads 2 > run.log 2>&1 || { echo "FAIL: the run failed"; cat run.log; exit 1; }
"$python" "$repo/examples/read_results.py" out > recipe.log 2>&1 || { echo "FAIL: the recipe failed"; cat recipe.log; exit 1; }
cat recipe.log
fail=0
grep -q "at the end: strain_warp 0.00300," recipe.log || { echo "FAIL: no final strain 0.003"; fail=1; }
grep -q "^status: completed" recipe.log || { echo "FAIL: no status"; fail=1; }
grep -Eq "^last step, t = 0.1 s: .* [1-9][0-9]* contact points carrying [0-9.]+ N$" recipe.log ||
  { echo "FAIL: no contact points at the last step"; fail=1; }
exit "$fail"
