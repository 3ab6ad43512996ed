#!/usr/bin/env bash
# Fabric decks built from TexGen files: every examples/biaxial-texgen-*.toml runs to its
# max_strain (the last row of curves.csv), and a deck whose .tg3 is missing or broken exits with
# code 2, naming the deck's texgen key and the file's own line and column.
# Usage: texgen.sh YARNSIM REPO WORKDIR
set -u
yarnsim="$1"; repo="$2"; work="$3"
source "$repo/tests/cli/lib/results.sh"
require_tools h5ls h5dump xmllint
rm -rf "$work"; mkdir -p "$work"; cd "$work"
fail=0
found=0
for deck in "$repo"/examples/biaxial-texgen-*.toml; do
  [ -e "$deck" ] || continue
  found=$((found + 1))
  name=$(basename "$deck" .toml)
  start=$(now)
  if ! "$yarnsim" run "$deck" -o "$name" -q --threads 2 > "$name.log" 2>&1; then
    echo "FAIL $name: exit not 0"; cat "$name.log"; fail=1; continue
  fi
  check_results "$name" "$name" "completed"
  # The more strained direction reaches max_strain (k >= 1: the warp, column 2).
  want=$(sed -n 's/^max_strain *= *\([0-9.eE+-]*\).*/\1/p' "$deck")
  k=$(sed -n 's/^strain_ratio *= *\([0-9.eE+-]*\).*/\1/p' "$deck")
  got=$(tail -1 "$name/curves.csv" | awk -F, -v k="$k" '{ print (k >= 1 ? $2 : $3) }')
  if ! awk -v a="$got" -v b="$want" 'BEGIN { d = a - b; if (d < 0) d = -d; exit !(b > 0 && d <= 1e-9 * b) }'; then
    echo "FAIL $name: reached strain $got, expected max_strain $want"; fail=1
  fi
  echo "ok $name: strain $got of $want in $(elapsed "$start") s; $(tail -1 "$name.log")"
done
[ "$found" -ge 2 ] || { echo "FAIL: expected at least 2 examples/biaxial-texgen-*.toml, found $found"; fail=1; }

# A deck next to a missing file, then a broken one: exit 2, the deck's key and the file's lines.
sed 's|^texgen = .*|texgen = "missing.tg3"|' "$repo/examples/biaxial-texgen-pweave.toml" > missing.toml
"$yarnsim" run missing.toml -o out-missing -q > missing.log 2>&1
code=$?
[ "$code" -eq 2 ] || { echo "FAIL missing: exit $code, expected 2"; cat missing.log; fail=1; }
grep -q "^missing.toml:13:10: fabric.texgen: expected a TexGen file .* found no file at missing.tg3" missing.log ||
  { echo "FAIL missing: message"; cat missing.log; fail=1; }
[ -e out-missing ] && { echo "FAIL missing: an output folder was made"; fail=1; }
sed 's/Width="0.8"/Width="-0.8"/' "$repo/../shared/data/texgen/pweave.tg3" > broken.tg3
sed 's|^texgen = .*|texgen = "broken.tg3"|; s|^nu = .*|nu = 0.7|' "$repo/examples/biaxial-texgen-pweave.toml" > broken.toml
"$yarnsim" run broken.toml -o out-broken -q > broken.log 2>&1
code=$?
[ "$code" -eq 2 ] || { echo "FAIL broken: exit $code, expected 2"; cat broken.log; fail=1; }
for pattern in "^broken.toml:13:10: fabric.texgen: expected a TexGen file that reads cleanly, found 4 problem(s) in broken.tg3" \
  "^broken.tg3:15:73: <Section> attribute 'Width': expected a number > 0, found \"-0.8\"" \
  "^broken.toml:17:6: fabric.nu: expected a number in (-1, 0.5\]" "the deck has 6 problem(s)"; do
  grep -q -- "$pattern" broken.log || { echo "FAIL broken: message lacks '$pattern'"; cat broken.log; fail=1; }
done
if [ "$fail" -eq 0 ]; then echo "texgen: all checks passed"; fi
exit "$fail"
