#!/usr/bin/env python3
"""How many contact node pairs a shroud needs: the tables, the Richardson estimates and the
figures of docs/case-studies.md ("Contact-mesh convergence") from the two studies of
configs/case_studies/contact_mesh_case1.yaml and contact_mesh_case2.yaml.

Usage: contact_mesh_report.py OUT_DIR MODELS_DIR FIGURE_DIR

OUT_DIR holds the studies contact_mesh_case1/, contact_mesh_case2/ and contact_mesh_case2_tilted/
and, when run, the same meshes without contact (contact_mesh_case1_free/, contact_mesh_case2_free/:
the structure's own change with the face mesh) (frichb study outputs,
swept over variables.pairs); MODELS_DIR the models they ran on (test_case_p<N>/, whose
nodes.csv gives each mesh's sector DOFs). Writes into FIGURE_DIR contact_mesh.json (the
numbers of the page's tables), contact_mesh_peaks.png (the peak's distance to the reference against
the pair count), contact_mesh_frequencies.png (free, stuck and peak frequencies against
the pair count) and, for each study's finest mesh, a plot of its face coloured by the share of
the period each pair sticks (from the run's contact_states tables); prints
the tables in Markdown. Standard library only; needs gnuplot for the figures.

The face mesh spacing h of N pairs on a face is proportional to N^(-1/2). With the peak P(h) =
P_inf + C h^p, three meshes give the observed order p and the limit P_inf: from 4, 16 and 64
pairs (h halving each time) p = log2((P4 - P16) / (P16 - P64)), P_inf = P64 + (P64 - P16) /
(2^p - 1); 16, 64 and 128 pairs (unequal ratios) are the cross-check, p found by bisection.
Where the differences change sign the order is not defined: the finest mesh is then the
reference. "Enough pairs for 1 %" is the coarsest mesh from which every finer one is within 1 %
of the reference (of the finest mesh, when that is the reference: then only the coarser meshes
say anything). A run whose peak was not refined (summary.json peak.refined false) is reported.
"""
import csv
import glob
import json
import os
import shutil
import sys

from case_studies_report import gnuplot

CASES = {
    "case1": {"study": "contact_mesh_case1", "free": "contact_mesh_case1_free",
              "harmonic_index": 3, "node": "response",
              "title": "case 1 (EO3, 1D friction, N0 = 5 N)"},
    "case2": {"study": "contact_mesh_case2", "free": "contact_mesh_case2_free",
              "harmonic_index": 1, "node": "shroud_corner",
              "title": "case 2 (EO1, 3D coupled friction, N0 = 1 N)"},
    "case2_tilted": {"study": "contact_mesh_case2_tilted", "free": "contact_mesh_case2_free",
                     "harmonic_index": 1,
                     "node": "shroud_corner",
                     "title": "case 2, N0 = 1 N varying 9:1 over the face"},
}


