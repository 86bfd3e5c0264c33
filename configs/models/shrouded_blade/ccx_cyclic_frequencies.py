#!/usr/bin/env python3
"""CalculiX's own cyclic-symmetry natural frequencies of a built shrouded blade sector.

An independent check of the sector matrices and of FricHB's cyclic reduction (`frichb modes`):
the mesh that build_model.py meshed (kept with --keep-work in <model>/work/mesh_gmsh.inp) goes
into a CalculiX deck with the same nodes, elements and steel as the matrix export, the bore
clamped (*BOUNDARY on the 3 translations of every bore node: the DOFs build_model.py removes
from the matrices), the disk's side faces tied by *TIE, CYCLIC SYMMETRY (the disk faces only,
as in cyclic_pairs.txt: the shroud faces stay free), and a *FREQUENCY step restricted to the
nodal diameters NMIN..NMAX by *SELECT CYCLIC SYMMETRY MODES. CalculiX solves each nodal
diameter on a doubled (cosine and sine) real model, so every eigenvalue appears twice in its
.dat file, for every nodal diameter (0 and N/2 included, where the two copies are the same
uncoupled problem); the pairs are checked and de-duplicated, 2 K + 2 eigenvalues being asked
for so that the K-th pair is complete.

Usage:
  python3 configs/models/shrouded_blade/ccx_cyclic_frequencies.py MODEL_DIR \
          [--nmin 0] [--nmax N/2] [--modes 6] [--out FILE.json] [--work DIR] [--ccx PATH]

Writes (to --out, default <MODEL_DIR>/ccx_cyclic_frequencies.json) a JSON object:
  {"nodal_diameters": {"0": [f1, f2, ...], ...},   # Hz, ascending, K per nodal diameter
   "ccx_version": "2.20", "seconds": ...,            # wall time of the CalculiX run
   "model": name, "sectors": N, "modes": K, "dependent_nodes_tied": ...}
Frequencies are sqrt(eigenvalue) / (2 pi) from the eigenvalue column (7 significant digits:
at most 2.5e-7 relative in the frequency, against 5e-7 for the frequency column).
Standard library only; exit code 1 on any error.
"""
import argparse
import json
import math
import os
import re
import shutil
import sys
import time

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import build_model as bm  # noqa: E402  (same folder; mesh reader, deck writer, tool runner)

# Two copies of one eigenvalue of CalculiX's doubled cyclic model agree to its print precision
# (7 digits: a last-digit difference is at most 1e-6 relative); distinct modes of one nodal
# diameter are far further apart than this.
PAIR_RTOL = 1e-5
# The relative distance at which CalculiX ties a dependent node to an independent one; the
# build checks the disk faces' periodicity to 1e-6 r_tip.
TIE_TOL_RTIP = 1e-5
EIGEN_HEADER = "E I G E N V A L U E   O U T P U T"


class CyclicError(Exception):
    pass


def load_model(model_dir):
    """model.json and the kept mesh (nodes of the volume elements, elements, node sets)."""
    try:
        with open(os.path.join(model_dir, "model.json")) as f:
            info = json.load(f)
    except (OSError, ValueError) as e:
        raise CyclicError(f"cannot read {model_dir}/model.json: {e}")
    inp = os.path.join(model_dir, "work", "mesh_gmsh.inp")
    if not os.path.isfile(inp):
        raise CyclicError(f"{inp} is missing: build the model with --keep-work")
    nodes, elements, nsets = bm.parse_gmsh_inp(inp)
    etype = info["element_type"]
    elements = [e for e in elements if e[0] == etype]
    used = set()
    for _, conn in elements:
        used.update(conn)
    coords = {n: nodes[n] for n in used}
    bore = set(nsets["bore"]) & used           # exactly the nodes build_model.py removes
    counts = info["counts"]
    if (len(used), len(elements), len(bore)) != (counts["mesh_nodes"], counts["elements"],
                                                  counts["bore_nodes_removed"]):
        raise CyclicError(f"{inp} does not match model.json (nodes, elements, bore nodes: "
                          f"{len(used)}, {len(elements)}, {len(bore)} against "
                          f"{counts['mesh_nodes']}, {counts['elements']}, "
                          f"{counts['bore_nodes_removed']})")
    disk_left = sorted((set(nsets["disk_left"]) & used) - bore)
    disk_right = sorted((set(nsets["disk_right"]) & used) - bore)
    return info, coords, elements, etype, bore, disk_left, disk_right


