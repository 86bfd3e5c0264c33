#!/usr/bin/env python3
"""The large FE case at mu = 0.8 has its physical folds alone (configs/case_studies).

Builds the large_case model (configs/models/shrouded_blade, 146 sectors, 33 087 DOFs per
sector) into WORK, points a copy of configs/case_studies/large_case_3_friction.yaml at it and
runs it with mu = 0.8 (one harmonic, coupled_3d traced along the motion, near sticking at its
resonance) at 256 samples per period, as shipped, and at 1024. Checks:
  - both curves reach the end of their sweep with 2 turning points and no micro-folds (the
    sample-only step folds 34 times at 256 samples, 150 at 1024: docs/validation.md);
  - the two runs' turning points agree to 0.01 Hz;
  - the refined peaks agree to 1e-5 in amplitude (measured 2.3e-6).

About 50 s on 2 cores, most of it the modal solutions of the two harmonic indices (the
sanitizer build leaves it out).

Usage: check_large_case_folds.py SOURCE_DIR FRICHB WORK_DIR   (exit code 1 on a failed check)
"""
import json
import pathlib
import shutil
import subprocess
import sys


def fail(message):
    sys.exit(f"check_large_case_folds: {message}")


def run(command):
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        fail(f"{' '.join(map(str, command))} exited {result.returncode}:\n"
             f"{result.stdout}{result.stderr}")


def main():
    source, frichb, work = (pathlib.Path(a).resolve() for a in sys.argv[1:4])
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    model = work / "large_case"
    run([sys.executable, str(source / "configs/models/shrouded_blade/build_model.py"),
         "--preset", "large_case", "--out", str(model)])
    shipped = (source / "configs/case_studies/large_case_3_friction.yaml").read_text()
    if "../models/generated/large_case/" not in shipped:
        fail("large_case_3_friction.yaml no longer names ../models/generated/large_case/")
    scene = work / "large_case_3_friction.yaml"
    scene.write_text(shipped.replace("../models/generated/large_case/", "large_case/"))
    summaries = {}
    for samples in (256, 1024):
        out = work / f"mu0.8_n{samples}"
        run([str(frichb), "run", str(scene), "-q", "-o", str(out),
             "--set", "contacts.shroud.params.mu=0.8",
             "--set", f"harmonic_balance.samples_per_period={samples}",
             "--set", "harmonic_balance.trace_along_motion=true",
             "--set", "output.plots=false"])
        summary = json.loads((out / "summary.json").read_text())
        missing = [key for key in ("termination", "turning_points", "micro_folds",
                                   "turning_point_frequencies", "peak", "points")
                   if key not in summary]
        if missing or "response" not in summary["peak"]:
            fail(f"{out / 'summary.json'} lacks {missing or ['peak.response']}")
        termination = summary["termination"]
        reason = termination["reason"] if isinstance(termination, dict) else termination
        if reason != "reached_end":
            fail(f"{samples} samples: the curve ended with {reason}")
        if summary["turning_points"] != 2 or summary["micro_folds"] != 0:
            fail(f"{samples} samples: {summary['turning_points']} turning points "
                 f"({summary['micro_folds']} micro-folds) at "
                 f"{summary['turning_point_frequencies']} Hz, expected 2 and none")
        summaries[samples] = summary
        peak = summary["peak"]["response"]
        print(f"{samples} samples: {summary['points']} points, turning points at "
              f"{[round(f, 4) for f in summary['turning_point_frequencies']]} Hz, peak "
              f"{peak['amplitude_m']:.7e} m at {peak['frequency_hz']:.4f} Hz")
    coarse, fine = summaries[256], summaries[1024]
    for a, b in zip(sorted(coarse["turning_point_frequencies"]),
                    sorted(fine["turning_point_frequencies"])):
        if abs(a - b) > 0.01:
            fail(f"turning points at 256 and 1024 samples differ: {a} against {b} Hz")
    ratio = coarse["peak"]["response"]["amplitude_m"] / fine["peak"]["response"]["amplitude_m"]
    print(f"peak at 256 samples off the 1024-sample one by {ratio - 1:.2e}")
    if abs(ratio - 1) > 1e-5:
        fail(f"the peak at 256 samples is {ratio - 1:.2e} off the 1024-sample one (limit 1e-5)")


if __name__ == "__main__":
    main()
