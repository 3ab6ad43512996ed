#!/usr/bin/env bash
# `yarnsim study` with a case on both integration paths (`paths = ["implicit", "explicit"]`): one
# run per path in DIR/<case>/<path>/, curves.csv with a path column, summary.csv with a row per
# run (wall time, increments, mass scaling, kinetic/internal energy, difference to the implicit
# curve), the force-strain plot with both runs and their wall times in the legend. Bad `paths`
# are refused with exit code 2. A study of a picture frame and a uniaxial tension writes their own
# files; a case deck without a test block is refused with exit code 2.
# Usage: study.sh YARNSIM REPO WORKDIR
set -u
yarnsim="$1"; repo="$2"; work="$3"
rm -rf "$work"; mkdir -p "$work"; cd "$work"
fail=0
check() { # description command...
  local what="$1"; shift
  "$@" || { echo "FAIL: $what"; fail=1; }
}

# A 2 x 2 weave of the paper's fabric to 0.5 % in 1 s; the explicit run mass-scaled to 1e-4 s.
cat > fabric.toml <<'DECK'
title = "2 x 2 weave"
[fabric]
n_warp = 2
n_weft = 2
spacing_warp = 4.54545e-3
spacing_weft = 4.54545e-3
length_warp = 22.72725e-3
length_weft = 22.72725e-3
gap = 0.11364e-3
a = 1.136364e-3
b = 0.2840909e-3
EA = 38000.0
nu = 0.2
density = 2540.0
elements_per_spacing = 2

[biaxial]
strain_ratio = 1
max_strain = 0.005
type = "dynamic"

[biaxial.explicit]
mass_scaling_dt = 1e-4
output_every = 50
DECK
cat > study.toml <<'DECK'
title = "Two paths"
contact_maps = ["weave"]
[[cases]]
name = "weave"
label = "2 x 2"
deck = "fabric.toml"
paths = ["implicit", "explicit"]
DECK
"$yarnsim" study study.toml --output out --threads 2 > study.log 2>&1
code=$?
[ "$code" -eq 0 ] || { echo "FAIL: study exit $code"; cat study.log; fail=1; }
for f in weave/implicit/curves.csv weave/explicit/curves.csv weave/explicit/energy.csv \
         curves.csv summary.csv force-strain-k1.png force-strain-k1.gp \
         contact-forces-weave-implicit.png contact-forces-weave-explicit.png; do
  check "out/$f missing or empty" test -s "out/$f"
done
check "the implicit run wrote an energy.csv" test ! -e out/weave/implicit/energy.csv
check "curves.csv header" grep -qx 'case,label,path,k,time \[s\],strain_warp \[-\],strain_weft \[-\],force_warp \[N\],force_weft \[N\]' out/curves.csv
check "curves.csv has no implicit rows" grep -q '^weave,2 x 2,implicit,1,' out/curves.csv
check "curves.csv has no explicit rows" grep -q '^weave,2 x 2,explicit,1,' out/curves.csv
check "summary.csv has not 1 header + 2 rows" test "$(wc -l < out/summary.csv)" -eq 3
# The explicit row: 10 000 increments of 1e-4 s, mass added, both measures past the toe filled in.
explicit_row=$(grep '^weave,2 x 2,explicit,' out/summary.csv)
check "summary: explicit row '$explicit_row'" awk -F, '{ exit !($6 == 10000 && $7 == 0 && $8 == 1e-04 + 0 && $9 == 1e-04 + 0 && $10 > 0 && $11 != "" && $12 != "") }' <<< "$explicit_row"
implicit_row=$(grep '^weave,2 x 2,implicit,' out/summary.csv)
check "summary: implicit row '$implicit_row'" awk -F, '{ exit !($6 > 0 && $7 > 0 && $8 == "" && $10 == "" && $12 == "") }' <<< "$implicit_row"
# Both runs in the legend, with their wall time and increments.
check "legend lacks the implicit run" grep -Eq '"2 x 2, implicit \([0-9.]+ s, [0-9]+ increments\) warp"' out/force-strain-k1.gp
check "legend lacks the explicit run" grep -Eq '"2 x 2, explicit \([0-9.]+ s, 10000 increments\) warp"' out/force-strain-k1.gp
check "the study did not print the summary" grep -q '2 x 2, explicit: .* 10000 increments, mass scaling added' study.log

