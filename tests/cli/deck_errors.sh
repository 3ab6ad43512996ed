#!/usr/bin/env bash
# Bad decks exit with code 2 and name file:line and the key; every error of a deck is reported.
# Usage: deck_errors.sh YARNSIM REPO WORKDIR
set -u
yarnsim="$1"; repo="$2"; work="$3"
rm -rf "$work"; mkdir -p "$work"; cd "$work"
fail=0
check() { # name, expected exit code, pattern(s) the message must contain
  local name="$1" code="$2"; shift 2
  "$yarnsim" run "$name.toml" -o "out-$name" -q > "$name.log" 2>&1
  local got=$?
  if [ "$got" -ne "$code" ]; then echo "FAIL $name: exit $got, expected $code"; cat "$name.log"; fail=1; fi
  for pattern in "$@"; do
    grep -q -- "$pattern" "$name.log" || { echo "FAIL $name: message lacks '$pattern'"; cat "$name.log"; fail=1; }
  done
}
base() { # a valid cantilever deck with one substitution applied by sed
  sed "$1" "$repo/examples/rollup.toml"
}
base 's/^EI = \(.*\)/EIX = \1/' > unknown-key.toml
check unknown-key 2 "unknown-key.toml:[0-9]*:[0-9]*:" "EIX" "did you mean"
base 's/^EA = .*/EA = "stiff"/' > wrong-type.toml
check wrong-type 2 "wrong-type.toml:[0-9]*:[0-9]*:" "EA" "expected a number"
base 's/^EA = .*/EA = -1.0/' > negative.toml
check negative 2 "negative.toml:[0-9]*:[0-9]*:" "EA" "> 0"
base 's/^moment = \(.*\)/moment = \1\naxes = "local"/' > bad-axes.toml
check bad-axes 2 "bad-axes.toml:29:[0-9]*:" "loads\[0\].axes" 'expected "global" or "section", found "local"'
base 's/node_set = "beam.end"/node_set = "beam.edn"/' > missing-set.toml
check missing-set 2 "missing-set.toml:[0-9]*:[0-9]*:" "beam.edn"
cat "$repo/examples/rollup.toml" > missing-node.toml
printf '\n[[node_sets]]\nname = "ghost"\nnodes = [9999]\n' >> missing-node.toml
check missing-node 2 "missing-node.toml:[0-9]*:[0-9]*:" "9999"
base 's/^EI = \(.*\)/EIX = \1/; s/^EA = .*/EA = -1.0/; s/node_set = "beam.end"/node_set = "beam.edn"/' > three.toml
check three 2 "EIX" "EA" "beam.edn" "3 problem"
check no-such-file 2 "no-such-file.toml"
"$yarnsim" --version | grep -q "yarnsim" || { echo "FAIL --version"; fail=1; }
"$yarnsim" --help > help.log 2>&1 || { echo "FAIL --help exit"; fail=1; }
"$yarnsim" run > usage.log 2>&1; [ $? -eq 2 ] || { echo "FAIL usage exit"; fail=1; }
"$yarnsim" run "$repo/examples/rollup.toml" --threads 0 > threads.log 2>&1; [ $? -eq 2 ] || { echo "FAIL --threads 0"; fail=1; }
# eigen-lu is no longer a choice: CLI11 refuses it and lists the valid ones.
"$yarnsim" run "$repo/examples/rollup.toml" -o eigen-lu -q --linear-solver eigen-lu > eigen-lu.log 2>&1
[ $? -eq 2 ] || { echo "FAIL --linear-solver eigen-lu: exit not 2"; cat eigen-lu.log; fail=1; }
grep -q "eigen-lu not in {auto,lu,ldlt,ldlt-gmres,mumps,petsc}" eigen-lu.log || { echo "FAIL --linear-solver eigen-lu: message does not list the choices"; cat eigen-lu.log; fail=1; }
[ -e eigen-lu ] && { echo "FAIL --linear-solver eigen-lu: an output folder was made"; fail=1; }
# petsc is the MPI build's (this suite runs in the default build): refused, exit 2, saying where.
"$yarnsim" run "$repo/examples/rollup.toml" -o petsc -q --linear-solver petsc > petsc.log 2>&1
[ $? -eq 2 ] || { echo "FAIL --linear-solver petsc: exit not 2"; cat petsc.log; fail=1; }
grep -q "made without MPI and PETSc.*YARNSIM_MPI" petsc.log || { echo "FAIL --linear-solver petsc: the message does not say where it is"; cat petsc.log; fail=1; }
[ -e petsc ] && { echo "FAIL --linear-solver petsc: an output folder was made"; fail=1; }
if [ "$fail" -eq 0 ]; then echo "deck errors: all checks passed"; fi
exit "$fail"
