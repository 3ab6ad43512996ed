#!/usr/bin/env bash
# scripts/render-results draws what a run leaves: a 3 x 3 weave pulled to 0.3 %, drawn at its
# first step (iso view, the yarn surfaces) and its last (top view, with the contact points and the
# spline contact's tubes). Each picture must be a PNG of the asked size in which the yarns cover a
# good part of the frame (the pixels are counted by ParaView's own PNG reader); a results folder
# without surfaces (the XDMF's surface collections removed) must be refused with exit 1.
# Usage: render.sh YARNSIM REPO WORKDIR
set -u
yarnsim="$1"; repo="$2"; work="$3"
rm -rf "$work"; mkdir -p "$work"; cd "$work"
command -v pvpython > /dev/null && command -v xvfb-run > /dev/null ||
  { echo "FAIL: pvpython or xvfb-run missing (scripts/test installs python3-paraview and xvfb)"; exit 1; }
sed -e 's/^n_warp = .*/n_warp = 3/; s/^n_weft = .*/n_weft = 3/' \
  -e 's/^length_warp = .*/length_warp = 18.18182e-3/; s/^length_weft = .*/length_weft = 18.18182e-3/' \
  -e 's/^elements_per_spacing = .*/elements_per_spacing = 2/' \
  -e 's/^max_strain = .*/max_strain = 0.003/; s/^loading_time = .*/loading_time = 0.1/' \
  "$repo/examples/biaxial-k1.toml" > small.toml
"$yarnsim" run small.toml -o out -q > run.log 2>&1 || { echo "FAIL: the run failed"; cat run.log; exit 1; }
fail=0
render() { # name, then render-results options
  local name="$1"; shift
  "$repo/scripts/render-results" out/results.xdmf -o "$name.png" "$@" > "$name.log" 2>&1 ||
    { echo "FAIL: render-results $* exited $?"; cat "$name.log"; fail=1; return; }
  cat "$name.log"
}
render iso --time first --size 800 500
render top --time last --view top --tubes --size 600 600
# Coverage: the share of pixels that are not the white background.
cat > coverage.py <<'PY'
import sys
from paraview.vtk.vtkIOImage import vtkPNGReader
from paraview.vtk.util.numpy_support import vtk_to_numpy
r = vtkPNGReader(); r.SetFileName(sys.argv[1]); r.Update()
image = r.GetOutput()
w, h, _ = image.GetDimensions()
rgb = vtk_to_numpy(image.GetPointData().GetScalars())[:, :3]
print("%d %d %.3f" % (w, h, (rgb.min(axis=1) < 250).mean()))
PY
check() { # name, width, height, least coverage
  [ -f "$1.png" ] || { echo "FAIL: $1.png missing"; fail=1; return; }
  read -r w h cover < <(pvpython coverage.py "$1.png" 2> /dev/null | tail -1)
  echo "$1.png: ${w}x${h}, ${cover} of the pixels drawn"
  [ "$w" = "$2" ] && [ "$h" = "$3" ] || { echo "FAIL: $1.png is ${w}x${h}, expected $2x$3"; fail=1; }
  awk -v c="$cover" -v m="$4" 'BEGIN { exit !(c >= m && c < 0.99) }' ||
    { echo "FAIL: $1.png has $cover of its pixels drawn, expected $4 to 0.99"; fail=1; }
}
check iso 800 500 0.05
check top 600 600 0.20
# Results without surfaces: a clear refusal.
python3 - out/results.xdmf > old.xdmf <<'PY'
import re, sys
text = open(sys.argv[1]).read()
print(re.sub(r'    <Grid Name="(surfaces|contact_tubes)" GridType="Collection".*?\n    </Grid>\n', '',
             text, flags=re.S), end="")
PY
cp old.xdmf out/old.xdmf
"$repo/scripts/render-results" out/old.xdmf -o old.png > old.log 2>&1
status=$?
[ "$status" = 1 ] && grep -q "has no yarn surfaces" old.log ||
  { echo "FAIL: results without surfaces: exit $status, expected 1 with a message"; cat old.log; fail=1; }
exit "$fail"
