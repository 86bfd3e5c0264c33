#!/usr/bin/env python3
"""Builds the FE sector matrices of a shrouded blade on a disk for FricHB's fe_sector provider.

Pipeline (every step checked; any failure stops with a message and a non-zero exit code):
  1. gmsh meshes shrouded_blade.geo (parameters passed with -setnumber; periodic side faces)
     and writes an Abaqus .inp;
  2. the volume elements (C3D10 or C3D4) and nodes go into a CalculiX deck with steel and a
     *FREQUENCY, SOLVER=MATRIXSTORAGE step; ccx writes job.sti / job.mas (stiffness, mass:
     "row column value", 1-based, upper triangle) and job.dof (node.direction per row);
  3. the matrices are checked in the global Cartesian frame (sum of the x-x mass block = rho *
     mesh volume; K times a rigid translation or rotation about z vanishes), the bore DOFs
     (clamped hub, r = r_hub) are removed, every node's DOFs are turned into its cylindrical
     frame (r, theta, z) and the results are written for fe_sector;
  4. the contact nodes of the shroud's side faces get tributary areas and outward normals,
     checked to pair under the +phi rotation, and the model map (mesh.yaml, nodes.csv,
     faces.csv) is written.

Usage:
  python3 configs/models/shrouded_blade/build_model.py --preset test_case|large_case|tiny
          [--out DIR] [--name NAME] [--keep-work] [--force] [overrides: --sectors N,
          --mesh-size H, --blade-mesh-size H, --element-order 1|2, --r-hub R, ...]
          [--contact-pairs N | --contact-face-size H]

Outputs (default folder configs/models/generated/<name>, name = the preset's, with _p<N> or
_h<H> appended for --contact-pairs N or --contact-face-size H):
  sector_mass.mtx, sector_stiffness.mtx  Matrix Market, coordinate real symmetric (lower
                                         triangle), DOFs node by node (ascending node number),
                                         components (r, theta, z); FricHB DOF = file row - 1
  cyclic_pairs.txt                       'left right' 0-based DOF pairs of the disk's cyclic
                                         boundary (fe_sector's cyclic_pairs)
  dofs.yaml                              named nodes: name: [i_r, i_theta, i_z]
  mesh.yaml, nodes.csv, faces.csv        the model map (FricHB's shared format): every node's
                                         coordinates and rows, the named nodes as node sets,
                                         the contact nodes of the faces shroud_left and
                                         shroud_right with tributary area and outward normal
  model.json                             parameters, counts, mass, named nodes, timings, versions
The build is skipped when model.json holds the same parameters and sources and every output
exists (--force rebuilds). Standard library only.
"""
import argparse
import hashlib
import json
import math
import os
import re
import shutil
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
GEO = os.path.join(HERE, "shrouded_blade.geo")
DEFAULT_ROOT = os.path.normpath(os.path.join(HERE, "..", "generated"))
OUTPUTS = ("sector_mass.mtx", "sector_stiffness.mtx", "cyclic_pairs.txt", "dofs.yaml",
           "mesh.yaml", "nodes.csv", "faces.csv", "model.json")
FORMAT_VERSION = 2  # bump when the outputs change for the same parameters

# Steel (SI)
MATERIAL = {"E": 2.1e11, "nu": 0.3, "rho": 7850.0}

# Geometry and mesh parameters (names as in shrouded_blade.geo; lengths in m, stagger in deg).
GEO_PARAMS = ("sectors", "r_hub", "r_rim", "disk_width", "r_tip", "blade_chord",
              "blade_thickness", "stagger", "shroud_thickness", "shroud_width", "mesh_size",
              "blade_mesh_size", "element_order")
INT_PARAMS = ("sectors", "element_order")

# The test case's geometry was tuned (see README.md) for a first flap family near 115 Hz and a
# first torsion family near 180 Hz (thesis: 1F shifted by the contact to 128.7 Hz, 1T 181 Hz).
# The 35 degree stagger turns the flap direction away from the shroud contact's normal (theta),
# so that a flap mode slides the shroud faces axially as well as pressing them together.
TEST_GEOMETRY = dict(sectors=8, r_hub=0.20, r_rim=0.40, disk_width=0.10, r_tip=0.70,
                     blade_chord=0.08, blade_thickness=0.035, stagger=35.0,
                     shroud_thickness=0.02, shroud_width=0.08)
PRESETS = {
    # 8 sectors, quadratic tets (C3D10), ~4400 DOFs (thesis: 4488)
    "test_case": dict(TEST_GEOMETRY, mesh_size=0.05, blade_mesh_size=0.05, element_order=2),
    # 146 sectors, C3D10, ~33000 DOFs (thesis: 32490), first blade family near 265 Hz
    "large_case": dict(sectors=146, r_hub=0.25, r_rim=0.35, disk_width=0.05, r_tip=0.45,
                       blade_chord=0.03, blade_thickness=0.004, stagger=0.0,
                       shroud_thickness=0.004, shroud_width=0.02, mesh_size=0.0045,
                       blade_mesh_size=0.0045, element_order=2),
    # the test case's geometry with coarse linear tets (C3D4): a few hundred DOFs, builds in
    # about a second (CI); its frequencies are far too high (linear tets lock in bending)
    "tiny": dict(TEST_GEOMETRY, mesh_size=0.2, blade_mesh_size=0.2, element_order=1),
}

# Named contact pairs on the shroud faces: (radial fraction, axial fraction) of the face
CONTACT_GRID = [(fr, fz) for fr in (0.0, 0.5, 1.0) for fz in (-0.5, 0.0, 0.5)]


class BuildError(Exception):
    pass


def log(msg):
    print(f"[build_model] {msg}", flush=True)


