#!/usr/bin/env python3
"""The first nonlinear mode of the FE test-case blade (frichb nma) at its two linear limits.

Builds the test_case model (configs/models/shrouded_blade) into WORK, points a copy of
configs/case_studies/test_case_nonlinear_modes.yaml at it, sets the shroud's normal stiffness
kn to 0 (a constant normal load: the contact's tangent at rest is kt in its plane alone) and
traces mode 1's backbone from 1 nm to 1 mm of shroud motion. Checks, against the linear
resonances `frichb run` lists in summary.json's resonance_bands (the eigenvalues of the modal
basis stiffened by the stuck contacts in series with the residual flexibility, and the free
structure's):
  - the smallest amplitude's frequency equals the stuck structure's undamped natural frequency
    to 1e-6 (the damping shift xi cancels the modal damping where it is proportional; the
    contacts' coupling leaves a difference of the order of zeta^2 x the coupling, 4e-6 at
    most) and its damping ratio equals the stuck mode's (psi^H C psi / 2 w) to 1e-5;
  - the mode's frequency without contacts equals the free resonance's to 1e-9;
  - at the largest amplitude (the shroud slides over most of the period) the frequency has come
    within 1 % of the way from the free to the stuck frequency, and the damping ratio is below
    half the most damped point's.
The kn of the shipped scene makes the large-amplitude limit a contact that opens and closes,
not the free blade. About 10 s with the model's build.

Usage: check_fe_blade_nma.py SOURCE_DIR FRICHB WORK_DIR   (exit code 1 on a failed check)
"""
import csv
import json
import pathlib
import sys

import fe_test_case


def fail(message):
    sys.exit(f"check_fe_blade_nma: {message}")


def run(command):
    fe_test_case.run_or_fail(command, fail)


def nearest(bands, system, frequency):
    """The harmonic-1 resonance band of `system` nearest `frequency` (Hz)."""
    ones = [b for b in bands if b["system"] == system and b["harmonic"] == 1]
    if not ones:
        fail(f"no {system} resonance at harmonic 1 in the run's window")
    return min(ones, key=lambda b: abs(b["centre"] - frequency))


def main():
    source, frichb, work = (pathlib.Path(a).resolve() for a in sys.argv[1:4])
    scene = fe_test_case.prepare(source, work, "test_case_nonlinear_modes.yaml", fail)
    constant_load = ["--set", "contacts.shroud.params.kn=0", "--set", "output.plots=false"]

    out = work / "nma"
    run([frichb, "--log-level", "warn", "nma", scene, "--mode", "1", *constant_load, "-o", out])
    summary = json.loads((out / "summary.json").read_text())
    rows = list(csv.DictReader((out / "nma.csv").open()))
    if summary["continuation"]["termination"] != "reached_end":
        fail(f"the backbone ended with {summary['continuation']['termination']}")
    first, last = rows[0], rows[-1]
    free_hz = summary["mode"]["frequency_without_contacts_hz"]

    # The linear resonances around the mode, as a run lists them (one harmonic, a narrow window).
    linear = work / "linear"
    run([frichb, "--log-level", "warn", "run", scene, *constant_load,
         "--set", "harmonic_balance.max_harmonic=1",
         "--set", "harmonic_balance.samples_per_period=64",
         "--set", "continuation.frequency.from=100", "--set", "continuation.frequency.to=130",
         "-o", linear])
    bands = json.loads((linear / "summary.json").read_text())["resonance_bands"]
    stuck = nearest(bands, "stuck", float(first["frequency_hz"]))
    free = nearest(bands, "free", free_hz)

    start_error = abs(float(first["frequency_hz"]) / stuck["centre"] - 1)
    ratio_error = abs(float(first["damping_ratio"]) / stuck["damping_ratio"] - 1)
    if start_error > 1e-6 or ratio_error > 1e-5:
        fail(f"smallest amplitude: {first['frequency_hz']} Hz, damping ratio "
             f"{first['damping_ratio']}; the stuck structure: {stuck['centre']} Hz, "
             f"{stuck['damping_ratio']}")
    if abs(free_hz / free["centre"] - 1) > 1e-9:
        fail(f"the mode without contacts at {free_hz} Hz, the free resonance at {free['centre']} Hz")
    way = (float(last["frequency_hz"]) - free["centre"]) / (stuck["centre"] - free["centre"])
    most = max(float(r["damping_ratio"]) for r in rows)
    if not (0 <= way < 0.01) or not float(last["damping_ratio"]) < most / 2:
        fail(f"largest amplitude: {last['frequency_hz']} Hz ({way:.3f} of the way from free to "
             f"stuck), damping ratio {last['damping_ratio']} (most damped {most})")
    print(f"check_fe_blade_nma: {len(rows)} points in {summary['wall_time_s']:.1f} s; smallest "
          f"amplitude {float(first['frequency_hz']):.6f} Hz against the stuck structure's "
          f"{stuck['centre']:.6f} Hz ({start_error:.1e}), damping ratio {float(first['damping_ratio']):.6f} against "
          f"{stuck['damping_ratio']:.6f} ({ratio_error:.1e}); largest amplitude {float(last['frequency_hz']):.4f} Hz, "
          f"{way:.4f} of the way from free ({free['centre']:.4f} Hz) to stuck; most damped "
          f"{most:.4f}")


if __name__ == "__main__":
    main()
