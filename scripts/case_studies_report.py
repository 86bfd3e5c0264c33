#!/usr/bin/env python3
"""Figures and key numbers of the thesis case studies (docs/case-studies.md) from the outputs
of configs/case_studies/run_case_studies.sh.

Usage: case_studies_report.py OUT_DIR FIGURE_DIR

OUT_DIR holds the runs (test_case_modes/, test_case_1/ (a study; the friction loops are its
five-harmonic run's), test_case_1_free/, test_case_2/ (a study), test_case_2_free/ and, when
the large case was run,
large_case_modes/ and large_case_3*/). Writes into FIGURE_DIR: PNG figures drawn by gnuplot (response curves on a
log scale, force harmonics, peak against preload) and case_studies.json with the numbers the
document quotes. Prints what it wrote. Standard library only; needs gnuplot for the figures.
"""
import csv
import json
import math
import os
import shutil
import subprocess
import sys


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], [r for r in rows[1:] if r]


def column(path, name):
    header, rows = read_csv(path)
    i = header.index(name)
    return [float(r[i]) for r in rows]


def study_runs(study_dir):
    """The study's index rows as dicts (values as text)."""
    header, rows = read_csv(os.path.join(study_dir, "study.csv"))
    return [dict(zip(header, r)) for r in rows]


def peak(summary_path, node):
    with open(summary_path) as f:
        p = json.load(f)["peak"][node]
    return {"amplitude_m": p["amplitude_m"], "frequency_hz": p["frequency_hz"]}


def gnuplot(script, figure_dir, name):
    path = os.path.join(figure_dir, name + ".gp")
    with open(path, "w") as f:
        f.write(script)
    if shutil.which("gnuplot") is None:
        print(f"  gnuplot missing: {path} not drawn")
        return
    subprocess.run(["gnuplot", name + ".gp"], cwd=figure_dir, check=True)
    print(f"  {os.path.join(figure_dir, name + '.png')}")


def header(name, title, xlabel, ylabel, logy=True):
    return (f"set terminal pngcairo size 900,560 noenhanced\nset output '{name}.png'\n"
            f"set datafile separator ','\nset grid\nset key outside right top\n"
            f"set title '{title}'\nset xlabel '{xlabel}'\nset ylabel '{ylabel}'\n"
            + ("set logscale y\nset format y '%.0e'\n" if logy else ""))


def short_label(path, value):
    """A swept key's value for a legend: gap in um, N0, H, f, mu."""
    key = path.split(".")[-1]
    if key == "gap":
        return f"gap {value * 1e6:g} um"
    names = {"normal_load": "N0", "max_harmonic": "H", "amplitude": "f", "mu": "mu"}
    units = {"normal_load": " N", "amplitude": " N"}
    return f"{names.get(key, key)} = {value:g}{units.get(key, '')}"


