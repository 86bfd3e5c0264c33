#!/usr/bin/env python3
"""Checks the model map written by configs/models/shrouded_blade/build_model.py.

Builds three small models into WORK (tiny: linear tets, unstructured contact faces; test_case:
quadratic tets, unstructured faces whose mid-side nodes are contact nodes too; test_case with
--contact-pairs 16: a structured 16-node contact grid) and checks for each:
  - mesh.yaml names nodes.csv and faces.csv, format 1, SI units;
  - nodes.csv: the exact header, unique node numbers, frame cylindrical, its rows a permutation
    of 0 .. DOFs-1 (DOFs from sector_stiffness.mtx); every named node of dofs.yaml is a node
    set of mesh.yaml whose node has the same rows in nodes.csv;
  - faces.csv: the exact header, faces shroud_left and shroud_right, positive areas summing to
    the face area shroud_thickness * shroud_width (1e-12 relative), unit normals pointing out
    of the sector (-e_theta on the left face at theta = -phi/2, +e_theta on the right face),
    every face node in nodes.csv, row k of shroud_right the +phi rotation of row k of
    shroud_left with the same area;
  - with --contact-pairs N: N contact nodes per face on an n_r x n_z grid (n_r * n_z = N
    distinct radii and axial positions as recorded in model.json).

Usage: check_model_map.py SOURCE_DIR WORK_DIR     (exit code 1 on the first failed check)
Standard library only.
"""
import csv
import json
import math
import os
import re
import shutil
import subprocess
import sys


def fail(msg):
    sys.exit(f"check_model_map: {msg}")


def read_mesh_yaml(path):
    """The subset of YAML that mesh.yaml uses: 'key: value' and a 'node_sets:' block of
    '  name: [n, ...]' lines."""
    top, sets, in_sets = {}, {}, False
    with open(path) as f:
        for line in f:
            line = line.split("#", 1)[0].rstrip()
            if not line.strip():
                continue
            if in_sets and line.startswith(" "):
                m = re.fullmatch(r"\s+(\w+):\s*\[([\d,\s]*)\]", line)
                if not m:
                    fail(f"{path}: cannot read node set line '{line}'")
                sets[m.group(1)] = [int(v) for v in m.group(2).split(",") if v.strip()]
                continue
            in_sets = False
            key, _, value = line.partition(":")
            if key == "node_sets" and not value.strip():
                in_sets = True
            else:
                top[key.strip()] = value.strip()
    return top, sets


def read_dofs_yaml(path):
    named = {}
    with open(path) as f:
        for line in f:
            line = line.split("#", 1)[0].strip()
            if line:
                m = re.fullmatch(r"(\w+):\s*\[(\d+),\s*(\d+),\s*(\d+)\]", line)
                if not m:
                    fail(f"{path}: cannot read '{line}'")
                named[m.group(1)] = [int(m.group(k)) for k in (2, 3, 4)]
    return named


def matrix_size(path):
    with open(path) as f:
        for line in f:
            if not line.startswith("%"):
                rows, cols, _ = (int(v) for v in line.split())
                if rows != cols:
                    fail(f"{path}: not square")
                return rows
    fail(f"{path}: no size line")


