#!/usr/bin/env bash
# `yarnsim check DECK` reads a deck (model deck, woven or TexGen fabric deck) without running it:
# exit 0 and a report of the model (nodes, elements, DOF, contact definitions with their
# candidate pairs, the initial clearance, the stable explicit step, the steps), no output folder;
# a bad deck exits 2 with its problems.
# Usage: check.sh YARNSIM REPO WORKDIR
set -u
yarnsim="$1"; repo="$2"; work="$3"
rm -rf "$work"; mkdir -p "$work"; cd "$work"
fail=0
check() { # label deck pattern...
  local label="$1" deck="$2"; shift 2
  "$yarnsim" check "$deck" > "$label.log" 2>&1
  local code=$?
  [ "$code" -eq 0 ] || { echo "FAIL $label: exit $code, expected 0"; cat "$label.log"; fail=1; return; }
  for pattern in "$@"; do
    grep -q -- "$pattern" "$label.log" || { echo "FAIL $label: report lacks '$pattern'"; cat "$label.log"; fail=1; }
  done
}
# TexGen fabric: 12 yarns of 24 elements (49 nodes each), the warp-weft spline contact.
check pweave "$repo/examples/biaxial-texgen-pweave.toml" \
  "^model: 588 nodes, 288 elements (3-node beams), 3528 DOF" \
  "^yarns: 6 warp + 6 weft (biaxial test, k = 1, to 1 % strain)" \
  "^  spline contact 'warp-weft': 6 x 6 splines, linear, penalty 1.5e+06 N/m" \
  "^  spline contact at the initial configuration: [1-9][0-9]* candidate pair(s) from the broad phase, 0 active" \
  "^spline contact: initial clearance 0.00785156 mm" \
  "^  step 1: dynamic, t = 0 to 1 s, dt 0.02 s" \
  "^explicit path (no step uses it): stable step [0-9.e-]* s without mass scaling" \
  "^the deck is fine: nothing was run"
# An explicit woven deck: its step's stable step with the mass scaling.
check explicit "$repo/examples/biaxial-k1-explicit.toml" \
  "^  step 1: explicit, t = 0 to 1 s, dt 2e-05 s (50000 increments); stable step [0-9.e-]* s (safety 0.8 x critical [0-9.e-]* s, set by [a-z]* .*) with mass scaled to 2e-05 s"
# A surface contact deck and a model deck without contact.
check surface "$repo/examples/biaxial-surface-k1.toml" \
  "^  surface contact 'warp-weft': 6 x 6 surfaces, linear, penalty 350000 N/m" \
  "^  surface contact at the initial configuration: [1-9][0-9]* candidate pair(s)" "^surface contact: initial clearance"
# With torsional friction on the surface contact: said in its line.
sed 's/^friction = 0.2 .*/friction = 0.2\ntorsional_friction = true/' \
  "$repo/examples/biaxial-surface-k1-friction.toml" > surface-torsion.toml
check surface-torsion surface-torsion.toml \
  "^  surface contact 'warp-weft': .*, friction mu = 0.2, tangential penalty 350000 N/m (the stick displacement mu f_n / eps_t is 0.000571 mm per N of normal force), torsional friction at the crossings (radius from the yarn widths, penalty tangential penalty x radius^2)$"
rm -f surface-torsion.toml
# With an elastic slip: said in place of the tangential penalty, on every spline contact.
check elastic-slip "$repo/examples/bias-extension-twintex-friction.toml" \
  "^  spline contact 'warp-weft': .*, friction mu = 0.2, elastic slip 0.005 mm (the stick stiffness mu f_n / elastic slip)$" \
  "^explicit path (no step uses it): not available with the elastic slip of contact 'warp-weft'" \
  "^  section 'yarn': EA 3.3e+04 N, EI1 7.425e-05 N m^2 (about axis 1), EI2 7.422e-05 N m^2 (about axis 2), GJ 0.001213 N m^2$"
# The sections' stiffnesses follow reduce_upper_inertia (the in-plane bending of the flat yarn):
# another factor, and none (the solid ellipse's in-plane inertia).
sed 's/^reduce_upper_inertia = .*/reduce_upper_inertia = 0.005/' \
  "$repo/examples/bias-extension-twintex-friction.toml" > upper.toml
check upper upper.toml \
  "^  section 'yarn': EA 3.3e+04 N, EI1 7.425e-05 N m^2 (about axis 1), EI2 0.0001819 N m^2 (about axis 2), GJ 0.001213 N m^2$"
sed '/^reduce_upper_inertia = /d' "$repo/examples/bias-extension-twintex-friction.toml" > upper.toml
check solid upper.toml \
  "^  section 'yarn': EA 3.3e+04 N, EI1 7.425e-05 N m^2 (about axis 1), EI2 0.03638 N m^2 (about axis 2), GJ 0.001213 N m^2$"
rm -f upper.toml
check pweave-sections "$repo/examples/biaxial-texgen-pweave.toml" "^sections: 4," "^  section 'section3': EA 2356 N"
check rollup "$repo/examples/rollup.toml" "^model: [0-9]* nodes" "^contact definitions: 0" "^  step 1: static"
grep -q "clearance" rollup.log && { echo "FAIL rollup: a clearance line without contact"; fail=1; }
ls | grep -qv '\.log$' && { echo "FAIL: check left files behind: $(ls)"; fail=1; }
# A bad deck: exit 2, its problems listed.
sed 's/^nu = .*/nu = 0.7/' "$repo/examples/biaxial-texgen-pweave.toml" > bad.toml
sed -i 's|^texgen = .*|texgen = "'"$repo"'/../shared/data/texgen/pweave.tg3"|' bad.toml
"$yarnsim" check bad.toml > bad.log 2>&1
code=$?
[ "$code" -eq 2 ] || { echo "FAIL bad: exit $code, expected 2"; cat bad.log; fail=1; }
grep -q "^bad.toml:17:6: fabric.nu: expected a number in (-1, 0.5\], found 0.7" bad.log ||
  { echo "FAIL bad: message"; cat bad.log; fail=1; }
"$yarnsim" check no-such-deck.toml > none.log 2>&1
[ $? -eq 2 ] || { echo "FAIL no-such-deck: exit not 2"; fail=1; }
if [ "$fail" -eq 0 ]; then echo "check: all checks passed"; fi
exit "$fail"