def read_rows(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return [dict(zip(rows[0], r)) for r in rows[1:] if r]


def sector_dofs(models, pairs):
    nodes = os.path.join(models, f"test_case_p{pairs}", "nodes.csv")
    if not os.path.exists(nodes):
        return None
    with open(nodes) as f:
        rows = [line for line in f if line.strip() and not line.startswith("#")]
    return 3 * (len(rows) - 1)


def resonance(summary, system, harmonic_index, near_hz):
    """The first-harmonic resonance of `system` (free|stuck) of the harmonic index nearest
    near_hz (Hz), or None."""
    bands = [b for b in summary["resonance_bands"] if b["system"] == system
             and b["harmonic"] == 1 and b["harmonic_index"] == harmonic_index]
    if not bands:
        return None
    return min(bands, key=lambda b: abs(b["centre"] - near_hz))["centre"]


def free_peaks(free_dir, node):
    """{pairs: peak amplitude (m)} of the contact-free runs, or {} without them."""
    if not os.path.exists(os.path.join(free_dir, "study.csv")):
        return {}
    peaks = {}
    for r in read_rows(os.path.join(free_dir, "study.csv")):
        with open(os.path.join(free_dir, "runs", r["run"], "summary.json")) as f:
            peaks[int(float(r["variables.pairs"]))] = json.load(f)["peak"][node]["amplitude_m"]
    return peaks


def case_rows(study_dir, free_dir, models, harmonic_index, node):
    free = free_peaks(free_dir, node)
    rows = []
    for r in read_rows(os.path.join(study_dir, "study.csv")):
        with open(os.path.join(study_dir, "runs", r["run"], "summary.json")) as f:
            s = json.load(f)
        pairs = int(float(r["variables.pairs"]))
        peak = s["peak"][node]
        if not peak.get("refined", False):
            print(f"  warning: {study_dir} run {r['run']}: the peak of {node} was not refined "
                  "(the largest sampled point)")
        rows.append({
            "pairs": pairs, "sector_dofs": sector_dofs(models, pairs),
            "unknowns": s["unknowns"], "points": s["points"],
            "peak_amplitude_m": peak["amplitude_m"], "peak_frequency_hz": peak["frequency_hz"],
            "free_hz": resonance(s, "free", harmonic_index, peak["frequency_hz"]),
            "stuck_hz": resonance(s, "stuck", harmonic_index, peak["frequency_hz"]),
            "free_peak_m": free.get(pairs),
            "wall_s": s["wall_time_s"]["total_s"], "termination": s["termination"]["reason"],
            "run": r["run"]})
    return sorted(rows, key=lambda x: x["pairs"])


def order_and_limit(meshes):
    """[(pairs, peak)] x3, coarse to fine -> (p, limit) or (None, None)."""
    (n1, p1), (n2, p2), (n3, p3) = meshes
    h1, h2, h3 = (n ** -0.5 for n in (n1, n2, n3))
    d12, d23 = p1 - p2, p2 - p3
    if d12 == 0 or d23 == 0 or (d12 > 0) != (d23 > 0):
        return None, None
    target = d12 / d23

    def ratio(p):  # (h1^p - h2^p) / (h2^p - h3^p), increasing in p
        return (h1 ** p - h2 ** p) / (h2 ** p - h3 ** p)

    lo, hi = 1e-3, 20.0
    if not ratio(lo) <= target <= ratio(hi):
        return None, None
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        (lo, hi) = (mid, hi) if ratio(mid) < target else (lo, mid)
    p = 0.5 * (lo + hi)
    c = d23 / (h2 ** p - h3 ** p)
    return p, p3 - c * h3 ** p


def fmt(x, digits=4):
    return "-" if x is None else f"{x:.{digits}g}"


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    out, models, figures = sys.argv[1:]
    os.makedirs(figures, exist_ok=True)
    numbers, data_files = {}, {}
    for key, case in CASES.items():
        study_dir = os.path.join(out, case["study"])
        if not os.path.exists(os.path.join(study_dir, "study.csv")):
            print(f"  {study_dir}: no study, skipped")
            continue
        rows = case_rows(study_dir, os.path.join(out, case["free"]), models,
                         case["harmonic_index"], case["node"])
        by_n = {r["pairs"]: r["peak_amplitude_m"] for r in rows}
        result = {"rows": rows}
        for label, ladder in (("richardson_4_16_64", (4, 16, 64)),
                              ("richardson_16_64_128", (16, 64, 128))):
            if all(n in by_n for n in ladder):
                p, limit = order_and_limit([(n, by_n[n]) for n in ladder])
                result[label] = {"order": p, "limit_m": limit}
        # The reference: the Richardson limit where the meshes converge monotonically, else
        # the finest mesh (the differences then change sign: no asymptotic order to use).
        limit = result.get("richardson_4_16_64", {}).get("limit_m")
        result["reference"] = "richardson_4_16_64" if limit is not None else "finest mesh"
        if limit is None:
            limit = rows[-1]["peak_amplitude_m"]
        result["reference_m"] = limit
        for r in rows:
            r["peak_vs_reference"] = r["peak_amplitude_m"] / limit - 1
        enough = [r["pairs"] for r in rows
                  if all(abs(q["peak_vs_reference"]) < 0.01 for q in rows
                         if q["pairs"] >= r["pairs"])]
        result["pairs_for_1_percent"] = enough[0] if enough else None
        # The contact's own effect: each peak over its mesh's contact-free peak (the structure's
        # change with the face mesh divided out), against the finest mesh's.
        if all(r["free_peak_m"] for r in rows):
            finest = rows[-1]["peak_amplitude_m"] / rows[-1]["free_peak_m"]
            for r in rows:
                r["reduction_vs_finest"] = (r["peak_amplitude_m"] / r["free_peak_m"]) / finest - 1
        spread = [r["peak_amplitude_m"] for r in rows]
        result["peak_spread"] = (max(spread) - min(spread)) / limit
        numbers[key] = result
        data = os.path.join(figures, f"contact_mesh_{key}.csv")
        with open(data, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["pairs", "peak_amplitude_m", "peak_frequency_hz", "free_hz", "stuck_hz",
                        "abs_peak_vs_reference"])
            for r in rows:
                w.writerow([r["pairs"], r["peak_amplitude_m"], r["peak_frequency_hz"],
                            r["free_hz"], r["stuck_hz"],
                            abs(r["peak_vs_reference"])
                            if r is not rows[-1] or result["reference"] != "finest mesh" else ""])
        data_files[key] = os.path.basename(data)

        print(f"\n{case['title']}\n")
        print("| pairs | sector DOFs | unknowns | free | stuck | free peak | peak | "
              "peak frequency | peak vs reference | peak / free peak vs finest | points | "
              "wall time |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|")
        for r in rows:
            vs = f"{100 * r['peak_vs_reference']:+.2f} %"
            if "reduction_vs_finest" in r:
                vs += f" | {100 * r['reduction_vs_finest']:+.2f} %"
            else:
                vs += " | -"
            print(f"| {r['pairs']} | {r['sector_dofs']} | {r['unknowns']} | "
                  f"{fmt(r['free_hz'], 6)} Hz | {fmt(r['stuck_hz'], 6)} Hz | "
                  f"{fmt(r['free_peak_m'], 5)} m | "
                  f"{r['peak_amplitude_m']:.4e} m | {r['peak_frequency_hz']:.3f} Hz | {vs} | "
                  f"{r['points']} | {r['wall_s']:.0f} s |")
        for label in ("richardson_4_16_64", "richardson_16_64_128"):
            if label in result:
                e = result[label]
                print(f"{label}: order {fmt(e['order'], 3)}, limit {fmt(e['limit_m'], 6)} m")
        print(f"reference: {result['reference']} ({result['reference_m']:.6g} m); spread "
              f"{100 * result['peak_spread']:.2f} %; pairs for 1 %: "
              f"{result['pairs_for_1_percent']}")

        # Where the finest mesh's face sticks (the run's contact_states tables; a study's runs
        # draw no plots of their own).
        finest = rows[-1]
        for table in sorted(glob.glob(os.path.join(study_dir, "runs", finest["run"],
                                                   "contact_states", "*.csv"))):
            name = f"contact_mesh_{key}_p{finest['pairs']}_" + \
                os.path.basename(table)[:-4].replace(".", "_")
            shutil.copy(table, os.path.join(figures, name + ".csv"))
            gnuplot("set terminal pngcairo size 900,420 noenhanced\n"
                    f"set output '{name}.png'\nset datafile separator ','\n"
                    "set grid\nset size ratio -1\nset key off\n"
                    f"set title '{case['title']}: share of the period stuck, "
                    f"{finest['pairs']} pairs, {os.path.basename(table)[:-4]}'\n"
                    "set xlabel 'along tangent1 (axial) from the face centroid [mm]'\n"
                    "set ylabel 'along tangent2 [mm]'\nset cbrange [0:1]\n"
                    "set cblabel 'share of the period stuck'\n"
                    "set palette defined (0 'red', 0.5 'yellow', 1 'blue')\n"
                    f"plot '{name}.csv' using (1000*column('face_s1_m')):"
                    "(1000*column('face_s2_m')):'stuck' with points pt 7 ps 2 palette\n",
                    figures, name)

    if not numbers:
        sys.exit("contact_mesh_report: no study found in " + out)
    with open(os.path.join(figures, "contact_mesh.json"), "w") as f:
        json.dump(numbers, f, indent=2, sort_keys=True)
    print(f"  {os.path.join(figures, 'contact_mesh.json')}")

    base = ("set terminal pngcairo size 900,560 noenhanced\nset datafile separator ','\n"
            "set grid\nset key below\nset logscale x 2\n"
            "set xlabel 'contact node pairs per face'\n")
    plots = [f"'{f}' using 'pairs':'abs_peak_vs_reference' with linespoints lw 2 pt 7 "
             f"title '{CASES[k]['title']}'" for k, f in data_files.items()]
    if plots:
        gnuplot(base + "set output 'contact_mesh_peaks.png'\nset logscale y\n"
                "set format y '%.0e'\n"
                "set title 'Peak amplitude against the reference (limit or finest mesh)'\n"
                "set ylabel '|peak / reference - 1|'\n"
                "plot " + ", \\\n     ".join(plots)
                + ", 0.01 with lines dt 2 lc rgb 'black' title '1 %'\n",
                figures, "contact_mesh_peaks")
    # Two panels: 1F (case 1) and 1T (case 2; the tilted preload has case 2's free and stuck
    # structure).
    panels = []
    for keys, mode in ((("case1",), "1F, case 1"), (("case2", "case2_tilted"), "1T, case 2")):
        plots = []
        for k in keys:
            if k not in data_files:
                continue
            f = data_files[k]
            if k == keys[0]:
                plots += [f"'{f}' using 'pairs':'free_hz' with linespoints pt 6 title 'free'",
                          f"'{f}' using 'pairs':'stuck_hz' with linespoints pt 4 title 'stuck'"]
            label = "peak, tilted preload" if k.endswith("tilted") else "peak"
            plots.append(f"'{f}' using 'pairs':'peak_frequency_hz' with linespoints lw 2 pt 7 "
                         f"title '{label}'")
        if plots:
            panels.append(f"set title '{mode}'\nplot " + ", \\\n     ".join(plots) + "\n")
    gnuplot("set terminal pngcairo size 1000,480 noenhanced\n"
            "set output 'contact_mesh_frequencies.png'\nset datafile separator ','\n"
            "set grid\nset key below\nset logscale x 2\n"
            "set xlabel 'contact node pairs per face'\nset ylabel 'frequency [Hz]'\n"
            f"set multiplot layout 1,{len(panels)}\n" + "".join(panels) + "unset multiplot\n",
            figures, "contact_mesh_frequencies")


if __name__ == "__main__":
    main()
