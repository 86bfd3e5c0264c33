#!/usr/bin/env python3
"""The peak of the FE test-case blade traced in the shroud's normal load (frichb peaks).

Builds the test_case model (configs/models/shrouded_blade) into WORK, points a copy of
configs/case_studies/test_case_2_eo1_gap_to_preload.yaml at it and traces the peak of
shroud_right at gap 0 from a normal load of 0.05 N (the shroud slips freely: the free blade's
peak) to 200 N (stuck) on a logarithmic axis. Checks, against full response curves run with
`frichb run` at the same loads (the same equations and measure; their solved peak):
  - the tracking reaches 200 N with its optimum solved inside the range;
  - the traced peaks equal the full curves' at the first and last points, the three points
    around the lowest and one point between, to 1e-5 in amplitude and 1e-6 in frequency;
  - the solved optimum equals the full curve's peak at its load (1e-5, 1e-6), and the full
    curves at 1 % less and 1 % more load peak higher (its location to 1e-2).

A linear axis from 0 N would make the range's width (200 N) the load's scale, and its steps
cross the 0.3-1 N where the peak falls ten-fold and two close maxima exchange: the log axis
resolves them. About 2-3 minutes on 2 cores (label `long`, outside the default test run).

Usage: check_fe_blade_peaks.py SOURCE_DIR FRICHB WORK_DIR   (exit code 1 on a failed check)
"""
import csv
import json
import pathlib
import sys

import fe_test_case

LOAD = "contacts.shroud.params.normal_load"
NODE = "shroud_right"


def fail(message):
    sys.exit(f"check_fe_blade_peaks: {message}")


def run(command):
    fe_test_case.run_or_fail(command, fail)


def full_peak(frichb, scene, work, load):
    """The solved peak of NODE of a full response curve at `load` N: (amplitude m, Hz)."""
    out = work / f"run_{load!r}"
    run([frichb, "--log-level", "warn", "run", scene, "--set", "contacts.shroud.params.gap=0",
         "--set", f"{LOAD}={load!r}", "--set", "output.plots=false", "-o", out])
    peak = json.loads((out / "summary.json").read_text())["peak"][NODE]
    if not peak.get("refined"):
        fail(f"the full curve at {load} N has no solved peak")
    return peak["amplitude_m"], peak["frequency_hz"]


def expect_equal(what, traced, full):
    (a, f), (fa, ff) = traced, full
    if abs(a / fa - 1) > 1e-5 or abs(f / ff - 1) > 1e-6:
        fail(f"{what}: traced {a:.10g} m at {f:.10g} Hz, full curve {fa:.10g} m at {ff:.10g} Hz")
    return max(abs(a / fa - 1), 0.0), abs(f / ff - 1)


def main():
    source, frichb, work = (pathlib.Path(a).resolve() for a in sys.argv[1:4])
    scene = fe_test_case.prepare(source, work, "test_case_2_eo1_gap_to_preload.yaml", fail)

    out = work / "peaks"
    run([frichb, "--log-level", "warn", "peaks", scene, "--vary", f"{LOAD}=0.05:200",
         "--set", "contacts.shroud.params.gap=0", "--set", "output.plots=false", "--node", NODE,
         "-o", out])
    summary = json.loads((out / "summary.json").read_text())
    rows = list(csv.DictReader((out / "peaks.csv").open()))
    termination = summary["tracking"]["termination"]
    if termination != "reached_end" or abs(float(rows[-1][LOAD]) / 200 - 1) > 1e-12:
        fail(f"the tracking ended with {termination} at {rows[-1][LOAD]} N")
    optimum = summary["optimum"]
    if not optimum.get("solved") or optimum.get("at_range_end"):
        fail(f"the optimum is not solved inside the range: {optimum}")
    lowest = optimum["lowest_point"]
    picks = sorted({0, lowest - 1, lowest, lowest + 1, (lowest + len(rows)) // 2, len(rows) - 1})
    worst = [0.0, 0.0]
    for i in picks:
        load = float(rows[i][LOAD])
        traced = (float(rows[i]["peak_amplitude_m"]), float(rows[i]["peak_frequency_hz"]))
        error = expect_equal(f"point {i} at {load} N", traced,
                             full_peak(frichb, scene, work, load))
        worst = [max(worst[0], error[0]), max(worst[1], error[1])]
    solved = (optimum["amplitude_m"], optimum["frequency_hz"])
    error = expect_equal(f"the optimum at {optimum['parameter']} N", solved,
                         full_peak(frichb, scene, work, optimum["parameter"]))
    for factor in (0.99, 1.01):
        amplitude, _ = full_peak(frichb, scene, work, optimum["parameter"] * factor)
        if not amplitude > optimum["amplitude_m"]:
            fail(f"the full curve at {factor} x the optimum's load peaks at {amplitude} m, not "
                 f"above the optimum's {optimum['amplitude_m']} m")
    print(f"check_fe_blade_peaks: {len(rows)} traced peaks, {len(summary['jumps'])} jumps; at "
          f"{len(picks)} loads they equal the full curves' to {worst[0]:.1e} in amplitude and "
          f"{worst[1]:.1e} in frequency; optimum {optimum['amplitude_m']:.7g} m at "
          f"{optimum['parameter']:.6g} N, {optimum['frequency_hz']:.6g} Hz (full curve "
          f"{error[0]:.1e}, {error[1]:.1e}); tracking {summary['wall_time_s']['total_s']:.1f} s")


if __name__ == "__main__":
    main()
