"""The thesis's design chart (peak amplitude over excitation amplitude f against mu N0 / f) of a
shroud contact at three excitation levels, for three contact models: a constant normal load, a
normal load that follows the normal motion through a linear normal stiffness, and a Hertz
contact whose stiffnesses grow with the preload.

With a constant normal load, and with N = max(0, N0 + kn u_n), every force of the scene is
homogeneous of degree one in (motion, f, N0): scaling f and N0 by the same factor scales the
periodic motion by it, so the charts of all excitation levels are one curve. A Hertz contact
(N = c_n p^1.5 with p = p0 + u_n) breaks this: its stiffnesses follow the preload, not the
excitation, and the charts part. For each model the peak of the blade tip is traced against
the preload with frichb.peaks at each level; the check is that the solved optima of the two
homogeneous models agree to 1e-6 between levels (location in mu N0 / f, amplitude over f,
frequency), and that the Hertz contact's part by more than 1 %, its spread reported.

    python3 docs/examples/normalised_chart.py [--levels 1,3,7] [--range 0.5:10]
        [--models constant,linear_normal,hertz] [--output DIR]

Writes DIR/normalised_chart.png, DIR/normalised_chart.csv (every traced peak) and
DIR/normalised_chart.json (the optima and their spreads), and exits with status 1 when a check
fails.
"""
import argparse
import csv
import json
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt  # noqa: E402

import frichb  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
LINEAR = ROOT / "configs" / "peaks" / "shroud_normal_load_chart.yaml"
HERTZ = ROOT / "configs" / "peaks" / "shroud_hertz_chart.yaml"
MU = 0.5  # both scenes' friction coefficient
HERTZ_NORMAL = 2.1773e7  # configs/peaks/shroud_hertz_chart.yaml's c_n, N/m^1.5
HERTZ_EPS = 1e-9  # the law's default regularization, m
# Relative spread below which the optima of the levels count as one, and above which the Hertz
# contact's count as parted (its stiffness at f = 7 N is 7^(1/3) = 1.9 times that at 1 N).
COLLAPSE = 1e-6
PARTED = 1e-2


def hertz_load(penetration):
    """The Hertz law's normal load (N) at a penetration p >= eps (m)."""
    return HERTZ_NORMAL * (penetration ** 1.5 - HERTZ_EPS ** 1.5 / 8)


def hertz_penetration(load):
    """The penetration (m) at which the Hertz law carries `load` (N)."""
    return (load / HERTZ_NORMAL + HERTZ_EPS ** 1.5 / 8) ** (2.0 / 3.0)


# (name, label, scene, overrides, varied path, parameter from N0, N0 from parameter).
MODELS = [
    ("constant", "constant normal load", LINEAR, {"contacts.shroud.params.kn": 0.0},
     "contacts.shroud.params.normal_load", lambda n0: n0, lambda p: p),
    ("linear_normal", "N = N0 + kn u_n (kn = 2e5 N/m)", LINEAR, {},
     "contacts.shroud.params.normal_load", lambda n0: n0, lambda p: p),
    ("hertz", "Hertz: N = c_n (p0 + u_n)^1.5", HERTZ, {},
     "contacts.shroud.params.static_penetration", hertz_penetration, hertz_load),
]


def spread(values):
    """(max - min) / |mean| of a list of numbers."""
    mean = sum(values) / len(values)
    return (max(values) - min(values)) / abs(mean)


