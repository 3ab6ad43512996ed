#!/usr/bin/env python3
"""Compares two yarnsim output folders: every CSV file they share (curves, monitors, contact)
and, in results.h5, every step's positions and contact forces. Relative differences are taken
against the largest magnitude of a CSV column's unit in its file, and of each dataset over the
run. Exit 1 when one exceeds the tolerance, or
when the runs did not write the same steps.
Usage: compare_runs.py REFERENCE OTHER TOLERANCE"""
import csv
import pathlib
import sys

import h5py
import numpy as np


def read_csv(path):
    rows = list(csv.reader(open(path)))
    return rows[0], np.array([[float(v) for v in r] for r in rows[1:]], dtype=float)


def relative(a, b, scale=None):
    if a.shape != b.shape:
        return float("inf")
    if a.size == 0:
        return 0.0
    if scale is None:
        scale = np.max(np.abs(a))
    scale = np.where(scale > 0, scale, 1.0)
    return float(np.max(np.abs(a - b) / scale))


def unit_scales(header, values):
    """Per column, the largest magnitude among the file's columns of the same unit ("[N]"): a
    reaction that is round-off beside the others (1e-10 N where the test pulls 10 N) is compared
    with the forces, not with itself."""
    units = [h[h.find("["):] if "[" in h else h for h in header]
    column_max = np.max(np.abs(values), axis=0) if values.size else np.zeros(len(header))
    largest = {}
    for u, m in zip(units, column_max):
        largest[u] = max(largest.get(u, 0.0), m)
    return np.array([largest[u] for u in units])


def main():
    ref, other, tol = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2]), float(sys.argv[3])
    worst, where = 0.0, ""
    names = sorted(p.name for p in ref.glob("*.csv"))
    if not names:
        sys.exit(f"{ref}: no CSV files")
    for name in names:
        if name == "contact_points.csv":  # a row per point: its order compared through results.h5
            continue
        h1, a = read_csv(ref / name)
        h2, b = read_csv(other / name)
        if h1 != h2 or a.shape != b.shape:
            sys.exit(f"{name}: different columns or rows ({a.shape} against {b.shape})")
        d = relative(a, b, unit_scales(h1, a))
        if d > worst:
            worst, where = d, name
    with h5py.File(ref / "results.h5", "r") as f, h5py.File(other / "results.h5", "r") as g:
        steps = sorted(f["steps"].keys())
        if steps != sorted(g["steps"].keys()):
            sys.exit(f"results.h5: {len(steps)} steps against {len(g['steps'].keys())}")
        for ds in ("positions", "contacts/force"):
            # Against the dataset's largest magnitude over the run (a contact that has just
            # closed carries a force far below the run's, and its round-off with it).
            scale = max(float(np.max(np.abs(f["steps"][s][ds]), initial=0.0)) for s in steps)
            for s in steps:
                d = relative(np.asarray(f["steps"][s][ds]), np.asarray(g["steps"][s][ds]), scale)
                if d > worst:
                    worst, where = d, f"results.h5 step {s} {ds}"
    print(f"{other} against {ref}: {len(steps)} steps, largest relative difference {worst:.3g}"
          f"{' (' + where + ')' if where else ''}")
    sys.exit(0 if worst <= tol else 1)


main()
