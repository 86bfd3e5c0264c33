#!/usr/bin/env python3
"""Checks the sample vendor exports (configs/models/vendor_samples) against their walk-through.

The walk-through "Walk-through with the sample exports" of docs/fe-models.md takes the shipped
samples to a response curve with the shipped scene vendor_sample_blade.yaml. This test keeps
the page, the scene and the samples from drifting apart:
  (a) runs the `frichb import` commands of the walk-through's code blocks as written ($S the
      samples' folder, outputs in WORK): each must import 155 nodes and write the model files,
      and the ANSYS and the Abaqus import must write the same matrices (SI, the nodes' frames;
      entries to 1e-9 of the largest);
  (b) every FE node number the walk-through's YAML blocks and the shipped scene name
      (`dof: N`, `node: N`, `response: [N, ...]`) must be the same set in both, a node of the
      sample (in k.mapping and sector.node of the ANSYS sample, in the matrices and *NODE
      lines of the Abaqus one) and a node with three rows in the imported nodes.csv; the two
      nodes of each `between` contact must be shroud contact nodes (not_cyclic.txt) and
      coincide once the second is turned by the sectors between them (+2 pi / 8 each), 1e-9 m;
  (c) `frichb validate` accepts the shipped scene beside the imported model, and `frichb modes`
      on the ANSYS and the Abaqus import gives the same frequencies (1e-9 relative) and the
      first-family frequencies the page quotes (to its 2 decimals);
  (d) the samples' faces.csv ("Faces of an imported model"): its faces shroud_left and
      shroud_right hold exactly the shroud nodes of not_cyclic.txt, each in the imported
      nodes.csv; the page's patch contact is the shipped patch scene's, and `frichb validate`
      accepts that scene once faces.csv is in the imported model map.

Usage: check_vendor_samples.py SOURCE_DIR FRICHB WORK_DIR   (exit 1 on the first failed check)
Standard library only; about 2 s.
"""
import csv
import math
import os
import re
import shlex
import shutil
import subprocess
import sys

SECTORS = 8


def fail(msg):
    sys.exit(f"check_vendor_samples: {msg}")