def nset_lines(name, ids):
    lines = [f"*NSET, NSET={name}"]
    ids = sorted(ids)
    for i in range(0, len(ids), 10):
        lines.append(", ".join(str(n) for n in ids[i:i + 10]))
    return lines


def write_cyclic_deck(path, info, coords, elements, etype, bore, disk_left, disk_right, nmin,
                      nmax, n_eig):
    """build_model.py's deck (same nodes, elements, material) with a cyclic frequency step."""
    bm.write_ccx_deck(path, coords, elements, etype)
    with open(path) as f:
        deck = f.read()
    storage_step = "*STEP\n*FREQUENCY, SOLVER=MATRIXSTORAGE\n*END STEP\n"
    if not deck.endswith(storage_step):
        raise CyclicError("build_model.write_ccx_deck no longer ends with the matrix storage "
                          "step; update ccx_cyclic_frequencies.py")
    p = info["parameters"]
    lines = ["** cyclic-symmetry frequencies, configs/models/shrouded_blade/"
             "ccx_cyclic_frequencies.py"]
    lines += nset_lines("BORE", bore)
    lines += nset_lines("DISKL", disk_left)
    lines += nset_lines("DISKR", disk_right)
    lines += [
        "*SURFACE, NAME=SDISKL, TYPE=NODE", "DISKL",
        "*SURFACE, NAME=SDISKR, TYPE=NODE", "DISKR",
        # dependent (slave) surface first, then the independent one
        f"*TIE, NAME=CYCL, CYCLIC SYMMETRY, POSITION TOLERANCE={TIE_TOL_RTIP * p['r_tip']:.6g}",
        "SDISKR, SDISKL",
        f"*CYCLIC SYMMETRY MODEL, N={p['sectors']}, NGRAPH=1, TIE=CYCL",
        "0., 0., 0., 0., 0., 1.",                # the axis: z
        "*BOUNDARY", "BORE, 1, 3",              # the clamped bore, as removed from the matrices
        "*STEP", "*FREQUENCY", str(n_eig),
        f"*SELECT CYCLIC SYMMETRY MODES, NMIN={nmin}, NMAX={nmax}",
        "*END STEP", ""]
    with open(path, "w") as f:
        f.write(deck[:-len(storage_step)] + "\n".join(lines))


def parse_eigenvalues(dat_path):
    """{nodal diameter: [eigenvalues in listing order]} from the eigenvalue tables of a .dat."""
    with open(dat_path) as f:
        text = f.read()
    table = {}
    for block in text.split(EIGEN_HEADER)[1:]:
        started = False
        for line in block.splitlines():
            a = line.split()
            if len(a) == 6 and a[0].isdigit() and a[1].isdigit():
                started = True
                lam, f_hz = float(a[2]), float(a[4])
                if lam <= 0 or abs(math.sqrt(lam) / (2 * math.pi) - f_hz) > 2e-6 * f_hz:
                    raise CyclicError(f"{dat_path}: eigenvalue {a[2]} and frequency {a[4]} "
                                      f"do not match (ND {a[0]}, mode {a[1]})")
                table.setdefault(int(a[0]), []).append(lam)
            elif started:
                break                          # end of this table
    return table


