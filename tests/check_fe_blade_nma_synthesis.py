#!/usr/bin/env python3
"""Forced responses of the FE test-case blade synthesised from its first nonlinear mode.

Builds the test_case model (configs/models/shrouded_blade) into WORK, points a copy of
configs/case_studies/test_case_nonlinear_modes.yaml at it (the shroud's coupled law with its
normal stiffness, preload 5 N) and runs `frichb nma --synthesise LEVELS --against-run` over a
window about the mode (110 to 130 Hz), so that each level's full run traces the one resonance.
The levels multiply the scene's 2 N excitation: 1 and 7 keep the shroud stuck; 10, 15, 30 and
50 give the synthesised peaks friction damping of about 0.4, 1, 2.8 and 4.7 times the
structure's. Checks:
  - stuck: the synthesis (the mode with the residual flexibility's share, the other linear
    modes with the contact at rest as residual terms) equals the full run's peak to 1e-4 in
    amplitude and frequency, and the harmonic-balance solve at the synthesised frequency to
    1e-4;
  - friction damping up to 2 times the structure's: the full run's peak within 1 % in
    amplitude and 0.2 % in frequency, and the solve at the synthesised frequency within 1 %;
  - every level: its peak synthesised and its check converged; the errors beyond 2 times are
    printed (single-mode theory degrades as the forced motion's shape departs from the free
    mode's).
Prints the cost: the backbone, the syntheses and the checks against the full runs.
About 20 s with the model's build.

Usage: check_fe_blade_nma_synthesis.py SOURCE_DIR FRICHB WORK_DIR   (exit code 1 on a failed
check)
"""
import csv
import json
import pathlib
import sys

import fe_test_case

LEVELS = [1, 7, 10, 15, 30, 50]


def fail(message):
    sys.exit(f"check_fe_blade_nma_synthesis: {message}")


def main():
    source, frichb, work = (pathlib.Path(a).resolve() for a in sys.argv[1:4])
    scene = fe_test_case.prepare(source, work, "test_case_nonlinear_modes.yaml", fail)
    out = work / "synthesis"
    fe_test_case.run_or_fail(
        [frichb, "--log-level", "warn", "nma", scene, "--mode", "1",
         "--synthesise", ",".join(str(level) for level in LEVELS), "--against-run",
         "--set", "continuation.frequency.from=110", "--set", "continuation.frequency.to=130",
         "--set", "output.plots=false", "-o", out], fail)
    summary = json.loads((out / "summary.json").read_text())
    synthesis = summary["synthesis"]
    # The stuck mode's damping ratio: the backbone's smallest amplitude.
    with (out / "nma.csv").open() as backbone:
        structural = float(next(csv.DictReader(backbone))["damping_ratio"])
    rows = []
    for level in synthesis["levels"]:
        if not level["found"]:
            fail(f"excitation x {level['excitation_scale']}: no peak ({level['message']})")
        peak, check, full = level["peak"], level["check"], level["full_run"]
        if not check["converged"]:
            fail(f"excitation x {level['excitation_scale']}: the check did not converge "
                 f"({check['message']})")
        if not full["found"]:
            fail(f"excitation x {level['excitation_scale']}: the full run's peak was not solved "
                 f"({full['message']})")
        friction = peak["damping_ratio"] / structural - 1
        rows.append((level["excitation_scale"], friction, peak, check, full))
        print(f"excitation x {level['excitation_scale']:g}: friction damping {friction:.2f} x the "
              f"structure's (damping ratio {peak['damping_ratio']:.5f}); synthesised "
              f"{peak['node_amplitude_m']:.6e} m at {peak['frequency_hz']:.4f} Hz, full run "
              f"{full['node_amplitude_m']:.6e} m at {full['frequency_hz']:.4f} Hz "
              f"({full['amplitude_error']:+.1e}, {full['frequency_error']:+.1e}; the mode alone "
              f"{full['amplitude_error_mode']:+.1e}); the solve at the synthesised frequency "
              f"{check['error']:+.1e} ({check['newton_iterations']} Newton iterations); full "
              f"run {full['seconds']:.2f} s, check {check['seconds'] * 1e3:.1f} ms")
    for scale, friction, peak, check, full in rows:
        if abs(friction) < 1e-9:
            if (abs(full["amplitude_error"]) > 1e-4 or abs(full["frequency_error"]) > 1e-4
                    or abs(check["error"]) > 1e-4):
                fail(f"excitation x {scale:g} (stuck): synthesis off by "
                     f"{full['amplitude_error']:.1e} / {full['frequency_error']:.1e} against the "
                     f"full run, {check['error']:.1e} against the solve")
        elif friction <= 2:
            if (abs(full["amplitude_error"]) > 1e-2 or abs(full["frequency_error"]) > 2e-3
                    or abs(check["error"]) > 1e-2):
                fail(f"excitation x {scale:g} (friction damping {friction:.2f} x): synthesis off "
                     f"by {full['amplitude_error']:.1e} / {full['frequency_error']:.1e} against "
                     f"the full run, {check['error']:.1e} against the solve")
    if any(abs(r[1]) >= 1e-9 for r in rows[:2]) or not any(0.5 < r[1] <= 2 for r in rows):
        fail("the levels no longer give stuck peaks at 1 and 7 and one with about 1 x friction "
             "damping")
    # The check starts from the backbone turned into the excitation's phase: where the contact
    # slips (a nonlinear solve) a start in the wrong phase would take many more iterations.
    for scale, friction, peak, check, full in rows:
        if friction > 0 and check["newton_iterations"] > 8:
            fail(f"excitation x {scale:g}: the check took {check['newton_iterations']} Newton "
                 "iterations from the synthesised motion")
    full_seconds = synthesis["full_run_seconds"]
    ours = synthesis["backbone_seconds"] + synthesis["synthesis_seconds"] + synthesis["check_seconds"]
    print(f"check_fe_blade_nma_synthesis: {len(rows)} levels; backbone "
          f"{synthesis['backbone_seconds']:.2f} s, syntheses {synthesis['synthesis_seconds'] * 1e3:.1f} "
          f"ms, checks {synthesis['check_seconds'] * 1e3:.0f} ms; full runs {full_seconds:.2f} s "
          f"({full_seconds / ours:.1f} x the backbone, syntheses and checks together)")


if __name__ == "__main__":
    main()
