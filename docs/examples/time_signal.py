"""The blade's motion and the friction contact's force over one period at the resonance peak,
rebuilt from the harmonics of a frichb.run and plotted with matplotlib.

The scene is the quick start (configs/quickstart_friction_oscillator.yaml): a blade mode held
by a Jenkins friction element to the ground. The run keeps the contact's harmonics
(output.contact_forces); at the highest point of the curve the example rebuilds

  * the blade's displacement from its harmonics (RunResult.time_signal),
  * the contact's relative displacement and force from theirs (RunResult.contact_signal),

and plots them against time, with the hysteresis loop of the contact: the force the law
computes on the run's own samples (RunResult.contact_trace) and its series cut at the kept
harmonics. It checks that the rebuilt displacement is the traced one at the run's samples
(1e-12 of its amplitude) and that the blade's rebuilt peak is the run's amplitude column (the
series' maximum in continuous time) to 1e-8 on 2^16 samples of the period.

    python3 docs/examples/time_signal.py [--output DIR]

Writes DIR/time_signal.png and exits with status 1 when a check fails.
"""
import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import frichb  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "configs" / "quickstart_friction_oscillator.yaml"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--output", type=Path, default=Path("out/time_signal"),
                        help="folder for the plot")
    args = parser.parse_args()
    args.output.mkdir(parents=True, exist_ok=True)

    run = frichb.run(SCENE, set={"output.contact_forces": True}, plots=False)
    if run.status != 0:
        print(f"the run ended early: {run.termination}: {run.message}")
        return 1
    amplitude = run.amplitude("blade")
    point = int(np.argmax(amplitude))
    (contact,) = run.contacts
    frequency = run.frequency_hz[point]
    print(f"highest point {point} of {run.points}: {frequency:.3f} Hz, "
          f"{amplitude[point] * 1e6:.3f} um")

    # The blade finely enough that its largest sample is within (pi / 2^16)^2 / 2 = 1.1e-9 of the
    # series' maximum for harmonic 1 (the amplitude column is that maximum).
    _, x_fine = run.time_signal("blade", point, 2**16)
    t, x = run.time_signal("blade", point, 1024)
    # The contact on the run's own samples, and finely for the plot.
    trace = run.contact_trace(contact, point)
    n = trace["displacement"].shape[1]
    _, u_samples, _ = run.contact_signal(contact, point, n)
    _, u, f = run.contact_signal(contact, point, 1024)

    checks = {
        "blade peak = amplitude column (1e-8)":
            0 <= amplitude[point] - np.abs(x_fine).max() <= 1e-8 * amplitude[point],
        "contact displacement = traced samples (1e-12)":
            np.abs(u_samples - trace["displacement"]).max()
            <= 1e-12 * np.abs(trace["displacement"]).max(),
    }

    ms = 1e3 * t
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained")
    left.plot(ms, 1e6 * x[0], color="#0072B2", label="blade displacement [µm]")
    left.plot(ms, 1e6 * u[0], "--", color="#009E73", label=f"{contact}: u_t1 [µm]")
    left.set_xlabel("time [ms]")
    left.set_ylabel("displacement [µm]")
    force_axis = left.twinx()
    force_axis.plot(ms, f[0], "-.", color="#D55E00", label=f"{contact}: T1 [N]")
    force_axis.set_ylabel("friction force [N]")
    lines = left.get_lines() + force_axis.get_lines()
    left.legend(lines, [line.get_label() for line in lines], loc="upper center",
                bbox_to_anchor=(0.5, -0.16), ncol=3, fontsize="small")
    left.set_title(f"one period at {frequency:.2f} Hz (the resonance peak)")
    left.grid(True, alpha=0.3)

    right.plot(1e6 * trace["displacement"][0], trace["force"][0], color="#0072B2",
               label="the law's force on the run's samples")
    right.plot(1e6 * u[0], f[0], "--", color="#D55E00",
               label=f"its series to harmonic {max(run.harmonics)}")
    right.set_xlabel("relative displacement u_t1 [µm]")
    right.set_ylabel("friction force T1 [N]")
    right.set_title(f"friction loop of {contact}")
    right.grid(True, alpha=0.3)
    right.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2, fontsize="small")
    fig.savefig(args.output / "time_signal.png", dpi=120)

    for name, ok in checks.items():
        print(("ok:     " if ok else "FAILED: ") + name)
    return 0 if all(checks.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
