"""The damper normal load that gives the lowest resonance peak of the blade, found by
scipy.optimize over frichb.run, against the grid of the shipped study.

The scene is configs/studies/damper_normal_load_sweep.yaml: a blade with a platform damper whose
friction contact holds a normal load N0. A light load lets the damper slide with little force, a
heavy one locks it; the peak is lowest in between. The shipped study samples N0 on 13
log-spaced values; here a bounded scalar minimisation (Brent's method on log10 N0) looks for the
optimum between them, and the result is checked against the grid: its peak must be no higher
than the grid's lowest, and its N0 must lie between the grid's neighbours of that lowest.

    python3 docs/examples/preload_optimisation.py [--output DIR]

Writes DIR/preload_optimisation.png (the grid and the optimiser's evaluations) and
DIR/preload_optimisation.json, and exits with status 1 when the check fails.
"""
import argparse
import json
import math
import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt  # noqa: E402
from scipy.optimize import minimize_scalar  # noqa: E402

import frichb  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "configs" / "studies" / "damper_normal_load_sweep.yaml"
LOAD = "contacts.platform_friction.params.normal_load"
NODE = "blade"


def blade_peak_of(peaks):
    """The blade's peak amplitude (m) among a run's peaks (a dict per response node)."""
    return next(p["amplitude_m"] for p in peaks if p["node"] == NODE)


def blade_peak(result):
    """The blade's peak amplitude (m) of a run that reached the end of its sweep."""
    if result.status != 0:
        raise RuntimeError(f"the run ended early: {result.termination}: {result.message}")
    return blade_peak_of(result.peaks)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--output", type=Path, default=Path("out/preload_optimisation"),
                        help="folder for the plot and the JSON summary")
    args = parser.parse_args()
    args.output.mkdir(parents=True, exist_ok=True)

    # The shipped study's grid, as `frichb study` computes it.
    with tempfile.TemporaryDirectory() as folder:
        study = frichb.study(SCENE, Path(folder) / "study")
    failed = [run["id"] for run in study.runs if run["exit_code"] != 0]
    if study.status != 0 or failed:
        print(f"the study did not complete: status {study.status}, failed runs {failed}")
        return 1
    grid = sorted((run["values"][0], blade_peak_of(run["peaks"])) for run in study.runs)
    best = min(range(len(grid)), key=lambda i: grid[i][1])
    print(f"grid: lowest peak {grid[best][1] * 1e6:.3f} um at N0 = {grid[best][0]:.4g} N "
          f"({len(grid)} runs)")

    # Brent's method on log10 N0 over the grid's range; every evaluation is one frichb.run.
    evaluations = []

    def objective(log_load):
        load = 10.0 ** log_load
        peak = blade_peak(frichb.run(SCENE, set={LOAD: load}, plots=False))
        evaluations.append((load, peak))
        return peak

    lo, hi = math.log10(grid[0][0]), math.log10(grid[-1][0])
    found = minimize_scalar(objective, bounds=(lo, hi), method="bounded",
                            options={"xatol": 1e-3})
    load, peak = 10.0 ** found.x, found.fun
    print(f"optimiser: lowest peak {peak * 1e6:.3f} um at N0 = {load:.4g} N "
          f"({len(evaluations)} runs)")

    below = grid[max(best - 1, 0)][0]
    above = grid[min(best + 1, len(grid) - 1)][0]
    checks = {
        "peak no higher than the grid's lowest": bool(peak <= grid[best][1]),
        f"N0 between the grid's neighbours {below:.4g} and {above:.4g} N": bool(below <= load <= above),
    }

    fig, ax = plt.subplots(figsize=(7, 4.5), layout="constrained")
    ax.loglog([g[0] for g in grid], [g[1] * 1e6 for g in grid], "o-", color="#0072B2",
              label="shipped study grid")
    ax.loglog([e[0] for e in evaluations], [e[1] * 1e6 for e in evaluations], "x",
              color="#D55E00", label="optimiser evaluations")
    ax.loglog([load], [peak * 1e6], "*", ms=14, color="#009E73",
              label=f"optimum: N0 = {load:.3g} N, {peak * 1e6:.2f} µm")
    ax.set_xlabel("damper normal load N0 [N]")
    ax.set_ylabel("blade peak amplitude [µm]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0))
    fig.savefig(args.output / "preload_optimisation.png", dpi=120)

    summary = {"grid": [{"normal_load_n": g[0], "peak_m": g[1]} for g in grid],
               "evaluations": [{"normal_load_n": e[0], "peak_m": e[1]} for e in evaluations],
               "optimum": {"normal_load_n": load, "peak_m": peak},
               "checks": checks}
    (args.output / "preload_optimisation.json").write_text(json.dumps(summary, indent=2) + "\n")
    for name, ok in checks.items():
        print(("ok:     " if ok else "FAILED: ") + name)
    return 0 if all(checks.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
