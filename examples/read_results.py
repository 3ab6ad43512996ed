"""Reads what a yarnsim run left in its output folder (docs/input.md, "Reading the results in
Python"): the biaxial curves from curves.csv, then per step the positions and the contact forces
from results.h5. Needs numpy and h5py (Debian: python3-numpy python3-h5py).

Usage: python3 examples/read_results.py OUTPUT_FOLDER   (e.g. results/biaxial-k1)
"""
import sys

import h5py
import numpy as np

out = sys.argv[1] if len(sys.argv) > 1 else "results/biaxial-k1"

# curves.csv: a header with units ("force_warp [N]"), the initial row, then one row per increment.
with open(f"{out}/curves.csv") as f:
    names = [h.split(" [")[0] for h in f.readline().strip().split(",")]
curves = np.loadtxt(f"{out}/curves.csv", delimiter=",", skiprows=1, ndmin=2)
col = {name: i for i, name in enumerate(names)}
print(f"{len(curves)} rows; at the end: strain_warp {curves[-1, col['strain_warp']]:.5f}, "
      f"force_warp {curves[-1, col['force_warp']]:.2f} N")

with h5py.File(f"{out}/results.h5", "r") as h5:
    print(f"status: {h5.attrs['status']} ({h5.attrs['message']})")
    x0 = h5["/mesh/reference_positions"][:]  # (n_nodes, 3), m
    for name in sorted(h5["/steps"]):  # "000000", "000001", ...: the completed increments in order
        step = h5["/steps"][name]
        t = step.attrs["time"]  # s
        x = step["positions"][:]  # (n_nodes, 3), m
        force = step["contacts/force"][:]  # (n_contacts,), N: normal force of each active point
        where = step["contacts/position"][:]  # (n_contacts, 3), m
    print(f"last step, t = {t:g} s: largest displacement {np.abs(x - x0).max():.3e} m; "
          f"{force.size} contact points carrying {force.sum():.2f} N")