def sha256_file(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        h.update(f.read())
    return h.hexdigest()


def run(cmd, cwd, what, env=None):
    """Runs cmd; returns its combined output; raises BuildError with the tail on failure."""
    try:
        p = subprocess.run(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           text=True, env=env)
    except OSError as e:
        raise BuildError(f"{what}: cannot run {cmd[0]}: {e}")
    out = p.stdout
    with open(os.path.join(cwd, what.replace(" ", "_") + ".log"), "w") as f:
        f.write(out)
    if p.returncode != 0:
        tail = "\n".join(out.splitlines()[-25:])
        raise BuildError(f"{what} failed (exit code {p.returncode}):\n{tail}")
    return out


def tool_version(exe, args, pattern):
    try:
        p = subprocess.run([exe] + args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired) as e:
        raise BuildError(f"cannot run {exe}: {e}")
    m = re.search(pattern, p.stdout)
    return m.group(1) if m else p.stdout.strip().splitlines()[0] if p.stdout.strip() else "?"


# ----------------------------------------------------------------------------- geometry checks
def check_params(p):
    phi = 2 * math.pi / p["sectors"]
    if p["sectors"] < 2:
        raise BuildError("sectors must be >= 2")
    if not 0 < p["r_hub"] < p["r_rim"] < p["r_tip"]:
        raise BuildError("need 0 < r_hub < r_rim < r_tip")
    for k in ("disk_width", "blade_chord", "blade_thickness", "shroud_thickness",
              "shroud_width", "mesh_size", "blade_mesh_size"):
        if not p[k] > 0:
            raise BuildError(f"{k} must be > 0")
    if p["element_order"] not in (1, 2):
        raise BuildError("element_order must be 1 (C3D4) or 2 (C3D10)")
    if phi / 2 >= math.pi / 2:
        raise BuildError("sectors must be >= 3 (half sector angle below 90 degrees)")
    st = math.radians(p["stagger"])
    half_circ = 0.5 * p["blade_chord"] * abs(math.sin(st)) + 0.5 * p["blade_thickness"] * abs(
        math.cos(st))
    if half_circ >= 0.9 * p["r_rim"] * math.sin(phi / 2):
        raise BuildError(f"the blade ({2 * half_circ:.4g} m wide circumferentially) does not fit "
                         f"in the sector at the rim ({2 * p['r_rim'] * math.sin(phi / 2):.4g} m): "
                         "reduce chord, thickness or stagger")
    half_ax = 0.5 * p["blade_chord"] * abs(math.cos(st)) + 0.5 * p["blade_thickness"] * abs(
        math.sin(st))
    if half_ax > 0.5 * p["disk_width"] or half_ax > 0.5 * p["shroud_width"]:
        log(f"warning: the blade ({2 * half_ax:.4g} m axially) overhangs the disk rim or the shroud")


# ----------------------------------------------------------------------------- mesh (.inp) I/O
def parse_gmsh_inp(path):
    """Nodes {id: (x, y, z, text)}, volume elements [(type, [nodes])], node sets {name: [ids]}."""
    nodes, elements, nsets = {}, [], {}
    mode, etype, cur = None, None, None
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
                elif u.startswith("*ELEMENT"):
                    m = re.search(r"TYPE=([A-Z0-9]+)", u)
                    etype = m.group(1) if m else "?"
                    mode = "elem" if etype in ("C3D10", "C3D4") else "skip"
                    cur = None
                elif u.startswith("*NSET"):
                    m = re.search(r"NSET=([^,]+)", s.replace(" ", ""), re.I)
                    cur = m.group(1).lower()
                    nsets[cur] = []
                    mode = "nset"
                continue
            if mode == "node":
                a = s.split(",")
                nodes[int(a[0])] = tuple(float(v) for v in a[1:4])
            elif mode == "elem":
                a = [int(v) for v in s.rstrip(",").split(",") if v.strip()]
                if cur is not None:          # continuation line
                    cur[1].extend(a)
                else:
                    cur = (etype, a[1:])
                    elements.append(cur)
                n_expected = 10 if etype == "C3D10" else 4
                if len(cur[1]) >= n_expected:
                    cur = None
            elif mode == "nset":
                nsets[cur].extend(int(v) for v in s.rstrip(",").split(",") if v.strip())
    return nodes, elements, nsets


def parse_face_triangles(path, face_names):
    """Surface triangles of the named element sets: {name: [[nodes], ...]} (CPS3 / CPS6)."""
    triangles, elsets = {}, {}
    mode, cur = None, None
    with open(path) as f:
        for line in f:
            s = line.strip()
            if not s or s.startswith("**"):
                continue
            if s.startswith("*"):
                u = s.upper().replace(" ", "")
                mode = None
                if u.startswith("*ELEMENT"):
                    m = re.search(r"TYPE=([A-Z0-9]+)", u)
                    mode = "tri" if m and m.group(1) in ("CPS3", "CPS6") else None
                elif u.startswith("*ELSET"):
                    m = re.search(r"ELSET=([^,]+)", u)
                    cur = m.group(1).lower()
                    mode = "elset" if cur in face_names else None
                    if mode:
                        elsets[cur] = []
                continue
            if mode == "tri":
                a = [int(v) for v in s.rstrip(",").split(",") if v.strip()]
                triangles[a[0]] = a[1:]
            elif mode == "elset":
                elsets[cur].extend(int(v) for v in s.rstrip(",").split(",") if v.strip())
    out = {}
    for name in face_names:
        if not elsets.get(name):
            raise BuildError(f"gmsh wrote no surface elements for '{name}'")
        try:
            out[name] = [triangles[e] for e in elsets[name]]
        except KeyError as e:
            raise BuildError(f"element set '{name}' lists element {e} that is not a triangle")
    return out


def triangle_area(a, b, c):
    ux, uy, uz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    vx, vy, vz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    return 0.5 * math.sqrt(nx * nx + ny * ny + nz * nz), (nx, ny, nz)


def lumped_face_areas(triangles, coords):
    """Tributary areas {node: area} of an unstructured face mesh: 1/3 of each linear triangle
    to each of its vertices; a 6-node triangle is split into its 4 linear sub-triangles first
    (corner-mid-mid three times and the middle one), so that mid-side nodes get area too.
    Returns the areas and the triangles' (unnormalised) normals."""
    areas, normals = {}, []
    for conn in triangles:
        if len(conn) == 3:
            subs = [conn]
        elif len(conn) == 6:
            a, b, c, ab, bc, ca = conn
            for m, (p, q) in ((ab, (a, b)), (bc, (b, c)), (ca, (c, a))):
                mid = [(coords[p][k] + coords[q][k]) / 2 for k in range(3)]
                if math.dist(mid, coords[m]) > 1e-9 * (1 + math.dist(coords[p], coords[q])):
                    raise BuildError(f"face triangle {conn}: node {m} is not the middle of "
                                     f"its side {p}-{q}")
            subs = [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
        else:
            raise BuildError(f"face triangle with {len(conn)} nodes")
        for sub in subs:
            area, normal = triangle_area(*(coords[n] for n in sub))
            if area <= 0:
                raise BuildError(f"face triangle {sub} has no area")
            normals.append(normal)
            for n in sub:
                areas[n] = areas.get(n, 0.0) + area / 3
    return areas, normals


def choose_contact_grid(pairs, length_r, length_z):
    """The factorisation n_r x n_z = pairs whose tributary cell (dr x dz) is closest to a
    square. A direction with n nodes has spacing length / (n - 1), or length for n = 1 (one
    node in the middle that carries the whole length)."""
    best = None
    for n_r in range(1, pairs + 1):
        if pairs % n_r:
            continue
        n_z = pairs // n_r
        dr = length_r / (n_r - 1) if n_r > 1 else length_r
        dz = length_z / (n_z - 1) if n_z > 1 else length_z
        score = abs(math.log(dr / dz))
        if best is None or score < best[0] - 1e-12:
            best = (score, n_r, n_z)
    return best[1], best[2]


def grid_lines(n, length):
    """Contact node positions along one direction (offsets from the edge) with their bilinear
    tributary lengths, and the number of mesh vertices along it (a single node sits in the
    middle of a 2-element line)."""
    if n == 1:
        return [(0.5 * length, length)], 3
    h = length / (n - 1)
    return [(i * h, h if 0 < i < n - 1 else 0.5 * h) for i in range(n)], n


def tet_volume(a, b, c, d):
    ux, uy, uz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    vx, vy, vz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    wx, wy, wz = d[0] - a[0], d[1] - a[1], d[2] - a[2]
    return (ux * (vy * wz - vz * wy) - uy * (vx * wz - vz * wx) + uz * (vx * wy - vy * wx)) / 6.0


# ----------------------------------------------------------------------------- CalculiX
def write_ccx_deck(path, nodes, elements, etype):
    with open(path, "w") as f:
        f.write("** shrouded blade sector: stiffness and mass matrices (matrix storage)\n"
                "** written by configs/models/shrouded_blade/build_model.py\n")
        f.write("*NODE, NSET=NALL\n")  # ccx reads numbers of at most 20 characters
        for n in sorted(nodes):
            x, y, z = nodes[n]
            f.write(f"{n}, {x:.14g}, {y:.14g}, {z:.14g}\n")
        f.write(f"*ELEMENT, TYPE={etype}, ELSET=EALL\n")
        for k, (_, conn) in enumerate(elements, 1):
            f.write(f"{k}, " + ", ".join(str(n) for n in conn) + "\n")
        f.write("*MATERIAL, NAME=STEEL\n*ELASTIC\n"
                f"{MATERIAL['E']:.17g}, {MATERIAL['nu']:.17g}\n"
                f"*DENSITY\n{MATERIAL['rho']:.17g}\n"
                "*SOLID SECTION, ELSET=EALL, MATERIAL=STEEL\n"
                "** No *BOUNDARY: the free-free matrices are exported and checked (rigid body\n"
                "** modes, total mass), then the driver removes the bore DOFs, which is exactly\n"
                "** what a *BOUNDARY on the bore nodes does to the stored matrices.\n"
                "*STEP\n*FREQUENCY, SOLVER=MATRIXSTORAGE\n*END STEP\n")


def read_ccx_matrix(path, n):
    """Entries (i, j, v) of a CalculiX .sti/.mas file: 'i j v', 1-based, i <= j."""
    rows, cols, vals = [], [], []
    with open(path) as f:
        for line in f:
            a = line.split()
            if not a:
                continue
            i, j = int(a[0]) - 1, int(a[1]) - 1
            if not (0 <= i <= j < n):
                raise BuildError(f"{path}: entry ({a[0]}, {a[1]}) is not in the upper triangle "
                                 f"of a {n} x {n} matrix")
            rows.append(i)
            cols.append(j)
            vals.append(float(a[2]))
    return rows, cols, vals


# ----------------------------------------------------------------------------- conversion
def node_blocks(rows, cols, vals, dof_node, dof_dir, name):
    """3x3 blocks {(na, nb): [9 values row-major]} with na <= nb (Cartesian), full blocks."""
    blocks, filled = {}, {}
    for i, j, v in zip(rows, cols, vals):
        na, nb = dof_node[i], dof_node[j]
        da, db = dof_dir[i], dof_dir[j]
        if na > nb:
            na, nb, da, db = nb, na, db, da
        b = blocks.get((na, nb))
        if b is None:
            b = blocks[(na, nb)] = [0.0] * 9
        bit = 1 << (3 * da + db)
        if filled.get((na, nb), 0) & bit:
            raise BuildError(f"{name}: entry ({i + 1}, {j + 1}) listed twice")
        filled[(na, nb)] = filled.get((na, nb), 0) | bit
        b[3 * da + db] = v
        if na == nb:
            b[3 * db + da] = v
    return blocks


def rotate_blocks(blocks, frame):
    """B'_ab = R_a^T B_ab R_b with R = [e_r e_theta e_z] (columns) of each node."""
    out = {}
    for (na, nb), b in blocks.items():
        ca, sa = frame[na]
        cb, sb = frame[nb]
        b00, b01, b02, b10, b11, b12, b20, b21, b22 = b
        # C = B R_b  (R_b = [[cb, -sb, 0], [sb, cb, 0], [0, 0, 1]])
        c00, c01 = b00 * cb + b01 * sb, -b00 * sb + b01 * cb
        c10, c11 = b10 * cb + b11 * sb, -b10 * sb + b11 * cb
        c20, c21 = b20 * cb + b21 * sb, -b20 * sb + b21 * cb
        c02, c12, c22 = b02, b12, b22
        # R_a^T C  (R_a^T = [[ca, sa, 0], [-sa, ca, 0], [0, 0, 1]])
        out[(na, nb)] = (ca * c00 + sa * c10, ca * c01 + sa * c11, ca * c02 + sa * c12,
                         -sa * c00 + ca * c10, -sa * c01 + ca * c11, -sa * c02 + ca * c12,
                         c20, c21, c22)
    return out


def write_mtx(path, blocks, index, ndof, comment):
    """Lower triangle of the symmetric matrix given by its upper node blocks (na <= nb)."""
    entries = []
    for (na, nb), b in blocks.items():
        ia, ib = index[na], index[nb]
        for p in range(3):
            for q in range(3):
                v = b[3 * p + q]
                r, c = ib + q, ia + p          # (row, col) = (nb dir q, na dir p): lower
                if r < c or v == 0.0 and r != c:
                    continue
                entries.append((c, r, v))
    entries.sort()
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write("%%MatrixMarket matrix coordinate real symmetric\n")
        for line in comment:
            f.write(f"% {line}\n")
        f.write(f"{ndof} {ndof} {len(entries)}\n")
        f.writelines(f"{r + 1} {c + 1} {v:.17g}\n" for c, r, v in entries)
    os.replace(tmp, path)
    return len(entries)


def find_partners(left, right, coords, phi, tol, what):
    """Maps each left node to the right node at its +phi rotation (within tol)."""
    c, s = math.cos(phi), math.sin(phi)
    cell = max(tol * 1e3, 1e-9)
    grid = {}
    for n in right:
        x, y, z = coords[n]
        grid.setdefault((round(x / cell), round(y / cell), round(z / cell)), []).append(n)
    pairs, used = {}, set()
    for n in left:
        x, y, z = coords[n]
        px, py, pz = c * x - s * y, s * x + c * y, z
        k = (round(px / cell), round(py / cell), round(pz / cell))
        best, bd = None, tol
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    for m in grid.get((k[0] + dx, k[1] + dy, k[2] + dz), ()):
                        xm, ym, zm = coords[m]
                        d = math.sqrt((xm - px) ** 2 + (ym - py) ** 2 + (zm - pz) ** 2)
                        if d <= bd:
                            best, bd = m, d
        if best is None:
            raise BuildError(f"{what}: left node {n} at {coords[n]} has no right partner within "
                             f"{tol:.3g} m after the +phi rotation (mesh not periodic)")
        if best in used:
            raise BuildError(f"{what}: right node {best} is the partner of two left nodes")
        used.add(best)
        pairs[n] = best
    if len(used) != len(right):
        raise BuildError(f"{what}: {len(right)} right nodes but {len(left)} left nodes")
    return pairs


def nearest(candidates, coords, target):
    return min(candidates, key=lambda n: sum((coords[n][k] - target[k]) ** 2 for k in range(3)))


def cyl_point(r, theta, z):
    return (r * math.cos(theta), r * math.sin(theta), z)


# ----------------------------------------------------------------------------- contact faces
def contact_layout(p):
    """How the shroud side faces are meshed: unstructured (default), or a structured grid of
    contact nodes chosen by --contact-pairs (n_r x n_z = pairs) or --contact-face-size."""
    length_r, length_z = p["shroud_thickness"], p["shroud_width"]
    if p.get("contact_pairs") is not None:
        n_r, n_z = choose_contact_grid(p["contact_pairs"], length_r, length_z)
    elif p.get("contact_face_size") is not None:
        h = p["contact_face_size"]
        n_r = max(2, int(round(length_r / h)) + 1)
        n_z = max(2, int(round(length_z / h)) + 1)
    else:
        return {"structured": False, "grid": None, "mesh_grid": None}
    lines_r, m_r = grid_lines(n_r, length_r)
    lines_z, m_z = grid_lines(n_z, length_z)
    return {"structured": True, "grid": [n_r, n_z], "mesh_grid": [m_r, m_z],
            "lines_r": lines_r, "lines_z": lines_z}


def contact_faces(p, contact, coords, face_tris, sl, sr, shroud_pairs, phi):
    """{face: {"nodes": [(node, area)], "normal": (nx, ny, nz)}} for shroud_left (ascending
    node) and shroud_right (in the order of the left partners); checks the areas, the normals
    and the pairing under the +phi rotation."""
    length_r, length_z = p["shroud_thickness"], p["shroud_width"]
    face_area = length_r * length_z
    r_mid = p["r_tip"] + 0.5 * length_r
    tol = 1e-6 * p["r_tip"]
    out = {}
    for name, face_nodes, theta in (("shroud_left", sl, -phi / 2), ("shroud_right", sr, phi / 2)):
        sign = 1.0 if theta > 0 else -1.0
        normal = (-sign * math.sin(theta), sign * math.cos(theta), 0.0)  # +-e_theta, outward
        areas, tri_normals = lumped_face_areas(face_tris[name], coords)
        if set(areas) != set(face_nodes):
            raise BuildError(f"{name}: the face triangles' nodes are not the face's node set")
        for tn in tri_normals:
            size = math.sqrt(sum(c * c for c in tn))
            cross = (tn[1] * normal[2] - tn[2] * normal[1], tn[2] * normal[0] - tn[0] * normal[2],
                     tn[0] * normal[1] - tn[1] * normal[0])
            if math.sqrt(sum(c * c for c in cross)) > 1e-9 * size:
                raise BuildError(f"{name}: a face triangle is not in the plane theta = {theta:.6g}")
        probe = coords[face_nodes[0]]
        if sum(normal[k] * (probe[k] - (r_mid, 0.0, 0.0)[k]) for k in range(3)) <= 0:
            raise BuildError(f"{name}: the normal {normal} does not point out of the sector")
        if contact["structured"]:
            areas = structured_areas(name, contact, face_tris[name], coords, p, tol)
        total = math.fsum(areas.values())
        if abs(total - face_area) > 1e-9 * face_area:
            raise BuildError(f"{name}: tributary areas sum to {total:.12g} m^2, the face is "
                             f"{face_area:.12g} m^2")
        if min(areas.values()) <= 0:
            raise BuildError(f"{name}: a contact node has no tributary area")
        out[name] = {"areas": areas, "normal": normal}
    left, right = out["shroud_left"]["areas"], out["shroud_right"]["areas"]
    left_nodes = sorted(left)
    for n in left_nodes:
        m = shroud_pairs[n]
        if m not in right:
            raise BuildError(f"contact faces: the +phi rotation of left contact node {n} is node "
                             f"{m}, not a right contact node")
        if abs(right[m] - left[n]) > 1e-9 * left[n]:
            raise BuildError(f"contact faces: left node {n} and its partner {m} have different "
                             f"areas ({left[n]:.9g}, {right[m]:.9g} m^2)")
    if len(right) != len(left):
        raise BuildError(f"contact faces: {len(left)} left but {len(right)} right contact nodes")
    return {"shroud_left": {"nodes": [(n, left[n]) for n in left_nodes],
                            "normal": out["shroud_left"]["normal"]},
            "shroud_right": {"nodes": [(shroud_pairs[n], right[shroud_pairs[n]])
                                       for n in left_nodes],
                             "normal": out["shroud_right"]["normal"]}}


def structured_areas(name, contact, triangles, coords, p, tol):
    """Bilinear tributary areas {node: area} of the contact nodes of a structured face: the
    vertex nodes of its triangles at the grid positions (mid-side nodes are not contact
    nodes)."""
    m_r, m_z = contact["mesh_grid"]
    h_r = p["shroud_thickness"] / (m_r - 1)
    h_z = p["shroud_width"] / (m_z - 1)
    vertices = {}
    for conn in triangles:
        for n in conn[:3]:
            x, y, z = coords[n]
            fi = (math.hypot(x, y) - p["r_tip"]) / h_r
            fj = (z + 0.5 * p["shroud_width"]) / h_z
            i, j = int(round(fi)), int(round(fj))
            if abs(fi - i) * h_r > tol or abs(fj - j) * h_z > tol or not (
                    0 <= i < m_r and 0 <= j < m_z):
                raise BuildError(f"{name}: vertex node {n} is off the {m_r} x {m_z} grid")
            if vertices.setdefault((i, j), n) != n:
                raise BuildError(f"{name}: two vertex nodes at grid position {(i, j)}")
    if len(vertices) != m_r * m_z:
        raise BuildError(f"{name}: {len(vertices)} vertex nodes, the grid has {m_r} x {m_z}")
    # a direction with a single contact node uses the middle one of its 3 mesh vertices
    rows_r = range(len(contact["lines_r"])) if m_r == len(contact["lines_r"]) else [1]
    rows_z = range(len(contact["lines_z"])) if m_z == len(contact["lines_z"]) else [1]
    areas = {}
    for i, (_, ar) in zip(rows_r, contact["lines_r"]):
        for j, (_, az) in zip(rows_z, contact["lines_z"]):
            areas[vertices[(i, j)]] = ar * az
    return areas


def write_model_map(out, p, kept, index, coords, faces, named):
    """mesh.yaml, nodes.csv and faces.csv: the model map in FricHB's shared format."""
    with open(os.path.join(out, "nodes.csv.tmp"), "w") as f:
        f.write("node,x,y,z,frame,dof_1,dof_2,dof_3\n")
        for n in kept:
            x, y, z = coords[n]
            i = index[n]
            f.write(f"{n},{x:.17g},{y:.17g},{z:.17g},cylindrical,{i},{i + 1},{i + 2}\n")
    os.replace(os.path.join(out, "nodes.csv.tmp"), os.path.join(out, "nodes.csv"))
    with open(os.path.join(out, "faces.csv.tmp"), "w") as f:
        f.write("face,node,area,nx,ny,nz\n")
        for name, face in faces.items():
            nx, ny, nz = face["normal"]
            for n, area in face["nodes"]:
                f.write(f"{name},{n},{area:.17g},{nx:.17g},{ny:.17g},{nz:.17g}\n")
    os.replace(os.path.join(out, "faces.csv.tmp"), os.path.join(out, "faces.csv"))
    with open(os.path.join(out, "mesh.yaml.tmp"), "w") as f:
        f.write("# FricHB model map (written by configs/models/shrouded_blade/build_model.py)\n"
                f"# {p['name']}: nodes.csv holds every node of the sector matrices (bore\n"
                "# removed), "
"faces.csv the contact nodes of the shroud side faces (shroud_right of\n"
                "# sector s touches shroud_left of sector s+1; row k of shroud_right is the +phi\n"
                "# rotation of row k of shroud_left)\n"
                "format: 1\nunits: SI\nnodes: nodes.csv\nfaces: faces.csv\nnode_sets:\n")
        for name, n in named.items():
            f.write(f"  {name}: [{n}]\n")
    os.replace(os.path.join(out, "mesh.yaml.tmp"), os.path.join(out, "mesh.yaml"))


# ----------------------------------------------------------------------------- main build
def build(p, out, keep_work, gmsh, ccx, threads):
    t_all = time.time()
    times = {}
    phi = 2 * math.pi / p["sectors"]
    r_out = p["r_tip"] + p["shroud_thickness"]
    gmsh_version = tool_version(gmsh, ["--version"], r"(\d+\.\d+\.\d+)")
    ccx_version = tool_version(ccx, ["-v"], r"Version\s+([\d.]+)")

    # an interrupted build must not leave a model.json that vouches for other files
    os.makedirs(out, exist_ok=True)
    if os.path.exists(os.path.join(out, "model.json")):
        os.remove(os.path.join(out, "model.json"))
    work = os.path.join(out, "work")
    if os.path.isdir(work):
        shutil.rmtree(work)
    os.makedirs(work)

    # 1. mesh
    t = time.time()
    cmd = [gmsh, GEO, "-3", "-format", "inp", "-o", "mesh_gmsh.inp", "-nt", "1"]
    for k in GEO_PARAMS:
        cmd += ["-setnumber", k, repr(p[k])]
    contact = contact_layout(p)
    if contact["structured"]:
        cmd += ["-setnumber", "contact_n_r", str(contact["mesh_grid"][0]),
                "-setnumber", "contact_n_z", str(contact["mesh_grid"][1])]
    log("gmsh: " + " ".join(cmd))
    gout = run(cmd, work, "gmsh")
    errors = [l for l in gout.splitlines() if l.startswith("Error")]
    if errors or not os.path.isfile(os.path.join(work, "mesh_gmsh.inp")):
        raise BuildError("gmsh reported errors:\n" + "\n".join(errors[:20]))
    nodes_all, elements, nsets = parse_gmsh_inp(os.path.join(work, "mesh_gmsh.inp"))
    etype = "C3D10" if p["element_order"] == 2 else "C3D4"
    elements = [e for e in elements if e[0] == etype]
    if not elements:
        raise BuildError(f"gmsh wrote no {etype} element")
    for name in ("bore", "disk_left", "disk_right", "shroud_left", "shroud_right",
                 "shroud_top"):
        if not nsets.get(name):
            raise BuildError(f"gmsh wrote no node set '{name}'")
    used = set()
    for _, conn in elements:
        used.update(conn)
    coords = {n: nodes_all[n] for n in used}
    volume = 0.0
    for _, conn in elements:
        v = tet_volume(*(coords[n] for n in conn[:4]))
        if v <= 0:
            raise BuildError(f"element with nodes {conn[:4]} has a non-positive volume {v:.3g}")
        volume += v
    times["gmsh_s"] = round(time.time() - t, 3)
    log(f"mesh: {len(coords)} nodes, {len(elements)} {etype}, volume {volume:.9g} m^3 "
        f"({times['gmsh_s']:.1f} s)")

    # 2. CalculiX matrix storage
    t = time.time()
    write_ccx_deck(os.path.join(work, "job.inp"), coords, elements, etype)
    env = dict(os.environ, OMP_NUM_THREADS=str(threads), CCX_NPROC_STIFFNESS=str(threads))
    cout = run([ccx, "-i", "job"], work, "ccx", env=env)
    if "*ERROR" in cout.upper() or "Job finished" not in cout:
        bad = [l for l in cout.splitlines() if "ERROR" in l.upper()]
        raise BuildError("ccx failed:\n" + "\n".join(bad[:20] or cout.splitlines()[-20:]))
    for ext in ("sti", "mas", "dof"):
        if not os.path.isfile(os.path.join(work, "job." + ext)):
            raise BuildError(f"ccx wrote no job.{ext}")
    times["ccx_s"] = round(time.time() - t, 3)
    log(f"ccx: matrices stored ({times['ccx_s']:.1f} s)")

    # 3. read, check, convert
    t = time.time()
    dof_node, dof_dir = [], []
    with open(os.path.join(work, "job.dof")) as f:
        for line in f:
            s = line.strip()
            if s:
                a, b = s.split(".")
                dof_node.append(int(a))
                dof_dir.append(int(b) - 1)
    n_cart = len(dof_node)
    if set(dof_dir) != {0, 1, 2} or set(dof_node) != used or n_cart != 3 * len(used):
        raise BuildError("job.dof does not list the 3 translations of every mesh node")
    Kr = read_ccx_matrix(os.path.join(work, "job.sti"), n_cart)
    Mr = read_ccx_matrix(os.path.join(work, "job.mas"), n_cart)
    times["read_s"] = round(time.time() - t, 3)

    # checks in the Cartesian frame, before any DOF is removed
    t = time.time()
    rho = MATERIAL["rho"]
    msum = [[0.0] * 3 for _ in range(3)]
    for i, j, v in zip(*Mr):
        msum[dof_dir[i]][dof_dir[j]] += v
        if i != j:
            msum[dof_dir[j]][dof_dir[i]] += v
    mass = msum[0][0]
    for d in range(3):
        if abs(msum[d][d] - rho * volume) > 1e-6 * rho * volume:
            raise BuildError(f"mass check: sum of the {'xyz'[d]}-{'xyz'[d]} block of M = "
                             f"{msum[d][d]:.10g} kg, rho * mesh volume = {rho * volume:.10g} kg")
    for a in range(3):
        for b in range(3):
            if a != b and abs(msum[a][b]) > 1e-9 * mass:
                raise BuildError(f"mass check: cross block {'xyz'[a]}{'xyz'[b]} sums to "
                                 f"{msum[a][b]:.3g}")
    # rigid modes: translations x, y, z and the rotation about z (u = (-y, x, 0))
    rigid = []
    for d in range(3):
        rigid.append([1.0 if dof_dir[i] == d else 0.0 for i in range(n_cart)])
    rigid.append([(-coords[dof_node[i]][1] if dof_dir[i] == 0 else
                   coords[dof_node[i]][0] if dof_dir[i] == 1 else 0.0) for i in range(n_cart)])
    kmax = max(abs(v) for v in Kr[2])
    for name, u in zip(("x", "y", "z", "rot_z"), rigid):
        f = [0.0] * n_cart
        for i, j, v in zip(*Kr):
            f[i] += v * u[j]
            if i != j:
                f[j] += v * u[i]
        umax = max(abs(x) for x in u)
        res = max(abs(x) for x in f) / (kmax * umax)
        if res > 1e-9:
            raise BuildError(f"stiffness check: K times the rigid {name} motion is {res:.3g} of "
                             "max|K| (should vanish)")
    times["checks_s"] = round(time.time() - t, 3)

    # cyclic boundary (disk faces) and shroud faces
    t = time.time()
    bore = set(nsets["bore"]) & used
    for n in bore:
        r = math.hypot(coords[n][0], coords[n][1])
        # midside nodes of straight-sided elements lie on the chords, inside the arc
        if not p["r_hub"] * 0.9 < r < p["r_hub"] + 1e-6 * p["r_tip"]:
            raise BuildError(f"bore node {n} at r = {r} is not on r_hub")
    tol = 1e-6 * p["r_tip"]
    dl = [n for n in nsets["disk_left"] if n in used and n not in bore]
    dr = [n for n in nsets["disk_right"] if n in used and n not in bore]
    disk_pairs = find_partners(sorted(dl), dr, coords, phi, tol, "disk faces")
    sl = [n for n in nsets["shroud_left"] if n in used]
    sr = [n for n in nsets["shroud_right"] if n in used]
    shroud_pairs = find_partners(sorted(sl), sr, coords, phi, tol, "shroud faces")
    for n in list(nsets["disk_left"]):  # bore nodes on the boundary: absent on both sides
        if n in bore:
            x, y, z = coords[n]
            px, py = math.cos(phi) * x - math.sin(phi) * y, math.sin(phi) * x + math.cos(phi) * y
            m = nearest(nsets["disk_right"], coords, (px, py, z))
            if m not in bore:
                raise BuildError(f"left bore node {n} has a right partner {m} off the bore")

    # contact faces: contact nodes, tributary areas, outward normals
    face_tris = parse_face_triangles(os.path.join(work, "mesh_gmsh.inp"),
                                     ("shroud_left", "shroud_right"))
    faces = contact_faces(p, contact, coords, face_tris, sl, sr, shroud_pairs, phi)

    # DOF numbering: remaining nodes ascending, (r, theta, z)
    kept = sorted(used - bore)
    index = {n: 3 * k for k, n in enumerate(kept)}
    ndof = 3 * len(kept)
    frame = {n: (coords[n][0] / math.hypot(coords[n][0], coords[n][1]),
                 coords[n][1] / math.hypot(coords[n][0], coords[n][1])) for n in kept}

    def reduce_rotate(raw, name):
        blocks = node_blocks(*raw, dof_node, dof_dir, name)
        blocks = {k: b for k, b in blocks.items() if k[0] not in bore and k[1] not in bore}
        blocks = rotate_blocks(blocks, frame)
        for n in kept:
            b = blocks.get((n, n))
            if b is None or min(b[0], b[4], b[8]) <= 0:
                raise BuildError(f"{name}: non-positive diagonal at node {n}")
            for pq, qp in ((1, 3), (2, 6), (5, 7)):
                if abs(b[pq] - b[qp]) > 1e-12 * max(abs(x) for x in b):
                    raise BuildError(f"{name}: nodal block of node {n} is not symmetric")
        return blocks

    Kb = reduce_rotate(Kr, "stiffness")
    Mb = reduce_rotate(Mr, "mass")
    del Kr, Mr
    times["convert_s"] = round(time.time() - t, 3)

    # named nodes
    st = math.radians(p["stagger"])
    cs, ss = math.cos(st), math.sin(st)

    def blade_point(x, yl, zl):  # blade-local (x, y, z) turned by the stagger about x
        return (x, yl * cs - zl * ss, yl * ss + zl * cs)

    r_exc = p["r_tip"] - 0.05 * (p["r_tip"] - p["r_rim"])
    named = {}
    named["excitation"] = nearest(kept, coords, blade_point(r_exc, 0.0, -p["blade_chord"] / 2))
    named["response"] = nearest(nsets["shroud_top"], coords,
                                (r_out, 0.0, -p["shroud_width"] / 2))
    # The outer leading corner of the shroud_right face: a vertex of the geometry, hence a node
    # at the same place on every face mesh (a response point for comparing meshes).
    corner = cyl_point(r_out, phi / 2, -p["shroud_width"] / 2)
    named["shroud_corner"] = nearest(kept, coords, corner)
    miss = math.dist(coords[named["shroud_corner"]], corner)
    if miss > 1e-9:
        raise BuildError(f"no node at the shroud face's corner (nearest {miss:.3g} m away)")
    inv = {v: k for k, v in shroud_pairs.items()}
    r_mid = p["r_tip"] + 0.5 * p["shroud_thickness"]
    left_contact = [n for n, _ in faces["shroud_left"]["nodes"]]
    mid = nearest(left_contact, coords, cyl_point(r_mid, -phi / 2, 0.0))
    named["shroud_left"], named["shroud_right"] = mid, shroud_pairs[mid]
    grid_nodes = []
    for fr, fz in CONTACT_GRID:
        target = cyl_point(p["r_tip"] + fr * p["shroud_thickness"], -phi / 2,
                           fz * p["shroud_width"])
        n = nearest(left_contact, coords, target)
        if n not in grid_nodes:
            grid_nodes.append(n)
    for k, n in enumerate(grid_nodes, 1):
        named[f"shroud_left_{k}"], named[f"shroud_right_{k}"] = n, shroud_pairs[n]
    assert all(inv[shroud_pairs[n]] == n for n in grid_nodes)

    # outputs
    t = time.time()
    os.makedirs(out, exist_ok=True)
    head = [f"FricHB shrouded blade sector ({p['name']}), configs/models/shrouded_blade",
            f"{ndof} DOFs: {len(kept)} nodes x (r, theta, z) in each node's cylindrical frame, "
            "ascending CalculiX node number; bore (r = r_hub) DOFs removed",
            f"{etype}, E = {MATERIAL['E']:g} Pa, nu = {MATERIAL['nu']:g}, "
            f"rho = {MATERIAL['rho']:g} kg/m^3, SI units"]
    nnz_m = write_mtx(os.path.join(out, "sector_mass.mtx"), Mb, index, ndof,
                      ["sector mass matrix (kg)"] + head)
    nnz_k = write_mtx(os.path.join(out, "sector_stiffness.mtx"), Kb, index, ndof,
                      ["sector stiffness matrix (N/m)"] + head)
    left_dofs, right_dofs = [], []
    for n in sorted(disk_pairs):
        for d in range(3):
            left_dofs.append(index[n] + d)
            right_dofs.append(index[disk_pairs[n]] + d)
    with open(os.path.join(out, "cyclic_pairs.txt.tmp"), "w") as f:
        f.write(f"# cyclic boundary of the disk of {p['name']} ({p['sectors']} sectors): "
                "'left right' 0-based DOF indices;\n"
                "# right DOF of sector s = left DOF of sector s+1 (sector s+1 = sector s turned by "
                "+2 pi/sectors about z);\n"
                f"# {len(disk_pairs)} node pairs x (r, theta, z); the shroud faces are not in it "
                "(they touch by friction contact)\n")
        for a, b in zip(left_dofs, right_dofs):
            f.write(f"{a} {b}\n")
    os.replace(os.path.join(out, "cyclic_pairs.txt.tmp"), os.path.join(out, "cyclic_pairs.txt"))
    with open(os.path.join(out, "dofs.yaml.tmp"), "w") as f:
        f.write(f"# Named nodes of {p['name']}: name: [i_r, i_theta, i_z], 0-based DOF indices of "
                "sector_*.mtx;\n# the frame is (r, theta, z) per node (its cylindrical frame). "
                "shroud_right of sector s touches\n# shroud_left of sector s+1 (periodic partners); "
                "shroud_left_k / shroud_right_k: a grid of\n# contact pairs over the shroud's side "
                "faces (use either the single pair or the grid).\n")
        for name, n in named.items():
            i = index[n]
            f.write(f"{name}: [{i}, {i + 1}, {i + 2}]\n")
    os.replace(os.path.join(out, "dofs.yaml.tmp"), os.path.join(out, "dofs.yaml"))
    write_model_map(out, p, kept, index, coords, faces, named)
    times["write_s"] = round(time.time() - t, 3)
    times["total_s"] = round(time.time() - t_all, 3)

    info = {
        "format_version": FORMAT_VERSION,
        "parameters": p,
        "sources": {"shrouded_blade.geo": sha256_file(GEO),
                    "build_model.py": sha256_file(os.path.abspath(__file__))},
        "material": MATERIAL,
        "element_type": etype,
        "counts": {"mesh_nodes": len(used), "elements": len(elements),
                   "bore_nodes_removed": len(bore), "nodes": len(kept), "dofs": ndof,
                   "cyclic_node_pairs": len(disk_pairs), "cyclic_dof_pairs": len(left_dofs),
                   "shroud_face_nodes": len(sl), "nnz_mass_lower": nnz_m,
                   "nnz_stiffness_lower": nnz_k},
        "sector_mass_kg": mass,
        "mesh_volume_m3": volume,
        "dof_order": "node by node (ascending CalculiX node number), components (r, theta, z) in "
                     "the node's cylindrical frame; FricHB index = Matrix Market row - 1",
        "named_nodes": {name: {"node": n, "dofs": [index[n], index[n] + 1, index[n] + 2],
                               "xyz": list(coords[n]),
                               "r_theta_z": [math.hypot(coords[n][0], coords[n][1]),
                                             math.atan2(coords[n][1], coords[n][0]),
                                             coords[n][2]]}
                        for name, n in named.items()},
        "contact_faces": {
            "mesh": "structured" if contact["structured"] else "unstructured",
            "requested": {"contact_pairs": p["contact_pairs"],
                          "contact_face_size_m": p["contact_face_size"]},
            "grid_r_z": contact["grid"],
            "mesh_vertices_r_z": contact["mesh_grid"],
            "face_area_m2": p["shroud_thickness"] * p["shroud_width"],
            "faces": {name: {"contact_nodes": len(f["nodes"]),
                             "area_sum_m2": math.fsum(a for _, a in f["nodes"]),
                             "normal": list(f["normal"])}
                      for name, f in faces.items()},
            "contact_node_pairs": len(faces["shroud_left"]["nodes"]),
            "areas": "bilinear tributary areas of the structured grid (interior dr*dz, edge "
                     "half, corner quarter)" if contact["structured"] else
                     "1/3 of each linear triangle to each vertex; quadratic triangles split "
                     "into their 4 linear sub-triangles first"},
        "times_s": times,
        "versions": {"gmsh": gmsh_version, "ccx": ccx_version,
                     "python": sys.version.split()[0]},
    }
    with open(os.path.join(out, "model.json.tmp"), "w") as f:
        json.dump(info, f, indent=2)
        f.write("\n")
    os.replace(os.path.join(out, "model.json.tmp"), os.path.join(out, "model.json"))
    if not keep_work:
        shutil.rmtree(work)
    log(f"wrote {out}: {ndof} DOFs ({len(kept)} nodes, {len(bore)} bore nodes removed), "
        f"{len(left_dofs)} cyclic DOF pairs, mass {mass:.6g} kg, nnz K {nnz_k}, M {nnz_m}, "
        f"{times['total_s']:.1f} s")
    return info


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", choices=sorted(PRESETS), required=True)
    ap.add_argument("--out", help="output folder (default configs/models/generated/<name>)")
    ap.add_argument("--name", help="model name (default: the preset's)")
    ap.add_argument("--keep-work", action="store_true",
                    help="keep the gmsh/CalculiX files in <out>/work")
    ap.add_argument("--force", action="store_true", help="rebuild even when up to date")
    ap.add_argument("--gmsh", default="gmsh", help="gmsh executable (default: gmsh on PATH)")
    ap.add_argument("--ccx", default="ccx", help="CalculiX executable (default: ccx on PATH)")
    ap.add_argument("--threads", type=int, default=1, help="CalculiX threads (default 1)")
    ap.add_argument("--contact-pairs", type=int, metavar="N",
                    help="mesh the shroud side faces as a structured grid of N contact nodes "
                         "(n_r x n_z = N, the cells closest to square); default: unstructured")
    ap.add_argument("--contact-face-size", type=float, metavar="H",
                    help="mesh the shroud side faces as a structured grid of spacing near H "
                         "(m) instead")
    for k in GEO_PARAMS:
        ap.add_argument("--" + k.replace("_", "-"), type=int if k in INT_PARAMS else float,
                        help=f"override {k}")
    a = ap.parse_args()

    p = dict(PRESETS[a.preset])
    overridden = {}
    for k in GEO_PARAMS:
        v = getattr(a, k)
        if v is not None:
            overridden[k] = v
    if "mesh_size" in overridden and "blade_mesh_size" not in overridden:
        overridden["blade_mesh_size"] = overridden["mesh_size"]
    p.update(overridden)
    if a.contact_pairs is not None and a.contact_face_size is not None:
        print("build_model.py: error: --contact-pairs and --contact-face-size exclude each other",
              file=sys.stderr)
        return 1
    if a.contact_pairs is not None and a.contact_pairs < 1 or (
            a.contact_face_size is not None and not a.contact_face_size > 0):
        print("build_model.py: error: --contact-pairs must be >= 1, --contact-face-size > 0",
              file=sys.stderr)
        return 1
    p["contact_pairs"] = a.contact_pairs
    p["contact_face_size"] = a.contact_face_size
    suffix = (f"_p{a.contact_pairs}" if a.contact_pairs is not None else
              f"_h{a.contact_face_size:g}" if a.contact_face_size is not None else "")
    p["name"] = a.name or a.preset + suffix
    p["preset"] = a.preset
    out = os.path.abspath(a.out or os.path.join(DEFAULT_ROOT, p["name"]))

    try:
        gmsh, ccx = shutil.which(a.gmsh), shutil.which(a.ccx)
        if gmsh is None:
            raise BuildError(f"gmsh not found ('{a.gmsh}'): install gmsh (Debian: apt install "
                             "gmsh) or pass --gmsh PATH")
        if ccx is None:
            raise BuildError(f"CalculiX ccx not found ('{a.ccx}'): install it (Debian: apt "
                             "install calculix-ccx) or pass --ccx PATH")
        check_params(p)
        sources = {"shrouded_blade.geo": sha256_file(GEO),
                   "build_model.py": sha256_file(os.path.abspath(__file__))}
        mj = os.path.join(out, "model.json")
        if not a.force and all(os.path.isfile(os.path.join(out, f)) for f in OUTPUTS):
            try:
                with open(mj) as f:
                    old = json.load(f)
            except (OSError, ValueError):
                old = {}
            if (old.get("parameters") == p and old.get("sources") == sources
                    and old.get("format_version") == FORMAT_VERSION):
                log(f"{out} is up to date ({old['counts']['dofs']} DOFs); --force rebuilds")
                return 0
        log(f"building {p['name']} in {out}")
        build(p, out, a.keep_work, gmsh, ccx, a.threads)
    except BuildError as e:
        print(f"build_model.py: error: {e}", file=sys.stderr)
        if os.path.isdir(os.path.join(out, "work")):
            print(f"build_model.py: the intermediate files are in {os.path.join(out, 'work')}",
                  file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
