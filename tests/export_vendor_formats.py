#!/usr/bin/env python3
"""Writes a built shrouded-blade sector in the four vendor formats `frichb import` reads.

The test of `frichb import` (tests/check_fe_import.cmake) needs ANSYS and Abaqus exports of a
model whose natural frequencies are known independently. This script plays the exporter: it
takes the free-free global matrices CalculiX stored for build_model.py (MODEL_DIR/work: job.sti,
job.mas, job.dof; the mesh mesh_gmsh.inp, kept by build_model.py --keep-work), removes the
bore nodes (as a *BOUNDARY on the bore would, and as build_model.py does) and writes, after the
format descriptions cited in docs/fe-models.md:

  OUT/abaqus_matrix_input/  job_STIF1.mtx, job_MASS1.mtx ('node, dof, node, dof, value', lower
                            triangle), job.inp (*NODE); in mm-t-s units (N/mm, t, mm)
  OUT/abaqus_coordinate/    job_STIF1.mtx, job_MASS1.mtx ('row, column, value', upper
                            triangle), equations.txt ('equation, node, dof'), nodes.csv; SI
  OUT/ansys_hbmat/          k.matrix, m.matrix (Harwell-Boeing RSA), k.mapping, sector.node
                            (NWRITE layout); SI, every node's DOFs in its cylindrical frame
                            (rotated here, as an ANSYS cyclic model's nodes are)
  OUT/ansys_mmf/            k.mmf, m.mmf (Matrix Market, symmetric), k.mapping, sector.node; SI
  OUT/not_cyclic.txt        the shroud contact nodes (coincide with the neighbour's at rest,
                            not tied)

Equations of the three mapped formats are numbered in descending node order, so the importer
must go through the map. Usage: export_vendor_formats.py MODEL_DIR OUT_DIR. Standard library.
"""
import math
import os
import sys


def read_nsets_and_nodes(path):
    nodes, nsets, mode, name = {}, {}, None, None
    with open(path) as f:
        for line in f:
            s = line.strip()
            if not s or s.startswith("**"):
                continue
            if s.startswith("*"):
                u = s.upper().replace(" ", "")
                mode = None
                if u.startswith("*NODE") and not u.startswith("*NODEOUTPUT"):
                    mode = "node"
                elif u.startswith("*NSET"):
                    name = u.split("NSET=")[1].split(",")[0].lower()
                    nsets[name], mode = [], "nset"
                continue
            if mode == "node":
                a = s.split(",")
                nodes[int(a[0])] = tuple(float(v) for v in a[1:4])
            elif mode == "nset":
                nsets[name].extend(int(v) for v in s.rstrip(",").split(",") if v.strip())
    return nodes, nsets


def read_model(model_dir):
    work = os.path.join(model_dir, "work")
    coords, nsets = read_nsets_and_nodes(os.path.join(work, "mesh_gmsh.inp"))
    dofs = []
    with open(os.path.join(work, "job.dof")) as f:
        for line in f:
            if line.strip():
                node, direction = line.strip().split(".")
                dofs.append((int(node), int(direction)))
    bore = set(nsets["bore"])

    def entries(name):
        out = []
        with open(os.path.join(work, name)) as f:
            for line in f:
                a = line.split()
                if a:
                    (na, da), (nb, db) = dofs[int(a[0]) - 1], dofs[int(a[1]) - 1]
                    if na not in bore and nb not in bore:
                        out.append((na, da, nb, db, float(a[2])))
        return out

    kept = sorted({n for n, _ in dofs} - bore)
    shroud = sorted(set(nsets["shroud_left"] + nsets["shroud_right"]) & set(kept))
    return {n: coords[n] for n in kept}, entries("job.sti"), entries("job.mas"), shroud


def rotate(entries, coords):
    """T^T K T node block by node block, T = [e_r e_theta e_z] at each node (upper entries)."""
    blocks = {}
    for na, da, nb, db, v in entries:
        if (na, da) > (nb, db):
            na, da, nb, db = nb, db, na, da
        b = blocks.setdefault((na, nb), [[0.0] * 3 for _ in range(3)])
        b[da - 1][db - 1] += v
        if na == nb and da != db:
            b[db - 1][da - 1] += v
    frame = {}
    for n, (x, y, _) in coords.items():
        t = math.atan2(y, x)
        frame[n] = [[math.cos(t), -math.sin(t), 0.0], [math.sin(t), math.cos(t), 0.0],
                    [0.0, 0.0, 1.0]]
    out = []
    for (na, nb), b in blocks.items():
        ta, tb = frame[na], frame[nb]
        for p in range(3):
            for q in range(3):
                if na == nb and q < p:
                    continue
                v = sum(ta[i][p] * b[i][j] * tb[j][q] for i in range(3) for j in range(3))
                if v != 0.0 or (na == nb and p == q):
                    out.append((na, p + 1, nb, q + 1, v))
    return out


def equation_numbers(coords):
    """(node, dof) -> equation, nodes in descending order."""
    eq = {}
    for n in sorted(coords, reverse=True):
        for d in (1, 2, 3):
            eq[(n, d)] = len(eq) + 1
    return eq


def write(path, text):
    with open(path, "w") as f:
        f.write(text)


