# Decks the command-line tests share.

# The roll-up deck as a static run that cannot converge: two steps, the first completes (5
# increments to t = 0.25 s), the second meets a load jumping a hundredfold within 0.05 s with 6
# Newton iterations and dt_min = dt / 5 allowed. Applied moments: the LU solvers.
diverging_rollup_deck() { # repo file
  sed -e 's/^table = .*/table = [[0.0, 0.0], [0.25, 0.25], [0.3, 100.0], [1.0, 100.0]]/' \
    "$1/examples/rollup.toml" | sed '/^\[\[steps\]\]/,$d' > "$2"
  cat >> "$2" << 'DECK'
[[steps]]
type = "static"
end_time = 0.25
dt = 0.05
max_iterations = 30

[[steps]]
type = "static"
end_time = 1.0
dt = 0.05
dt_min = 0.01
max_iterations = 6
DECK
}
