#!/usr/bin/env python3
"""Tables of docs/performance.md from one frichb-bench run.

Usage: build/bin/frichb-bench --benchmark_out=bench.json --benchmark_out_format=json
       python3 scripts/performance_report.py bench.json

Prints Markdown: the time of each BM_Jacobian/<method>/<contacts>/<harmonics> (CPU time for
the methods timed by Google Benchmark, the scaled manual time for global_fd) and, from the
same run, the ratios analytic / residual, global_fd / analytic and local_fd / analytic; the
breakdown of one Newton iteration (BM_NewtonIteration) and the response curve
(BM_ResponseCurve), when the run has them.
"""
import json
import sys


def main(path):
    with open(path) as f:
        run = json.load(f)
    times = {}
    labels = {}
    for b in run["benchmarks"]:
        if b.get("error_occurred"):
            continue
        parts = b["run_name"].split("/")
        if parts[0] != "BM_Jacobian":
            continue
        method, contacts, harmonics = parts[1], int(parts[2]), int(parts[3])
        unit = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}[b["time_unit"]]
        # Wall time: OpenBLAS threads do part of the work (their CPU time is not the
        # caller's); global_fd is timed by hand (UseManualTime), its real_time is the scaled time.
        seconds = b["real_time"] * unit
        times[(method, contacts, harmonics)] = seconds
        if b.get("label"):
            labels[(method, contacts, harmonics)] = b["label"]
    newton = [b for b in run["benchmarks"]
              if b["run_name"].startswith("BM_NewtonIteration/") and not b.get("error_occurred")]
    curves = [b for b in run["benchmarks"]
              if b["run_name"].startswith("BM_ResponseCurve/") and not b.get("error_occurred")]
    grid = sorted({(c, h) for (_, c, h) in times})
    ctx = run["context"]
    print(f"Machine: {ctx.get('num_cpus')} CPUs at {ctx.get('mhz_per_cpu')} MHz, run "
          f"{ctx.get('date', '')}; wall time per call.\n")
    print("| contacts | H | unknowns | residual | analytic | local_fd | global_fd | "
          "analytic / residual | global_fd / analytic | local_fd / analytic |")
    print("|---|---|---|---|---|---|---|---|---|---|")

    def fmt(s):
        if s is None:
            return "-"
        return f"{s * 1e3:.3g} ms" if s < 1 else f"{s:.3g} s"

    def ratio(a, b):
        return f"{a / b:.3g}" if a is not None and b else "-"

    for contacts, h in grid:
        t = {m: times.get((m, contacts, h)) for m in
             ("residual", "analytic", "local_fd", "global_fd")}
        unknowns = contacts * 3 * (2 * h + 1)
        g = fmt(t["global_fd"])
        if (("global_fd", contacts, h)) in labels:
            g += "*"
        print(f"| {contacts} | {h} | {unknowns} | {fmt(t['residual'])} | {fmt(t['analytic'])} | "
              f"{fmt(t['local_fd'])} | {g} | {ratio(t['analytic'], t['residual'])} | "
              f"{ratio(t['global_fd'], t['analytic'])} | {ratio(t['local_fd'], t['analytic'])} |")
    if labels:
        sampled = sorted({labels[k].split(" of ")[0].replace("scaled from ", "") for k in labels})
        print("\n\\* global_fd timed on " + " / ".join(sampled) + " columns spread over the "
              "unknowns (each one residual) and scaled to all n + 1 columns.")

    if newton:
        print("\n### One Newton iteration\n")
        print("Milliseconds per iteration (wall time, BLAS threads included).\n")
        print("| contacts | H | unknowns | iteration | evaluation | contact traces | receptance | "
              "assembly | factorisation | other | floor | iteration / floor |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|")
        key = lambda b: tuple(int(x) for x in b["run_name"].split("/")[1:3])
        for b in sorted(newton, key=key):
            c, h = key(b)
            f = lambda k: f"{b[k]:.3g}"
            print(f"| {c} | {h} | {int(b['unknowns'])} | {f('iteration_ms')} | "
                  f"{f('evaluation_ms')} | {f('contact_ms')} | {f('receptance_ms')} | "
                  f"{f('assembly_ms')} | {f('factorisation_ms')} | {f('other_ms')} | "
                  f"{f('floor_ms')} | {b['iteration_per_floor']:.2f} |")
    for b in curves:
        c, h = b["run_name"].split("/")[1:3]
        unit = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}[b["time_unit"]]
        wall = b["real_time"] * unit
        corrector = b["run_name"].split("/")[3] if b["run_name"].count("/") >= 3 else "newton"
        print(f"\n### Response curve: {c} contacts, H = {h}, 256 samples, "
              f"{'chord corrector' if corrector == 'chord' else 'Newton corrector only'}\n")
        print(f"- wall time {wall:.1f} s ({b.get('label', '').split(' ')[0]}, last point at "
              f"{b.get('last_hz', 0):.2f} of {b.get('to_hz', 0):.0f} Hz), "
              f"{int(b['points'])} points, {int(b['newton_iterations'])} corrector iterations, "
              f"{int(b['unknowns'])} unknowns, peak memory {b['peak_memory_mib']:.0f} MiB")
        if "chord_points" in b:
            print(f"- chord corrector: {int(b['chord_points'])} points by chord iterations "
                  f"alone, {int(b['chord_iterations'])} chord iterations, "
                  f"{int(b['chord_fallbacks'])} steps handed to Newton; "
                  f"{int(b['residual_only_evaluations'])} of the evaluations without Jacobian")
        print(f"- continuation: {int(b['evaluations'])} evaluations in {b['evaluation_s']:.1f} s "
              f"(contact traces {b['contact_s']:.1f} s, receptance {b['receptance_s']:.1f} s, "
              f"assembly {b['assembly_s']:.1f} s, over all the run's evaluations), "
              f"{int(b['factorisations'])} factorisations in {b['factorisation_s']:.1f} s, "
              f"other {b['other_s']:.1f} s")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "bench.json")