def abaqus_matrix_input(out, coords, k, m):
    os.makedirs(out, exist_ok=True)
    for name, entries in (("job_STIF1.mtx", k), ("job_MASS1.mtx", m)):
        text = []
        for na, da, nb, db, v in entries:
            if (na, da) < (nb, db):  # lower triangle: the later DOF first
                na, da, nb, db = nb, db, na, da
            text.append(f"{na}, {da}, {nb}, {db}, {v * 1e-3:.17g}\n")  # N/mm, t
        write(os.path.join(out, name), "".join(text))
    text = ["*HEADING\nshrouded blade sector (mm, t, s)\n*NODE, NSET=NALL\n"]
    text += [f"{n}, {x * 1e3:.17g}, {y * 1e3:.17g}, {z * 1e3:.17g}\n"
             for n, (x, y, z) in sorted(coords.items())]
    text.append("*STEP\n*MATRIX GENERATE, STIFFNESS, MASS\n"
                "*MATRIX OUTPUT, STIFFNESS=YES, MASS=YES, FORMAT=MATRIX INPUT\n*END STEP\n")
    write(os.path.join(out, "job.inp"), "".join(text))


def abaqus_coordinate(out, coords, k, m):
    os.makedirs(out, exist_ok=True)
    eq = equation_numbers(coords)
    for name, entries in (("job_STIF1.mtx", k), ("job_MASS1.mtx", m)):
        text = []
        for na, da, nb, db, v in entries:
            i, j = sorted((eq[(na, da)], eq[(nb, db)]))
            text.append(f"{i}, {j}, {v:.17g}\n")
        write(os.path.join(out, name), "".join(text))
    write(os.path.join(out, "equations.txt"),
          "".join(f"{e}, {n}, {d}\n" for (n, d), e in sorted(eq.items(), key=lambda x: x[1])))
    write(os.path.join(out, "nodes.csv"), "node,x,y,z\n" + "".join(
        f"{n},{x:.17g},{y:.17g},{z:.17g}\n" for n, (x, y, z) in sorted(coords.items())))


def ansys_mapping_and_nodes(out, coords, eq, cylindrical):
    labels = {1: "UX", 2: "UY", 3: "UZ"}
    text = ["Matrix Eqn   Node   DOF\n"]
    text += [f"{e:10d}{n:10d}{labels[d]:>6s}\n"
             for (n, d), e in sorted(eq.items(), key=lambda x: x[1])]
    write(os.path.join(out, "k.mapping"), "".join(text))
    text = []
    for n, (x, y, z) in sorted(coords.items()):  # NWRITE: I9, 6G21.13E3 (x y z thxy thyz thzx)
        thxy = math.degrees(math.atan2(y, x)) if cylindrical else 0.0
        text.append(f"{n:9d}" + "".join(f"{v:21.13E}" for v in (x, y, z, thxy, 0.0, 0.0)) + "\n")
    write(os.path.join(out, "sector.node"), "".join(text))


def lower_by_columns(entries, eq):
    cols = {}
    for na, da, nb, db, v in entries:
        i, j = eq[(na, da)], eq[(nb, db)]
        cols.setdefault(min(i, j), []).append((max(i, j), v))
    return cols


def harwell_boeing(path, entries, eq, title):
    n = len(eq)
    cols = lower_by_columns(entries, eq)
    pointers, rows, values = [1], [], []
    for c in range(1, n + 1):
        for r, v in sorted(cols.get(c, [])):
            rows.append(r)
            values.append(v)
        pointers.append(len(rows) + 1)

    def lines(items, per_line, fmt):
        return ["".join(fmt % x for x in items[k:k + per_line]) + "\n"
                for k in range(0, len(items), per_line)]

    ptr = lines(pointers, 8, "%10d")
    ind = lines(rows, 8, "%10d")
    val = lines(values, 3, "%25.16E")
    head = [f"{title:<72s}{'KEY':<8s}\n",
            f"{len(ptr) + len(ind) + len(val):14d}{len(ptr):14d}{len(ind):14d}{len(val):14d}"
            f"{0:14d}\n",
            f"{'RSA':<14s}{n:14d}{n:14d}{len(rows):14d}{0:14d}\n",
            f"{'(8I10)':<16s}{'(8I10)':<16s}{'(3E25.16)':<20s}\n"]
    write(path, "".join(head + ptr + ind + val))


def matrix_market(path, entries, eq):
    text = ["%%MatrixMarket matrix coordinate real symmetric\n",
            f"{len(eq)} {len(eq)} {len(entries)}\n"]
    for na, da, nb, db, v in entries:
        i, j = eq[(na, da)], eq[(nb, db)]
        text.append(f"{max(i, j)} {min(i, j)} {v:.17g}\n")
    write(path, "".join(text))


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    model_dir, out = sys.argv[1], sys.argv[2]
    coords, k, m, shroud = read_model(model_dir)
    os.makedirs(out, exist_ok=True)
    write(os.path.join(out, "not_cyclic.txt"),
          "# shroud contact nodes\n" + "".join(f"{n}\n" for n in shroud))
    abaqus_matrix_input(os.path.join(out, "abaqus_matrix_input"), coords, k, m)
    abaqus_coordinate(os.path.join(out, "abaqus_coordinate"), coords, k, m)
    eq = equation_numbers(coords)
    hb = os.path.join(out, "ansys_hbmat")
    os.makedirs(hb, exist_ok=True)
    harwell_boeing(os.path.join(hb, "k.matrix"), rotate(k, coords), eq, "stiffness")
    harwell_boeing(os.path.join(hb, "m.matrix"), rotate(m, coords), eq, "mass")
    ansys_mapping_and_nodes(hb, coords, eq, cylindrical=True)
    mmf = os.path.join(out, "ansys_mmf")
    os.makedirs(mmf, exist_ok=True)
    matrix_market(os.path.join(mmf, "k.mmf"), k, eq)
    matrix_market(os.path.join(mmf, "m.mmf"), m, eq)
    ansys_mapping_and_nodes(mmf, coords, eq, cylindrical=False)
    print(f"{len(coords)} nodes, {len(k)} stiffness and {len(m)} mass entries, "
          f"{len(shroud)} shroud nodes; wrote {out}")


if __name__ == "__main__":
    main()
