# Checks of the files a run leaves behind, shared by the command-line tests (sourced, not run).
# Needs h5ls and h5dump (Debian package hdf5-tools) and xmllint (libxml2-utils).
# Every check prints "FAIL <what>" and sets fail=1 on a problem; the caller owns $fail.

# The reader must not wait on, or take, a lock of a file another process may still be writing.
export HDF5_USE_FILE_LOCKING=FALSE

# Wall-clock seconds, and seconds elapsed since a time taken with now() (two decimals).
now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.2f", b - a }'; }

# Runs $yarnsim with the arguments, output into LABEL.log; sets fail=1 (and shows the log) unless
# it exits with the expected code.
expect() { # label expected-code args...
  local label="$1" code="$2"; shift 2
  "$yarnsim" "$@" > "$label.log" 2>&1
  local got=$?
  [ "$got" -eq "$code" ] || { echo "FAIL $label: exit $got, expected $code"; cat "$label.log"; fail=1; }
}

# True when $yarnsim was built with AddressSanitizer (scripts/test --sanitize): its runs are
# tens of times slower than in Release.
built_with_sanitizers() { ldd "$yarnsim" 2> /dev/null | grep -q libasan; }

require_tools() { # tool...
  local t
  for t in "$@"; do
    command -v "$t" > /dev/null || { echo "FAIL: $t is missing (scripts/setup installs it)"; exit 1; }
  done
}

# Number of groups under /steps of an HDF5 file; nothing (and status 1) when it does not open.
h5_step_count() { # file.h5
  local list
  list=$(h5ls "$1/steps" 2> /dev/null) || return 1
  printf '%s\n' "$list" | grep -c ' Group$' || true
}

# A string attribute of the root group, without quotes.
h5_root_attribute() { # file.h5 name
  h5dump -w 0 -a "/$2" "$1" 2> /dev/null | sed -n 's/^ *(0): "\(.*\)"$/\1/p'
}

# The "time" attributes of the groups under /steps, one a line, in group order.
h5_step_times() { # file.h5
  h5dump -w 0 -m %.17g -A -g /steps "$1" 2> /dev/null |
    awk '/ATTRIBUTE "time"/ { want = 1 } want && /\(0\):/ { print $2; want = 0 }'
}