def run(cmd, cwd):
    p = subprocess.run(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if p.returncode != 0:
        fail(f"exit code {p.returncode}: {' '.join(cmd)}\n{p.stdout}")
    return p.stdout


def doc_section(doc_path, title):
    """The text under heading `title` up to the next heading of its level or above, and its
    code blocks [(language, body)]."""
    text = open(doc_path, encoding="utf-8").read()
    if text.count(title + "\n") != 1:
        fail(f"{doc_path}: no single section '{title}'")
    level = title.split(" ", 1)[0]
    section = text.split(title + "\n", 1)[1]
    section = re.split(r"\n#{1,%d} " % len(level), section, maxsplit=1)[0]
    blocks = re.findall(r"```(\w*)\n(.*?)```", section, re.S)
    if not blocks:
        fail(f"{doc_path}: the section '{title}' has no code blocks")
    return section, blocks


def contacts_block(yaml_text):
    """The lines of the top-level 'contacts:' block, comments kept, blank lines dropped."""
    lines, inside = [], False
    for line in yaml_text.splitlines():
        if line.startswith("contacts:"):
            inside = True
        elif inside and line and not line.startswith((" ", "#")):
            break
        if inside and line.strip():
            lines.append(line.rstrip())
    return lines


def node_numbers(yaml_text):
    """FE node numbers named in scene YAML: dof: N, node: N, response: [N, ...]."""
    nums = set(int(n) for n in re.findall(r"\b(?:dof|node):\s*(\d+)\b", yaml_text))
    for lst in re.findall(r"\bresponse:\s*\[([^\]]*)\]", yaml_text):
        nums.update(int(v) for v in lst.split(",") if v.strip().isdigit())
    return nums


def between_pairs(yaml_text):
    pat = (r"between:\s*\[\{node:\s*(\d+),\s*sector:\s*(\d+)\},\s*"
           r"\{node:\s*(\d+),\s*sector:\s*(\d+)\}\]")
    return [tuple(int(v) for v in m) for m in re.findall(pat, yaml_text)]


def sample_nodes(samples):
    """Node numbers of each sample, read from its own files."""
    hb = os.path.join(samples, "ansys_hbmat")
    mapping = set()
    with open(os.path.join(hb, "k.mapping")) as f:
        next(f)
        mapping = {int(line.split()[1]) for line in f if line.strip()}
    with open(os.path.join(hb, "sector.node")) as f:
        nwrite = {int(line[:9]) for line in f if line.strip()}
    ab = os.path.join(samples, "abaqus_matrix_input")
    with open(os.path.join(ab, "job_STIF1.mtx")) as f:
        matrix = set()
        for line in f:
            a = line.split(",")
            matrix.update((int(a[0]), int(a[2])))
    inp, in_node = set(), False
    with open(os.path.join(ab, "job.inp")) as f:
        for line in f:
            s = line.strip()
            if s.startswith("*"):
                in_node = s.upper().replace(" ", "").startswith("*NODE,") or s.upper() == "*NODE"
                continue
            if in_node and s:
                inp.add(int(s.split(",")[0]))
    return {"ansys_hbmat/k.mapping": mapping, "ansys_hbmat/sector.node": nwrite,
            "abaqus_matrix_input/job_STIF1.mtx": matrix, "abaqus_matrix_input/job.inp": inp}


def imported_nodes(model):
    out = {}
    with open(os.path.join(model, "nodes.csv")) as f:
        for r in csv.DictReader(f):
            rows = [int(r[f"dof_{k}"]) for k in (1, 2, 3)]
            out[int(r["node"])] = ((float(r["x"]), float(r["y"]), float(r["z"])), rows)
    return out


def matrix(path):
    """Matrix Market coordinate entries {(row, column): value}."""
    out = {}
    with open(path) as f:
        lines = [line for line in f if not line.startswith("%")]
    for line in lines[1:]:
        a = line.split()
        if a:
            out[(int(a[0]), int(a[1]))] = float(a[2])
    return out


def families(path):
    with open(path) as f:
        return {int(r["nodal_diameter"]): [float(v) for k, v in r.items() if k != "nodal_diameter"]
                for r in csv.DictReader(f)}


def main():
    if len(sys.argv) != 4:
        fail("usage: check_vendor_samples.py SOURCE_DIR FRICHB WORK_DIR")
    source, frichb, work = (os.path.abspath(a) for a in sys.argv[1:4])
    samples = os.path.join(source, "configs", "models", "vendor_samples")
    scene_path = os.path.join(samples, "vendor_sample_blade.yaml")
    doc = os.path.join(source, "docs", "fe-models.md")
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)

    section, blocks = doc_section(doc, "## Walk-through with the sample exports")

    # (a) the walk-through's imports, as written
    imports = []
    for lang, body in blocks:
        if lang:
            continue
        for cmd in body.replace("\\\n", " ").splitlines():
            if cmd.strip().startswith("frichb import"):
                imports.append(cmd.strip())
    if len(imports) < 2:
        fail(f"expected the walk-through's two `frichb import` commands, found {len(imports)}")
    outputs = []
    for cmd in imports:
        argv = shlex.split(cmd.replace("$S", samples))
        argv[0] = frichb
        out = run(argv, work)
        if "imported 155 nodes, 465 DOFs" not in out:
            fail(f"{cmd}: expected 'imported 155 nodes, 465 DOFs' in\n{out}")
        outputs.append(argv[argv.index("-o") + 1])
    for o in outputs:
        for name in ("sector_stiffness.mtx", "sector_mass.mtx", "cyclic_pairs.txt", "mesh.yaml",
                     "nodes.csv"):
            if not os.path.isfile(os.path.join(work, o, name)):
                fail(f"the import into {o} wrote no {name}")
    if "model" not in outputs:
        fail(f"the scene reads model/, the walk-through imports into {outputs}")
    # the imports are one model (SI, the same rows): entries to 1e-9 of the largest
    for name in ("sector_stiffness.mtx", "sector_mass.mtx"):
        mats = [matrix(os.path.join(work, o, name)) for o in outputs]
        scale = max(abs(v) for v in mats[0].values())
        for other, o in zip(mats[1:], outputs[1:]):
            keys = set(mats[0]) | set(other)
            worst = max(abs(mats[0].get(k, 0.0) - other.get(k, 0.0)) for k in keys) / scale
            if worst > 1e-9:
                fail(f"{name}: the imports into {outputs[0]} and {o} differ by {worst:.3g} "
                     f"of the largest entry")

    # (b) node numbers: page == scene, in each sample file, in the imported map
    scene_text = open(scene_path).read()
    doc_yaml = "".join(body for lang, body in blocks if lang == "yaml")
    doc_nodes, scene_nodes = node_numbers(doc_yaml), node_numbers(scene_text)
    if not doc_nodes:
        fail("the walk-through's YAML names no FE node")
    if doc_nodes != scene_nodes:
        fail(f"the walk-through names nodes {sorted(doc_nodes)}, the shipped scene "
             f"{sorted(scene_nodes)}")
    for name, nodes in sample_nodes(samples).items():
        missing = sorted(doc_nodes - nodes)
        if missing:
            fail(f"nodes {missing} of the walk-through are not in the sample's {name}")
    imported = imported_nodes(os.path.join(work, "model"))
    for n in sorted(doc_nodes):
        if n not in imported or min(imported[n][1]) < 0:
            fail(f"node {n} has no three rows in the imported nodes.csv")
    with open(os.path.join(samples, "not_cyclic.txt")) as f:
        shroud = {int(v) for line in f for v in line.split("#")[0].replace(",", " ").split()}
    pairs = between_pairs(doc_yaml)
    if not pairs or pairs != between_pairs(scene_text):
        fail(f"contacts 'between' of the walk-through {pairs} differ from the scene's "
             f"{between_pairs(scene_text)}")
    for a, sa, b, sb in pairs:
        if a not in shroud or b not in shroud:
            fail(f"contact nodes {a}, {b}: not both shroud contact nodes (not_cyclic.txt)")
        t = 2.0 * math.pi / SECTORS * (sb - sa)
        (xa, ya, za), (xb, yb, zb) = imported[a][0], imported[b][0]
        d = math.dist((xa, ya, za), (xb * math.cos(t) - yb * math.sin(t),
                                     xb * math.sin(t) + yb * math.cos(t), zb))
        if d > 1e-9:
            fail(f"node {b} of sector {sb} is {d:.3g} m from node {a} of sector {sa}")

    # (c) the shipped scene validates beside the import; modes of both imports
    shutil.copy(scene_path, work)
    run([frichb, "--log-level", "warn", "validate", "vendor_sample_blade.yaml"], work)
    run([frichb, "--log-level", "warn", "modes", "vendor_sample_blade.yaml", "-o", "modes"], work)
    other = [o for o in outputs if o != "model"][0]
    with open(os.path.join(work, "vendor_sample_blade_other.yaml"), "w") as f:
        f.write(scene_text.replace("model/", other + "/"))
    run([frichb, "--log-level", "warn", "modes", "vendor_sample_blade_other.yaml", "-o",
         "modes_other"], work)
    a, b = families(os.path.join(work, "modes", "families.csv")), \
        families(os.path.join(work, "modes_other", "families.csv"))
    worst = max(abs(x - y) / x for nd in a for x, y in zip(a[nd], b[nd]))
    if sorted(a) != sorted(b) or worst > 1e-9:
        fail(f"the two imports' frequencies differ by {worst:.3g} relative")
    m = re.search(r"first family at ([\d.]+) Hz \(nodal diameter 0\) and\s+([\d.]+) Hz "
                  r"\(nodal diameter 1\)", section)
    if not m:
        fail("the walk-through quotes no first-family frequencies")
    for nd, quoted in ((0, m.group(1)), (1, m.group(2))):
        if f"{a[nd][0]:.2f}" != quoted:
            fail(f"nodal diameter {nd}: first family {a[nd][0]:.6f} Hz, the page says {quoted}")
    # (d) the samples' faces and the patch scene
    with open(os.path.join(samples, "faces.csv")) as f:
        header = f.readline().strip()
        rows = [line.strip().split(",") for line in f if line.strip()]
    if header != "face,node,area,nx,ny,nz":
        fail(f"faces.csv: header '{header}'")
    faces = {}
    for r in rows:
        faces.setdefault(r[0], set()).add(int(r[1]))
    if sorted(faces) != ["shroud_left", "shroud_right"]:
        fail(f"faces.csv: faces {sorted(faces)}, expected shroud_left and shroud_right")
    if faces["shroud_left"] | faces["shroud_right"] != shroud:
        fail(f"faces.csv: nodes {sorted(faces['shroud_left'] | faces['shroud_right'])}, "
             f"not_cyclic.txt {sorted(shroud)}")
    if any(n not in imported for n in shroud):
        fail("faces.csv: a node not in the imported nodes.csv")
    patch_scene = os.path.join(samples, "vendor_sample_blade_patch.yaml")
    _, patch_blocks = doc_section(doc, "### Faces of an imported model")
    doc_patch = [contacts_block(body) for lang, body in patch_blocks if lang == "yaml"]
    if doc_patch != [contacts_block(open(patch_scene).read())]:
        fail(f"the page's patch contact {doc_patch} is not the patch scene's")
    shutil.copy(os.path.join(samples, "faces.csv"), os.path.join(work, "model"))
    with open(os.path.join(work, "model", "mesh.yaml"), "a") as f:
        f.write("faces: faces.csv\n")
    shutil.copy(patch_scene, work)
    out = run([frichb, "validate", "vendor_sample_blade_patch.yaml"], work)
    if "patch of 8 node pairs" not in out:
        fail(f"the patch scene: expected 'patch of 8 node pairs' in\n{out}")

    print(f"check_vendor_samples: {len(imports)} imports, nodes {sorted(doc_nodes)} in every "
          f"sample file, contact pairs {pairs} coincide, scene valid; first family "
          f"{a[0][0]:.6f} / {a[1][0]:.6f} Hz (ND 0 / 1), imports agree to {worst:.2g}; patch "
          f"scene valid (8 node pairs)")


if __name__ == "__main__":
    main()