def trace(scene, overrides, path, start, end, level):
    """The peak traced against `path` from `start` to `end` at excitation amplitude `level`."""
    settings = dict(overrides)
    settings["excitation.0.amplitude"] = level
    result = frichb.peaks(scene, path, start, end, check_runs=0, axis="log", set=settings)
    if result.status != 0:
        raise RuntimeError(f"{scene.name} at f = {level} N: {result.termination}: "
                           f"{result.message}")
    if result.optimum is None or not result.optimum["solved"]:
        raise RuntimeError(f"{scene.name} at f = {level} N: the optimum was not solved")
    return result


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--levels", default="1,3,7",
                        help="excitation amplitudes f, N, comma-separated (default 1,3,7)")
    parser.add_argument("--range", default="0.5:10",
                        help="mu N0 / f from:to, traced on a log axis (default 0.5:10)")
    parser.add_argument("--models", default=",".join(model[0] for model in MODELS),
                        help="the contact models to chart, comma-separated (default: all, "
                             "constant,linear_normal,hertz)")
    parser.add_argument("--output", type=Path, default=Path("out/normalised_chart"),
                        help="folder for the plot, the CSV and the JSON summary")
    args = parser.parse_args()
    levels = [float(text) for text in args.levels.split(",")]
    low, high = (float(text) for text in args.range.split(":"))
    if len(levels) < 2 or min(levels) <= 0 or not 0 < low < high:
        parser.error("give two or more positive levels and a range 0 < from < to")
    names = args.models.split(",")
    models = [model for model in MODELS if model[0] in names]
    if len(models) != len(set(names)):
        parser.error("--models: choose among " + ", ".join(model[0] for model in MODELS))
    args.output.mkdir(parents=True, exist_ok=True)

    rows, summary, checks = [], {}, {}
    for name, label, scene, overrides, path, parameter_of, load_of in models:
        optima = []
        for level in levels:
            start = parameter_of(low * level / MU)
            end = parameter_of(high * level / MU)
            result = trace(scene, overrides, path, start, end, level)
            for value, frequency, amplitude in zip(result.parameter_values, result.frequency_hz,
                                                   result.amplitude_m):
                rows.append({"model": name, "excitation_n": level,
                             "mu_n0_over_f": MU * load_of(value) / level,
                             "peak_amplitude_over_f_m_per_n": amplitude / level,
                             "peak_frequency_hz": frequency})
            optimum = result.optimum
            optima.append({"excitation_n": level,
                           "mu_n0_over_f": MU * load_of(optimum["parameter"]) / level,
                           "peak_amplitude_over_f_m_per_n": optimum["amplitude_m"] / level,
                           "peak_frequency_hz": optimum["frequency_hz"]})
            print(f"{name:14s} f = {level:g} N: optimum at mu N0/f = "
                  f"{optima[-1]['mu_n0_over_f']:.6f}, A/f = "
                  f"{optima[-1]['peak_amplitude_over_f_m_per_n'] * 1e6:.6f} um/N, "
                  f"{optima[-1]['peak_frequency_hz']:.4f} Hz ({len(result.parameter_values)} "
                  f"peaks)")
        spreads = {key: spread([o[key] for o in optima])
                   for key in ("mu_n0_over_f", "peak_amplitude_over_f_m_per_n",
                               "peak_frequency_hz")}
        summary[name] = {"label": label, "optima": optima, "spreads": spreads}
        print(f"{name:14s} spreads between levels: " +
              ", ".join(f"{key} {value:.2e}" for key, value in spreads.items()))
        if name == "hertz":
            checks[f"{label}: optima of the levels part by more than {PARTED:g}"] = bool(
                max(spreads.values()) > PARTED)
        else:
            checks[f"{label}: optima of the levels agree to {COLLAPSE:g}"] = bool(
                max(spreads.values()) <= COLLAPSE)

    with open(args.output / "normalised_chart.csv", "w", newline="", encoding="utf-8") as file:
        writer = csv.DictWriter(file, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)

    colours = ["#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00"]
    fig, axes = plt.subplots(2, len(models), figsize=(4.5 * len(models), 7), sharex=True,
                             sharey="row", squeeze=False, layout="constrained")
    for column, (name, label, *_rest) in enumerate(models):
        top, bottom = axes[0][column], axes[1][column]
        for index, level in enumerate(levels):
            mine = [r for r in rows if r["model"] == name and r["excitation_n"] == level]
            x = [r["mu_n0_over_f"] for r in mine]
            colour = colours[index % len(colours)]
            style = dict(color=colour, lw=2.4 - 0.6 * index, label=f"f = {level:g} N")
            top.plot(x, [r["peak_amplitude_over_f_m_per_n"] * 1e6 for r in mine], **style)
            bottom.plot(x, [r["peak_frequency_hz"] for r in mine], **style)
            optimum = summary[name]["optima"][index]
            top.plot([optimum["mu_n0_over_f"]],
                     [optimum["peak_amplitude_over_f_m_per_n"] * 1e6], "o", color=colour,
                     mfc="none")
        spreads = summary[name]["spreads"]
        top.set_title(f"{label}\noptima spread {spreads['mu_n0_over_f']:.1e} in μN0/f, "
                      f"{spreads['peak_amplitude_over_f_m_per_n']:.1e} in A/f", fontsize=9)
        top.set_xscale("log")
        for axis in (top, bottom):
            axis.grid(True, which="both", alpha=0.3)
        bottom.set_xlabel("μN0 / f")
    axes[0][0].set_ylabel("peak amplitude / f [µm/N]")
    axes[1][0].set_ylabel("peak frequency [Hz]")
    axes[0][0].legend(loc="best")
    fig.suptitle("Shroud contact: the normalised design chart at three excitation levels")
    fig.savefig(args.output / "normalised_chart.png", dpi=120)

    (args.output / "normalised_chart.json").write_text(
        json.dumps({"levels_n": levels, "range_mu_n0_over_f": [low, high], "models": summary,
                    "checks": checks}, indent=2) + "\n")
    for check, ok in checks.items():
        print(("ok:     " if ok else "FAILED: ") + check)
    return 0 if all(checks.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