# The results of a run that stopped: results.h5 opens, its status starts with the expected word,
# its /steps groups are 000000 ... n-1 with increasing times, and every monitor CSV has a row for
# the initial state (t = 0) and then a complete row per step with the same times (all decks of
# these tests write every increment).
# Sets $steps to the number of steps.
check_results() { # label dir expected-status-prefix
  local label="$1" dir="$2" status_prefix="$3"
  local h5="$dir/results.h5" n status
  steps=-1
  if ! h5ls "$h5" > /dev/null 2>&1; then
    echo "FAIL $label: $h5 does not open"
    fail=1
    return 1
  fi
  n=$(h5_step_count "$h5")
  status=$(h5_root_attribute "$h5" status)
  case "$status" in
    "$status_prefix"*) ;;
    *) echo "FAIL $label: status is '$status', expected '$status_prefix...'"; fail=1 ;;
  esac
  [ -n "$(h5_root_attribute "$h5" message)" ] || { echo "FAIL $label: no message attribute"; fail=1; }
  local expected_names got_names
  expected_names=$(for ((i = 0; i < n; ++i)); do printf '%06d\n' "$i"; done)
  got_names=$(h5ls "$h5/steps" | awk '{ print $1 }')
  [ "$expected_names" = "$got_names" ] || { echo "FAIL $label: /steps groups are not 000000 ... $((n - 1))"; fail=1; }
  local times
  times=$(h5_step_times "$h5")
  if ! printf '%s\n' "$times" | awk 'NF { if (NR > 1 && $1 + 0 <= prev) exit 1; prev = $1 + 0 }'; then
    echo "FAIL $label: step times do not increase"
    fail=1
  fi
  local csv
  for csv in "$dir"/*.csv; do
    [ -e "$csv" ] || continue
    if [ "$(basename "$csv")" = contact_points.csv ]; then
      check_contact_points "$label" "$csv" "$n" "$times"
    else
      check_csv "$label" "$csv" "$n" "$times"
    fi
  done
  if [ -s "$dir/results.xdmf" ]; then
    check_xdmf "$label" "$dir/results.xdmf" "$n"
  else
    echo "FAIL $label: no results.xdmf"
    fail=1
  fi
  steps=$n
}

# A CSV ends with a line break, every row has the header's number of numeric fields, the first
# row is the initial state (time 0), then there is one row per step and its first column is the
# step's time.
check_csv() { # label file.csv steps times
  local label="$1" csv="$2" n="$3" times="$4"
  if [ -s "$csv" ] && [ "$(tail -c 1 "$csv" | od -An -c | tr -d ' ')" != '\n' ]; then
    echo "FAIL $label: $(basename "$csv") ends in the middle of a row"
    fail=1
  fi
  local bad
  bad=$(awk -F, 'NR == 1 { cols = NF; next }
                 NF != cols { print "row " NR - 1 " has " NF " fields, the header " cols; exit }
                 { for (i = 1; i <= NF; ++i)
                     if ($i !~ /^[-+]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][-+]?[0-9]+)?$/ && $i !~ /^-?(inf|nan)$/) {
                       print "row " NR - 1 " field " i " is \"" $i "\""; exit } }' "$csv")
  [ -z "$bad" ] || { echo "FAIL $label: $(basename "$csv"): $bad"; fail=1; }
  local rows
  rows=$(($(wc -l < "$csv") - 1))
  [ "$rows" -eq $((n + 1)) ] || { echo "FAIL $label: $(basename "$csv") has $rows rows, results.h5 $n steps (expected a row at t = 0 and one per step)"; fail=1; }
  [ "$(sed -n 2p "$csv" | cut -d, -f1)" = "0" ] || { echo "FAIL $label: the first row of $(basename "$csv") is not at t = 0"; fail=1; }
  # Same times, to 1e-9 relative.
  if ! paste -d' ' <(printf '%s\n' "$times") <(tail -n +3 "$csv" | cut -d, -f1) |
    awk 'NF == 0 { next } NF != 2 { exit 1 }
         { d = $1 - $2; if (d < 0) d = -d; s = $1 < 0 ? -$1 : $1; if (d > 1e-9 * (s + 1e-300)) exit 1 }'; then
    echo "FAIL $label: the times of $(basename "$csv") differ from those of results.h5"
    fail=1
  fi
}

# contact_points.csv (a row per active contact point) ends with a line break, every row has the
# header's number of fields, its increments do not decrease, and each row's time is 0 (the
# initial state) or that of a step of results.h5, in order.
check_contact_points() { # label file.csv steps times
  local label="$1" csv="$2" n="$3" times="$4"
  if [ -s "$csv" ] && [ "$(tail -c 1 "$csv" | od -An -c | tr -d ' ')" != '\n' ]; then
    echo "FAIL $label: contact_points.csv ends in the middle of a row"
    fail=1
  fi
  local bad
  bad=$(printf '%s\n' "$times" | awk -F, -v n="$n" '
    FNR == NR { if (NF) t[FNR] = $1 + 0; next }
    FNR == 1 { cols = NF; t[0] = 0; j = 0; next }
    NF != cols { print "row " FNR - 1 " has " NF " fields, the header " cols; exit }
    $1 !~ /^[0-9]+$/ || $1 + 0 < prev { print "row " FNR - 1 ": increment " $1 " after " prev; exit }
    { prev = $1 + 0
      while (j <= n) { d = $2 - t[j]; if (d < 0) d = -d; s = t[j] < 0 ? -t[j] : t[j]
                       if (d <= 1e-9 * (s + 1e-300)) break; ++j }
      if (j > n) { print "row " FNR - 1 ": time " $2 " is not 0 or a step time of results.h5 (in order)"; exit } }' - "$csv")
  [ -z "$bad" ] || { echo "FAIL $label: contact_points.csv: $bad"; fail=1; }
}

# results.xdmf is well-formed XML and its "yarns" collection has one grid per step.
check_xdmf() { # label file.xdmf steps
  local label="$1" xdmf="$2" n="$3"
  if ! xmllint --noout "$xdmf" 2> "$xdmf.lint"; then
    echo "FAIL $label: results.xdmf is not well-formed XML:"
    head -5 "$xdmf.lint"
    fail=1
    return
  fi
  local grids
  grids=$(xmllint --xpath 'count(//Grid[@Name="yarns" and @CollectionType="Temporal"]/Grid)' "$xdmf")
  [ "$grids" = "$n" ] || { echo "FAIL $label: results.xdmf lists $grids steps, results.h5 $n"; fail=1; }
  [ -e "$(dirname "$xdmf")/results.xdmf.tmp" ] && { echo "FAIL $label: results.xdmf.tmp left behind"; fail=1; }
  return 0
}
