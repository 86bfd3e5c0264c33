#!/usr/bin/env python3
"""Runs every shipped input with two frichb programs and compares what they write.

For a change that must not change results (a restructuring): build the program before the
change and after it, then

    scripts/compare_results.py OLD/bin/frichb build/bin/frichb

Each input runs with its verb (configs/*.yaml, stress/, comparisons/ and the test-case scenes
when their FE model has been generated: run; studies/: study; friction_loops/: loop) into
DIR/old/NAME and DIR/new/NAME. Compared: the exit code; every CSV cell (numbers within
--rtol of the larger magnitude in their column, text exactly; not the wall-time columns); every JSON value (numbers
within --rtol relative, everything else exactly) except timings, peak memory, file paths and
the program's version. Plots, gnuplot scripts and the folder's manifest of what it holds
(.frichb-written.json, by inode) are not compared. Prints one line per input
and exits 1 when any differs.
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

# The output folder's manifest (support/output.hpp): its entries' identities are inode numbers.
MANIFEST = ".frichb-written.json"

# JSON keys whose values depend on the machine, the clock or the paths, not on the results.
# Keys with "wall" in their name (wall_s, wall_time_s) are left out too.
IGNORED_KEYS = {"profile", "peak_rss_mb", "version", "seconds", "timings", "setup_s",
                "elapsed_s", "threads"}


def inputs():
    """(verb, input file) for every shipped input."""
    cfg = ROOT / "configs"
    found = []
    for folder in ["", "stress", "comparisons"]:
        found += [("run", p) for p in sorted((cfg / folder).glob("*.yaml"))]
    found += [("study", p) for p in sorted((cfg / "studies").glob("*.yaml"))]
    found += [("loop", p) for p in sorted((cfg / "friction_loops").glob("*.yaml"))]
    if (cfg / "models" / "generated" / "test_case").is_dir():
        found += [("run", p) for p in sorted((cfg / "case_studies").glob("test_case_*.yaml"))]
    return found


def numbers_close(a, b, scale, rtol):
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return abs(a - b) <= rtol * max(abs(a), abs(b), scale)


def as_number(text):
    try:
        return float(text)
    except ValueError:
        return None


def compare_csv(old, new, rtol):
    with open(old, newline="") as f:
        a = list(csv.reader(f))
    with open(new, newline="") as f:
        b = list(csv.reader(f))
    if len(a) != len(b):
        return f"{len(a)} rows against {len(b)}"
    columns = max((len(r) for r in a), default=0)
    scale = [0.0] * columns
    for row in a + b:
        for j, cell in enumerate(row):
            x = as_number(cell)
            if x is not None and math.isfinite(x) and j < columns:
                scale[j] = max(scale[j], abs(x))
    # Timing columns (wall_s, ...) depend on the machine.
    timing = {j for j, name in enumerate(a[0] if a else []) if "wall" in name}
    for i, (ra, rb) in enumerate(zip(a, b)):
        if len(ra) != len(rb):
            return f"row {i + 1}: {len(ra)} cells against {len(rb)}"
        for j, (ca, cb) in enumerate(zip(ra, rb)):
            if j in timing and i > 0:
                continue
            xa, xb = as_number(ca), as_number(cb)
            if xa is not None and xb is not None:
                if not numbers_close(xa, xb, scale[j], rtol):
                    return f"row {i + 1}, column {j + 1}: {ca} against {cb}"
            elif ca != cb:
                return f"row {i + 1}, column {j + 1}: '{ca}' against '{cb}'"
    return None


def compare_json(a, b, rtol, where, old_dir, new_dir):
    if isinstance(a, dict) and isinstance(b, dict):
        keys = {k for k in set(a) | set(b) if k not in IGNORED_KEYS and "wall" not in k}
        for key in sorted(keys):
            if key not in a or key not in b:
                return f"{where}.{key}: only in {'new' if key in b else 'old'}"
            why = compare_json(a[key], b[key], rtol, f"{where}.{key}", old_dir, new_dir)
            if why:
                return why
        return None
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return f"{where}: {len(a)} entries against {len(b)}"
        for i, (x, y) in enumerate(zip(a, b)):
            why = compare_json(x, y, rtol, f"{where}[{i}]", old_dir, new_dir)
            if why:
                return why
        return None
    if isinstance(a, bool) or isinstance(b, bool):
        return None if a == b else f"{where}: {a} against {b}"
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return None if numbers_close(float(a), float(b), 0.0, rtol) else f"{where}: {a} against {b}"
    if isinstance(a, str) and isinstance(b, str):
        # Paths name each side's own folder.
        if a.replace(str(old_dir), "<out>") == b.replace(str(new_dir), "<out>"):
            return None
        if os.path.isabs(a) and os.path.isabs(b):
            return None
    return None if a == b else f"{where}: {a!r} against {b!r}"


def compare_folders(old, new, rtol):
    """The first difference between two output folders, or None."""
    files_old = sorted(p.relative_to(old) for p in old.rglob("*") if p.is_file())
    files_new = sorted(p.relative_to(new) for p in new.rglob("*") if p.is_file())
    if files_old != files_new:
        only = set(files_old) ^ set(files_new)
        return f"different files: {sorted(str(p) for p in only)[:5]}"
    for rel in files_old:
        if rel.name == MANIFEST:  # what the folder holds, by inode: not a result
            continue
        if rel.suffix == ".csv":
            why = compare_csv(old / rel, new / rel, rtol)
        elif rel.suffix == ".json":
            why = compare_json(json.loads((old / rel).read_text()),
                               json.loads((new / rel).read_text()), rtol, "", old, new)
        else:
            continue
        if why:
            return f"{rel}: {why}"
    return None


def run(program, verb, scene, out):
    start = time.monotonic()
    proc = subprocess.run([program, verb, str(scene), "-o", str(out), "--log-level", "warn"],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          check=False)
    return proc.returncode, proc.stdout, time.monotonic() - start


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("old", help="the frichb program before the change")
    parser.add_argument("new", help="the frichb program after it")
    parser.add_argument("-o", "--output", default="out/compare",
                        help="folder for both programs' outputs (default out/compare)")
    parser.add_argument("--rtol", type=float, default=1e-10,
                        help="relative tolerance on numbers (default 1e-10)")
    parser.add_argument("--only", default="", help="inputs whose path contains this text")
    args = parser.parse_args()
    out = Path(args.output).resolve()
    differing = 0
    compared = 0
    for verb, scene in inputs():
        rel = scene.relative_to(ROOT)
        if args.only not in str(rel):
            continue
        name = str(rel.with_suffix("")).replace("/", "__")
        old_dir, new_dir = out / "old" / name, out / "new" / name
        code_old, text_old, t_old = run(args.old, verb, scene, old_dir)
        code_new, text_new, t_new = run(args.new, verb, scene, new_dir)
        compared += 1
        if code_old != code_new:
            why = f"exit code {code_old} against {code_new}\n{text_old}\n{text_new}"
        elif not old_dir.is_dir() and not new_dir.is_dir():
            why = None
        elif old_dir.is_dir() != new_dir.is_dir():
            why = "one program wrote no output folder"
        else:
            why = compare_folders(old_dir, new_dir, args.rtol)
        points = ""
        summary = new_dir / "summary.json"
        if summary.is_file():
            points = json.loads(summary.read_text()).get("points", "")
        status = "same" if why is None else "DIFFERS: " + why
        print(f"{verb:6} {str(rel):55} exit {code_new}  points {points!s:>5}  "
              f"{t_old:6.1f} s / {t_new:6.1f} s  {status}", flush=True)
        differing += why is not None
    print(f"{compared} inputs compared, {differing} differ")
    return 1 if differing else 0


if __name__ == "__main__":
    sys.exit(main())
