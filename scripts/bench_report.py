#!/usr/bin/env python3
"""Summary of bench_weave's JSON for scripts/bench: growth exponents and thread speed-ups.

  scripts/bench_report.py results/bench/bench_weave.json >> results/bench/report.txt

For each solver and thread count, the exponent p of time ~ DOF^p, fitted by least squares on
log(time) against log(DOF) over the weaves n = 12 ... 96 present in the file, for the time per
Newton iteration and for each stage; then the speed-up of 2 threads over 1 per weave (assembly,
whole iteration). Targets (issue 7): iteration exponent <= 1.5, n = 96 iteration <= 3 s on two
threads, assembly speed-up >= 1.7.
"""
import json
import math
import sys
from collections import defaultdict

STAGES = ["iteration_ms", "graph_ms", "broad_ms", "narrow_ms", "beam_assembly_ms",
          "other_assembly_ms", "assembly_ms", "factorisation_ms", "solve_ms"]
SOLVERS = {0: "auto (SimplicialLDLT)", 1: "cholmod (supernodal LL^T)", 2: "lu (UMFPACK)"}
FIT_FROM = 12


def fit_exponent(points):
    """Least-squares slope of log(y) against log(x); None with fewer than two usable points."""
    pts = [(math.log(x), math.log(y)) for x, y in points if x > 0 and y > 0]
    if len(pts) < 2:
        return None
    mx = sum(p[0] for p in pts) / len(pts)
    my = sum(p[1] for p in pts) / len(pts)
    sxx = sum((p[0] - mx) ** 2 for p in pts)
    sxy = sum((p[0] - mx) * (p[1] - my) for p in pts)
    return sxy / sxx if sxx > 0 else None


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: bench_report.py bench_weave.json")
    with open(sys.argv[1]) as f:
        data = json.load(f)
    # runs[(solver, threads)][n] = counters
    runs = defaultdict(dict)
    for b in data.get("benchmarks", []):
        parts = b["name"].split("/")
        if parts[0] != "BM_NewtonIterationWeave" or b.get("error_occurred"):
            continue
        n, threads, solver = int(parts[1]), int(parts[2]), int(parts[3])
        runs[(solver, threads)][n] = b
    if not runs:
        print("bench_weave: no Newton-iteration results")
        return
    print("== growth with the DOF, time ~ DOF^p, fitted over n = %d ... 96 (bench_weave)" % FIT_FROM)
    for (solver, threads), by_n in sorted(runs.items()):
        ns = sorted(n for n in by_n if n >= FIT_FROM)
        label = "%s, %d thread(s), n = %s" % (SOLVERS.get(solver, solver), threads,
                                                ", ".join(map(str, ns)))
        print(label)
        for stage in STAGES:
            p = fit_exponent([(by_n[n]["dof"], by_n[n].get(stage, 0.0)) for n in ns])
            values = "  ".join("%.4g" % by_n[n].get(stage, 0.0) for n in ns)
            print("  %-18s p = %s   (ms: %s)" % (stage, "%.2f" % p if p is not None else "-",
                                                 values))
        if 96 in by_n:
            print("  n = 96: %.2f s per iteration" % (by_n[96]["iteration_ms"] / 1e3))
    print()
    print("== two threads against one (bench_weave): speed-up = time(1) / time(2)")
    for solver in sorted({s for s, _ in runs}):
        one, two = runs.get((solver, 1), {}), runs.get((solver, 2), {})
        for n in sorted(set(one) & set(two)):
            g1, g2 = one[n].get("graph_ms", 0.0), two[n].get("graph_ms", 0.0)
            i1, i2 = one[n]["iteration_ms"], two[n]["iteration_ms"]
            print("  %s, n = %3d: iteration graph (broad, narrow, beam and contact assembly) "
                  "%.2fx, iteration %.2fx" %
                  (SOLVERS.get(solver, solver), n, g1 / g2 if g2 > 0 else float("nan"),
                   i1 / i2 if i2 > 0 else float("nan")))


if __name__ == "__main__":
    main()