def distinct_frequencies(eigenvalues, modes, nd):
    """The lowest `modes` frequencies (Hz) from the doubled model's eigenvalues (pairs)."""
    lam = sorted(eigenvalues)
    out, i = [], 0
    while i + 1 < len(lam) and len(out) < modes:
        if abs(lam[i + 1] - lam[i]) > PAIR_RTOL * lam[i + 1]:
            raise CyclicError(f"ND {nd}: eigenvalue {lam[i]:.7g} is not paired (next "
                              f"{lam[i + 1]:.7g}); CalculiX's doubled cyclic model lists each "
                              "one twice")
        out.append(math.sqrt(0.5 * (lam[i] + lam[i + 1])) / (2 * math.pi))
        i += 2
    if len(out) < modes:
        raise CyclicError(f"ND {nd}: {len(out)} distinct frequencies found, {modes} asked for "
                          f"({len(lam)} eigenvalues listed)")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("model_dir", help="model folder built by build_model.py with --keep-work")
    ap.add_argument("--nmin", type=int, default=0, help="lowest nodal diameter (default 0)")
    ap.add_argument("--nmax", type=int, help="highest nodal diameter (default sectors/2)")
    ap.add_argument("--modes", type=int, default=6, help="frequencies per nodal diameter")
    ap.add_argument("--out", help="JSON file (default <MODEL_DIR>/ccx_cyclic_frequencies.json)")
    ap.add_argument("--work", help="CalculiX folder (default <MODEL_DIR>/work/cyclic)")
    ap.add_argument("--ccx", default="ccx", help="CalculiX executable (default: ccx on PATH)")
    ap.add_argument("--threads", type=int, default=1, help="CalculiX threads (default 1)")
    a = ap.parse_args()
    model_dir = os.path.abspath(a.model_dir)
    out = os.path.abspath(a.out or os.path.join(model_dir, "ccx_cyclic_frequencies.json"))
    work = os.path.abspath(a.work or os.path.join(model_dir, "work", "cyclic"))

    try:
        ccx = shutil.which(a.ccx)
        if ccx is None:
            raise CyclicError(f"CalculiX ccx not found ('{a.ccx}')")
        info, coords, elements, etype, bore, dl, dr = load_model(model_dir)
        sectors = info["parameters"]["sectors"]
        nmax = sectors // 2 if a.nmax is None else a.nmax
        if not 0 <= a.nmin <= nmax <= sectors // 2:
            raise CyclicError(f"need 0 <= nmin <= nmax <= sectors/2 = {sectors // 2}")
        if a.modes < 1:
            raise CyclicError("--modes must be >= 1")
        if len(dl) != len(dr) or len(dl) != info["counts"]["cyclic_node_pairs"]:
            raise CyclicError(f"{len(dl)} left and {len(dr)} right disk-face nodes, model.json "
                              f"has {info['counts']['cyclic_node_pairs']} cyclic node pairs")

        os.makedirs(work, exist_ok=True)
        for f in os.listdir(work):
            if f.startswith("cyclic."):
                os.remove(os.path.join(work, f))
        write_cyclic_deck(os.path.join(work, "cyclic.inp"), info, coords, elements, etype, bore,
                          dl, dr, a.nmin, nmax, 2 * a.modes + 2)
        ccx_version = bm.tool_version(ccx, ["-v"], r"Version\s+([\d.]+)")
        env = dict(os.environ, OMP_NUM_THREADS=str(a.threads),
                   CCX_NPROC_STIFFNESS=str(a.threads), CCX_NPROC_EQUATION_SOLVER=str(a.threads))
        t = time.time()
        try:
            cout = bm.run([ccx, "-i", "cyclic"], work, "ccx cyclic", env=env)
        except bm.BuildError as e:
            raise CyclicError(str(e))
        seconds = time.time() - t
        if "*ERROR" in cout.upper() or "Job finished" not in cout:
            bad = [l for l in cout.splitlines() if "ERROR" in l.upper()]
            raise CyclicError("ccx failed:\n" + "\n".join(bad[:20] or cout.splitlines()[-20:]))
        m = re.search(r"dependent nodes tied by cyclic constraints:\s*(\d+)", cout)
        tied = int(m.group(1)) if m else -1
        if tied != len(dr):
            raise CyclicError(f"ccx tied {tied} dependent nodes, expected {len(dr)} "
                              f"(see {work}/ccx_cyclic.log)")

        table = parse_eigenvalues(os.path.join(work, "cyclic.dat"))
        wanted = list(range(a.nmin, nmax + 1))
        if sorted(table) != wanted:
            raise CyclicError(f"cyclic.dat lists nodal diameters {sorted(table)}, "
                              f"expected {wanted}")
        freqs = {str(nd): distinct_frequencies(table[nd], a.modes, nd) for nd in wanted}
        result = {"nodal_diameters": freqs, "ccx_version": ccx_version,
                  "seconds": round(seconds, 3), "model": info["parameters"].get("name"),
                  "sectors": sectors, "modes": a.modes, "dependent_nodes_tied": tied}
        os.makedirs(os.path.dirname(out), exist_ok=True)
        with open(out + ".tmp", "w") as f:
            json.dump(result, f, indent=2)
            f.write("\n")
        os.replace(out + ".tmp", out)
    except (CyclicError, bm.BuildError, OSError, KeyError) as e:
        print(f"ccx_cyclic_frequencies.py: error: {e}", file=sys.stderr)
        return 1
    for nd in wanted:
        print(f"ND {nd}: " + " ".join(f"{f:.6f}" for f in freqs[str(nd)]))
    print(f"wrote {out} (ccx {ccx_version}, {seconds:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
