#!/usr/bin/env python3
"""Tables of docs/performance.md from one frichb-bench run.

Usage: build/bin/frichb-bench --benchmark_filter=BM_Jacobian \
           --benchmark_format=json --benchmark_out=bench.json
       python3 scripts/performance_report.py bench.json

Prints Markdown: the time of each BM_Jacobian/<method>/<contacts>/<harmonics> (CPU time for
the methods timed by Google Benchmark, the scaled manual time for global_fd) and, from the
same run, the ratios analytic / residual, global_fd / analytic and local_fd / analytic.
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
        # global_fd is timed by hand (UseManualTime): its real_time is the scaled time.
        seconds = (b["real_time"] if method == "global_fd" else b["cpu_time"]) * unit
        times[(method, contacts, harmonics)] = seconds
        if b.get("label"):
            labels[(method, contacts, harmonics)] = b["label"]
    grid = sorted({(c, h) for (_, c, h) in times})
    ctx = run["context"]
    print(f"Machine: {ctx.get('num_cpus')} CPUs at {ctx.get('mhz_per_cpu')} MHz, run "
          f"{ctx.get('date', '')}; CPU time per call.\n")
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


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "bench.json")
