#!/usr/bin/env python3
"""Writes the sector matrices of a small example bladed disk for the fe_sector provider.

One sector of a tuned disk with out-of-plane (axial) displacement as the single DOF per node:
a disk segment of N_R x N_T nodes joined by springs, grounded at the hub, and a blade of three
nodes standing on the outer rim; the blade tip carries the shroud. The left column of disk
nodes (j = 0) is the cyclic boundary shared with the previous sector, the right column
(j = N_T - 1) the one shared with the next; what lies on a boundary column (its mass, its
radial springs, its hub springs) is split half and half between the two sectors that share it.

Usage: make_example_sector.py [OUTPUT_DIR]   (default: configs/models/generated)
Writes sector_mass.mtx, sector_stiffness.mtx (Matrix Market, symmetric) and prints the DOF
numbering; configs/fe_sector_example.yaml uses them.
"""
import os
import sys

N_R, N_T = 4, 5            # disk nodes: radial x circumferential
DISK_MASS, BLADE_MASS = 0.2, 0.05       # kg per node
K_RADIAL, K_CIRC, K_HUB, K_BLADE = 5.0e5, 5.0e5, 1.0e7, 4.0e5  # N/m


def disk(i, j):
    return i * N_T + j


BLADE = [N_R * N_T + b for b in range(3)]  # root, middle, tip
N = N_R * N_T + len(BLADE)


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "generated")
    os.makedirs(out, exist_ok=True)
    mass = [0.0] * N
    stiffness = {}

    def add(a, b, k):  # spring between DOFs a and b (b = None: to the ground)
        stiffness[(a, a)] = stiffness.get((a, a), 0.0) + k
        if b is not None:
            stiffness[(b, b)] = stiffness.get((b, b), 0.0) + k
            key = (max(a, b), min(a, b))
            stiffness[key] = stiffness.get(key, 0.0) - k

    for i in range(N_R):
        for j in range(N_T):
            share = 0.5 if j in (0, N_T - 1) else 1.0
            mass[disk(i, j)] += share * DISK_MASS
            if i + 1 < N_R:
                add(disk(i, j), disk(i + 1, j), share * K_RADIAL)
            if j + 1 < N_T:
                add(disk(i, j), disk(i, j + 1), K_CIRC)
            if i == 0:
                add(disk(i, j), None, share * K_HUB)
    root = disk(N_R - 1, N_T // 2)
    add(root, BLADE[0], K_BLADE)
    add(BLADE[0], BLADE[1], K_BLADE)
    add(BLADE[1], BLADE[2], K_BLADE)
    for b in BLADE:
        mass[b] += BLADE_MASS

    def write(name, entries):
        with open(os.path.join(out, name), "w") as f:
            f.write("%%MatrixMarket matrix coordinate real symmetric\n")
            f.write("% example sector of FricHB (configs/models/make_example_sector.py)\n")
            f.write(f"{N} {N} {len(entries)}\n")
            for (r, c), v in sorted(entries.items()):
                f.write(f"{r + 1} {c + 1} {v:.17g}\n")

    write("sector_mass.mtx", {(d, d): m for d, m in enumerate(mass)})
    write("sector_stiffness.mtx", stiffness)
    left = [disk(i, 0) for i in range(N_R)]
    right = [disk(i, N_T - 1) for i in range(N_R)]
    print(f"wrote {out}/sector_mass.mtx and sector_stiffness.mtx: {N} DOFs")
    print(f"left_dofs: {left}\nright_dofs: {right}\nblade: {BLADE} (tip {BLADE[-1]})")


if __name__ == "__main__":
    main()
