#!/usr/bin/env python3
"""Writes a normal preload varying linearly over a contact face of a model map.

A contact patch takes its pairs' preloads from a table `node,normal_load` (N, compressive) of
its face A's nodes (`patch.normal_load_file`), as a static pre-stress analysis would give them.
This script writes one where no such analysis exists: a pressure p(s) = p0 (1 + tilt s) over
the face, s running linearly from -1 to +1 along a global axis across the face, so that node i
carries N_i = total * A_i (1 + tilt s_i) / sum_j A_j (1 + tilt s_j) (A_i its tributary area):
the loads sum to `total` and the face's far edge is pressed (1 + tilt) / (1 - tilt) times
harder than its near edge.

    python3 configs/scale/make_face_preload.py configs/models/generated/test_case_p100 \\
        --face shroud_right --total 5.0 --tilt 0.8 --axis z

writes <model>/preload_<face>.csv (or the --output file name). Python 3 standard library only; exit status 1 with a
message on bad input.
"""
import argparse
import csv
import pathlib
import sys


def read_face(faces_csv: pathlib.Path, face: str) -> list[tuple[int, float]]:
    with faces_csv.open(newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["face"] == face]
    return [(int(r["node"]), float(r["area"])) for r in rows]


def read_coordinates(nodes_csv: pathlib.Path, wanted: set[int], axis: int) -> dict[int, float]:
    coordinate = {}
    with nodes_csv.open(newline="") as f:
        for r in csv.DictReader(f):
            node = int(r["node"])
            if node in wanted:
                coordinate[node] = float(r["xyz"[axis]])
    return coordinate


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model", type=pathlib.Path, help="folder holding mesh.yaml, nodes.csv, faces.csv")
    parser.add_argument("--face", default="shroud_right", help="face name in faces.csv")
    parser.add_argument("--total", type=float, default=5.0, help="total normal preload, N")
    parser.add_argument("--tilt", type=float, default=0.8, help="pressure slope, -1 < tilt < 1")
    parser.add_argument("--axis", choices="xyz", default="z", help="global axis across the face")
    parser.add_argument("--output", help="file name in the model folder "
                        "(default preload_<face>.csv)")
    args = parser.parse_args()
    if not -1 < args.tilt < 1 or not args.total >= 0:
        print("make_face_preload: need -1 < tilt < 1 and total >= 0", file=sys.stderr)
        return 1
    faces_csv, nodes_csv = args.model / "faces.csv", args.model / "nodes.csv"
    for path in (faces_csv, nodes_csv):
        if not path.is_file():
            print(f"make_face_preload: {path} not found (build the model first)", file=sys.stderr)
            return 1
    face = read_face(faces_csv, args.face)
    if not face:
        print(f"make_face_preload: no face '{args.face}' in {faces_csv}", file=sys.stderr)
        return 1
    coordinate = read_coordinates(nodes_csv, {n for n, _ in face}, "xyz".index(args.axis))
    low, high = min(coordinate.values()), max(coordinate.values())
    mid, half = 0.5 * (low + high), 0.5 * (high - low)
    weight = {n: a * (1 + args.tilt * ((coordinate[n] - mid) / half if half > 0 else 0.0))
              for n, a in face}
    total_weight = sum(weight.values())
    name = args.output or f"preload_{args.face}.csv"
    if pathlib.Path(name).name != name or not name.endswith(".csv"):
        print(f"make_face_preload: --output '{name}' must be a file name ending in .csv",
              file=sys.stderr)
        return 1
    out = args.model / name
    tmp = out.with_suffix(".csv.tmp")
    with tmp.open("w", newline="") as f:
        f.write(f"# normal preload over {args.face}: total {args.total} N, tilt {args.tilt} "
                f"along {args.axis} (configs/scale/make_face_preload.py)\n")
        f.write("node,normal_load\n")
        for n, _ in face:
            f.write(f"{n},{args.total * weight[n] / total_weight:.17g}\n")
        f.flush()
    tmp.replace(out)
    print(f"make_face_preload: wrote {out} ({len(face)} nodes, {args.total} N)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
