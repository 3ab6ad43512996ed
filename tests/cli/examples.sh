#!/usr/bin/env bash
# Every example deck runs to completion with `yarnsim run` and leaves its results.
# Usage: examples.sh YARNSIM REPO WORKDIR
set -u
yarnsim="$1"; repo="$2"; work="$3"
source "$(dirname "${BASH_SOURCE[0]}")/lib/results.sh"
rm -rf "$work"; mkdir -p "$work"
fail=0
# Built with AddressSanitizer (scripts/test --sanitize) every deck runs its first 20 increments
# only (exit 130, or 0 if it has fewer): the sanitizers look at the code paths, which the first
# increments take; the Release suite runs each deck as below. Whole, the frictionless bias
# extension alone (48 s in Release) took most of this test's time under the sanitizers.
sanitized=0
if built_with_sanitizers; then sanitized=1; fi
for deck in "$repo"/examples/*.toml; do
  name=$(basename "$deck" .toml)
  case "$name" in
    biaxial-*) continue ;; # the fabric studies are run by their own tests (cli.study, Biaxial.*)
    # Study decks (not model decks): run by `yarnsim study`; read by Study.ExampleStudiesRead,
    # a small study of the same tests run by Study.* (the picture frame takes 10 minutes).
    *-study) continue ;;
    # Run whole by ParallelContact.TheDoubleHelixTwistsAFullTurn, which checks where it ends:
    # twice the same 200 increments (7 s in Release, over 3 minutes under the sanitizers).
    double-helix) continue ;;
  esac
  # The picture frame runs to 65 degrees, past locking (about 9 minutes in Release): its first 40
  # increments here (the pretension and the start of the shear), which must stop as asked (exit
  # 130) with their results; PictureFrame.* run a smaller frame whole.
  # The benchmark-like 12 x 12 frame likewise: its first 10 increments (the pretension).
  extra=(); expect=0
  if [ "$name" = picture-frame ]; then extra=(--stop-after 40); expect=130; fi
  if [ "$name" = picture-frame-twintex ]; then extra=(--stop-after 10); expect=130; fi
  # The frictional bias extension (about a minute on two threads): the compaction and the start of
  # the pull; the whole run is in docs/verification.md, "Bias extension".
  if [ "$name" = bias-extension-twintex-friction ]; then extra=(--stop-after 80); expect=130; fi
  if [ "$sanitized" -eq 1 ]; then extra=(--stop-after 20); expect=130; fi
  "$yarnsim" run "$deck" -o "$work/$name" -q --threads 2 "${extra[@]}" > "$work/$name.log" 2>&1
  status=$?
  # A deck of fewer increments than the sanitizers' 20 completes (exit 0).
  if [ "$status" -ne "$expect" ] && ! { [ "$sanitized" -eq 1 ] && [ "$status" -eq 0 ]; }; then
    echo "FAIL $name (exit $status, expected $expect)"; cat "$work/$name.log"; fail=1; continue
  fi
  for f in results.h5 results.xdmf; do
    [ -s "$work/$name/$f" ] || { echo "FAIL $name: no $f"; fail=1; }
  done
  echo "ok $name: $(tail -1 "$work/$name.log")"
done
exit "$fail"