def curves_figure(figure_dir, name, title, curves, node, per_newton=None):
    """curves: [(label, response.csv path)] -> amplitude of `node` against frequency;
    per_newton: one force per curve (N) to plot the receptance amplitude / force instead."""
    plots = []
    for k, (label, path) in enumerate(curves):
        rel = os.path.relpath(path, figure_dir)
        y = (f"(column('{node}_amplitude_m') / {per_newton[k]!r})" if per_newton
             else f"'{node}_amplitude_m'")
        plots.append(f"'{rel}' using 'frequency_hz':{y} with lines lw 2 title '{label}'")
    ylabel = f"{node} amplitude / force [m/N]" if per_newton else f"{node} amplitude [m]"
    gnuplot(header(name, title, "frequency [Hz]", ylabel)
            + "plot " + ", \\\n     ".join(plots) + "\n", figure_dir, name)


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    out, figures = sys.argv[1], sys.argv[2]
    os.makedirs(figures, exist_ok=True)
    numbers = {}

    # Nodal-diameter maps of the test case and, when run, of the large case.
    for model in ("test_case", "large_case"):
        modes = os.path.join(out, f"{model}_modes")
        if not os.path.isdir(modes):
            continue
        _, rows = read_csv(os.path.join(modes, "families.csv"))
        numbers[f"{model}_families_hz"] = {r[0]: [round(float(x), 2) for x in r[1:6]]
                                           for r in rows}
        if os.path.exists(os.path.join(modes, "modes.png")):
            shutil.copy(os.path.join(modes, "modes.png"),
                        os.path.join(figures, f"{model}_nodal_diameter_map.png"))

    # Case 1: harmonics needed, amplitude reduction, force harmonics.
    case1 = os.path.join(out, "test_case_1")
    if os.path.exists(os.path.join(case1, "study.csv")):
        runs = study_runs(case1)
        curves, by_h = [], {}
        for r in runs:
            h = int(float(r["harmonic_balance.max_harmonic"]))
            run_dir = os.path.join(case1, "runs", r["run"])
            curves.append((f"H = {h}", os.path.join(run_dir, "response.csv")))
            by_h[h] = {"peak_amplitude_m": float(r["response_peak_amplitude_m"]),
                       "peak_frequency_hz": float(r["response_peak_frequency_hz"]),
                       "points": int(r["points"]), "wall_s": float(r["wall_s"]),
                       "termination": r["termination"]}
        finest = by_h[max(by_h)]["peak_amplitude_m"]
        for h in by_h:
            by_h[h]["peak_vs_finest"] = by_h[h]["peak_amplitude_m"] / finest - 1.0
        numbers["case1_harmonics"] = by_h
        free = os.path.join(out, "test_case_1_free")
        if os.path.isdir(free):
            curves.append(("no contact", os.path.join(free, "response.csv")))
            p_free = peak(os.path.join(free, "summary.json"), "response")
            numbers["case1_free_peak"] = p_free
            h5 = by_h.get(5, by_h[max(by_h)])
            numbers["case1_reduction"] = p_free["amplitude_m"] / h5["peak_amplitude_m"]
        curves_figure(figures, "case1_response_harmonics",
                      "Case 1: test case, EO3, N0 = 5 N, f = 2 N", curves, "response")
        # The friction loops of the five-harmonic run (every run of the study writes them).
        h5_run = next((r["run"] for r in runs
                       if int(float(r["harmonic_balance.max_harmonic"])) == 5), None)
        loops_run = os.path.join(case1, "runs", h5_run) if h5_run else None
    else:
        loops_run = None
    if loops_run and os.path.isdir(os.path.join(loops_run, "loops")):
        with open(os.path.join(loops_run, "summary.json")) as f:
            entries = json.load(f)["friction_loops"]
        plots, harmonics = [], {}
        for e in entries:
            rel = os.path.relpath(os.path.join(loops_run, e["harmonics_file"]), figures)
            label = f"{e['frequency']:g} Hz, crossing {e['crossing']}"
            harmonics[label] = {"force_harmonic_amplitudes_N": e["force_harmonic_amplitudes_N"],
                                "dissipated_energy_per_cycle_J":
                                    e["dissipated_energy_per_cycle_J"]}
            plots.append(f"'{rel}' using ($1 + {0.2 * len(plots) - 0.1}):'f_t1_amplitude_N' "
                         f"with impulses lw 6 title 'tangential, {label}'")
        numbers["case1_force_harmonics"] = harmonics
        gnuplot(header("case1_force_harmonics", "Case 1: harmonics of the shroud friction force",
                       "harmonic", "amplitude [N]", logy=False)
                + "set xtics 1\nset xrange [-0.5:10.5]\nplot " + ", \\\n     ".join(plots) + "\n",
                figures, "case1_force_harmonics")

    # Case 2: gap to preload.
    case2 = os.path.join(out, "test_case_2")
    if os.path.exists(os.path.join(case2, "study.csv")):
        runs = study_runs(case2)
        node = "shroud_right"
        curves, table = [], []
        for r in runs:
            gap = float(r["contacts.shroud.params.gap"])
            load = float(r["contacts.shroud.params.normal_load"])
            label = f"gap {gap * 1e6:g} um" if gap > 0 else f"N0 = {load:g} N"
            curves.append((label, os.path.join(case2, "runs", r["run"], "response.csv")))
            table.append({"gap_m": gap, "normal_load_N": load, "termination": r["termination"],
                          "points": int(r["points"]),
                          "peak_amplitude_m": float(r[f"{node}_peak_amplitude_m"]),
                          "peak_frequency_hz": float(r[f"{node}_peak_frequency_hz"]),
                          "wall_s": float(r["wall_s"])})
        free = os.path.join(out, "test_case_2_free")
        if os.path.isdir(free):
            curves.append(("no contact", os.path.join(free, "response.csv")))
            numbers["case2_free_peak"] = peak(os.path.join(free, "summary.json"), node)
        numbers["case2_runs"] = table
        loaded = [t for t in table if t["gap_m"] == 0 and t["normal_load_N"] > 0]
        if loaded:
            best = min(loaded, key=lambda t: t["peak_amplitude_m"])
            numbers["case2_optimum"] = best
        curves_figure(figures, "case2_gap_to_preload",
                      "Case 2: test case, EO1, 1T, gap to preload", curves, node)
        rel = os.path.relpath(os.path.join(case2, "study.csv"), figures)
        gnuplot(header("case2_peak_against_preload", "Case 2: peak against the preload",
                       "normal preload N0 [N]", f"{node} peak amplitude [m]")
                + "set logscale x\n"
                + f"plot '{rel}' using (column(3) > 0 ? column(3) : 1/0):"
                  f"'{node}_peak_amplitude_m' with linespoints pt 7 lw 2 title 'preloaded'\n",
                figures, "case2_peak_against_preload")

    # Case 3 (large case), when run.
    for name in ("large_case_3", "large_case_3_excitation_levels", "large_case_3_friction"):
        study = os.path.join(out, name)
        if not os.path.exists(os.path.join(study, "study.csv")):
            continue
        runs = study_runs(study)
        swept = [k for k in runs[0] if "." in k]
        numbers[name] = [{**{k: float(r[k]) for k in swept}, "termination": r["termination"],
                          "points": int(r["points"]),
                          "peak_amplitude_m": float(r["response_peak_amplitude_m"]),
                          "peak_frequency_hz": float(r["response_peak_frequency_hz"]),
                          "wall_s": float(r["wall_s"])} for r in runs]
        curves = []
        for r in runs:
            shown = [k for k in swept if not k.startswith("excitation.") or k.startswith(
                "excitation.0.")]
            label = ", ".join(short_label(k, float(r[k])) for k in shown)
            curves.append((label, os.path.join(study, "runs", r["run"], "response.csv")))
        forces = ([float(r["excitation.0.amplitude"]) for r in runs]
                  if "excitation.0.amplitude" in swept else None)
        curves_figure(figures, name, name.replace("_", " "), curves, "response", forces)

    with open(os.path.join(figures, "case_studies.json"), "w") as f:
        json.dump(numbers, f, indent=2, sort_keys=True)
    print(f"  {os.path.join(figures, 'case_studies.json')}")


if __name__ == "__main__":
    main()