def check_model(model, pairs):
    info = json.load(open(os.path.join(model, "model.json")))
    p = info["parameters"]
    phi = 2 * math.pi / p["sectors"]
    face_area = p["shroud_thickness"] * p["shroud_width"]
    tol = 1e-6 * p["r_tip"]

    top, sets = read_mesh_yaml(os.path.join(model, "mesh.yaml"))
    expected = {"format": "1", "units": "SI", "nodes": "nodes.csv", "faces": "faces.csv"}
    for key, value in expected.items():
        if top.get(key) != value:
            fail(f"mesh.yaml: {key} is '{top.get(key)}', expected '{value}'")

    # nodes.csv
    with open(os.path.join(model, "nodes.csv")) as f:
        header = f.readline().strip()
        if header != "node,x,y,z,frame,dof_1,dof_2,dof_3":
            fail(f"nodes.csv: header '{header}'")
        nodes = {}
        for row in csv.reader(f):
            n = int(row[0])
            if n in nodes:
                fail(f"nodes.csv: node {n} listed twice")
            if row[4] != "cylindrical":
                fail(f"nodes.csv: node {n} has frame '{row[4]}'")
            nodes[n] = ([float(v) for v in row[1:4]], [int(v) for v in row[5:8]])
    ndof = matrix_size(os.path.join(model, "sector_stiffness.mtx"))
    rows = sorted(i for _, dofs in nodes.values() for i in dofs)
    if rows != list(range(ndof)):
        fail(f"nodes.csv: the rows are not a permutation of 0..{ndof - 1}")

    # named nodes: dofs.yaml against mesh.yaml's node sets and nodes.csv
    named = read_dofs_yaml(os.path.join(model, "dofs.yaml"))
    if set(named) != set(sets):
        fail(f"dofs.yaml names {sorted(named)} but mesh.yaml's node sets are {sorted(sets)}")
    for name, dofs in named.items():
        if len(sets[name]) != 1 or sets[name][0] not in nodes:
            fail(f"mesh.yaml: node set {name} is not one node of nodes.csv")
        if nodes[sets[name][0]][1] != dofs:
            fail(f"{name}: dofs.yaml {dofs}, nodes.csv {nodes[sets[name][0]][1]}")

    # faces.csv
    faces = {}
    with open(os.path.join(model, "faces.csv")) as f:
        header = f.readline().strip()
        if header != "face,node,area,nx,ny,nz":
            fail(f"faces.csv: header '{header}'")
        for row in csv.reader(f):
            faces.setdefault(row[0], []).append((int(row[1]), float(row[2]),
                                                 [float(v) for v in row[3:6]]))
    if sorted(faces) != ["shroud_left", "shroud_right"]:
        fail(f"faces.csv: faces {sorted(faces)}")
    for name, sign in (("shroud_left", -1.0), ("shroud_right", 1.0)):
        total = math.fsum(a for _, a, _ in faces[name])
        if abs(total - face_area) > 1e-12 * face_area:
            fail(f"{name}: areas sum to {total!r}, the face is {face_area!r} "
                 f"(relative {(total - face_area) / face_area:.2e})")
        for n, area, normal in faces[name]:
            if n not in nodes:
                fail(f"{name}: node {n} is not in nodes.csv")
            if not area > 0:
                fail(f"{name}: node {n} has area {area}")
            if abs(math.sqrt(sum(c * c for c in normal)) - 1) > 1e-12:
                fail(f"{name}: node {n}: the normal {normal} is not a unit vector")
            x, y, _ = nodes[n][0]
            theta = math.atan2(y, x)
            if abs(theta - sign * phi / 2) > 1e-9:
                fail(f"{name}: node {n} at theta = {theta} is not on the face")
            e_theta = (-math.sin(theta), math.cos(theta), 0.0)
            if abs(sum(normal[k] * e_theta[k] for k in range(3)) - sign) > 1e-12:
                fail(f"{name}: node {n}: the normal {normal} is not {sign:+g} e_theta (outward)")
    left, right = faces["shroud_left"], faces["shroud_right"]
    if len(left) != len(right) or len(set(n for n, _, _ in right)) != len(right):
        fail(f"{len(left)} left and {len(right)} right contact nodes (or a repeated node)")
    c, s = math.cos(phi), math.sin(phi)
    for (nl, al, _), (nr, ar, _) in zip(left, right):
        x, y, z = nodes[nl][0]
        target = (c * x - s * y, s * x + c * y, z)
        if math.dist(target, nodes[nr][0]) > tol:
            fail(f"right node {nr} is not the +phi rotation of left node {nl}")
        if abs(al - ar) > 1e-12 * al:
            fail(f"paired nodes {nl}, {nr} have areas {al!r}, {ar!r}")

    # the contact grid
    grid = info["contact_faces"]["grid_r_z"]
    if pairs is not None:
        if grid is None or grid[0] * grid[1] != pairs or len(left) != pairs:
            fail(f"--contact-pairs {pairs}: grid {grid}, {len(left)} contact nodes per face")
        radii = {round(math.hypot(*nodes[n][0][:2]) / tol) for n, _, _ in left}
        heights = {round(nodes[n][0][2] / tol) for n, _, _ in left}
        if (len(radii), len(heights)) != tuple(grid):
            fail(f"the contact nodes span {len(radii)} radii x {len(heights)} axial positions, "
                 f"the grid is {grid}")
    return (f"{os.path.basename(model)}: {ndof} DOFs, {len(left)} contact pairs"
            + (f" (grid {grid[0]} x {grid[1]})" if grid else " (unstructured face mesh)")
            + f", face area {face_area:.6g} m^2")


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    source, work = sys.argv[1], sys.argv[2]
    build = os.path.join(source, "configs", "models", "shrouded_blade", "build_model.py")
    if os.path.isdir(work):
        shutil.rmtree(work)
    os.makedirs(work)
    for preset, pairs in (("tiny", None), ("test_case", None), ("test_case", 16)):
        out = os.path.join(work, preset if pairs is None else f"{preset}_p{pairs}")
        cmd = [sys.executable, build, "--preset", preset, "--out", out]
        if pairs is not None:
            cmd += ["--contact-pairs", str(pairs)]
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        if p.returncode != 0:
            fail(f"{' '.join(cmd)} failed ({p.returncode}):\n{p.stdout}")
        print(check_model(out, pairs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