# Bad paths: exit code 2, every problem named.
sed 's/paths = .*/paths = ["explicit", "explicitt", "explicit"]/' study.toml > bad.toml
"$yarnsim" study bad.toml --output bad > bad.log 2>&1
code=$?
[ "$code" -eq 2 ] || { echo "FAIL: bad paths exit $code, expected 2"; cat bad.log; fail=1; }
check "bad paths: no message for 'explicitt'" grep -q 'cases\[0\].paths\[1\]: expected "implicit" or "explicit", found "explicitt"' bad.log
check "bad paths: no message for the repeat" grep -q 'cases\[0\].paths\[2\]: "explicit" is listed twice' bad.log

# A study of the other tests: a 4 x 4 picture frame (clamped, to 10 degrees) and a 3 x 3 uniaxial
# tension, about a second each; their own curves, summaries and plots, no biaxial files.
cat > frame.toml <<'DECK'
title = "4 x 4 frame"
[fabric]
n_warp = 4
n_weft = 4
spacing_warp = 4e-3
spacing_weft = 4e-3
length_warp = 20e-3
length_weft = 20e-3
gap = 0.1e-3
a = 1e-3
b = 0.3e-3
E = 3.7e10
nu = 0.2
density = 2540.0

[picture_frame]
max_angle = 10
ends = "clamped"
type = "static"
DECK
sed -e 's/n_warp = 4/n_warp = 3/; s/n_weft = 4/n_weft = 3/; s/20e-3/12e-3/' \
    -e '/^\[picture_frame\]/,$d' frame.toml > uniaxial.toml
printf '[uniaxial]\nmax_strain = 0.005\ntype = "dynamic"\n' >> uniaxial.toml
printf '[[cases]]\nname = "frame"\ndeck = "frame.toml"\n\n[[cases]]\nname = "warp"\ndeck = "uniaxial.toml"\n' > shear.toml
"$yarnsim" study shear.toml --output shear > shear.log 2>&1
code=$?
[ "$code" -eq 0 ] || { echo "FAIL: shear study exit $code"; cat shear.log; fail=1; }
for f in curves-picture_frame.csv summary-picture_frame.csv force-displacement-picture_frame.png \
         shear-picture_frame.png angle-picture_frame.png deformed-frame.png \
         curves-uniaxial.csv summary-uniaxial.csv uniaxial.png; do
  check "shear/$f missing or empty" test -s "shear/$f"
done
check "a study without biaxial cases wrote curves.csv" test ! -e shear/curves.csv
check "shear study: curves files not printed" grep -q '^curves: shear/curves-uniaxial.csv$' shear.log
check "shear study: the frame's summary not printed" grep -q '^frame: .* increments; frame angle 10.00 deg, measured' shear.log
# A case whose deck has no test block: exit code 2 before anything runs, at the case's deck key.
printf 'title = "beams"\n' > model.toml
printf '[[cases]]\nname = "m"\ndeck = "model.toml"\n' > no-test.toml
"$yarnsim" study no-test.toml --output no-test > no-test.log 2>&1
code=$?
[ "$code" -eq 2 ] || { echo "FAIL: a deck without a test exit $code, expected 2"; cat no-test.log; fail=1; }
check "no test block: no message" grep -q 'no-test.toml:3:8: cases\[0\].deck: expected a fabric deck with a test block' no-test.log
check "no test block: something ran" test ! -e no-test
[ "$fail" -eq 0 ] && echo "ok: $(grep -c . out/summary.csv) lines in summary.csv"
exit "$fail"
