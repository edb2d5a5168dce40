#!/usr/bin/python3
"""Turns fem_cloth_bench's JSON into the tables and the scaling plot of docs/performance.md.

    bench_report.py bench.json --out DIR [--peer peer.txt] [--node node.txt]

Prints (and writes DIR/performance.md):
  - the step table: ms per step, steps per second, real-time factor (dt / wall time per step),
    substeps, stretch at the end of the benchmark run, per integrator and grid size;
  - the scaling exponent of the cost per step (and per substep) in the vertex count n from
    33 x 33 to 129 x 129 (least-squares slope of log time against log n);
  - kernels and assembly;
and draws DIR/scaling.png (ms per step against vertices, log-log, one line per integrator).
"""
import argparse
import json
import math
import os
import re
import sys


def load(path):
    with open(path) as f:
        data = json.load(f)
    return data.get("context", {}), [b for b in data["benchmarks"] if b.get("run_type") != "aggregate"]


def ms(b):
    scale = {"ns": 1e-6, "us": 1e-3, "ms": 1.0, "s": 1e3}[b.get("time_unit", "ns")]
    return b["real_time"] * scale


def slope(points):
    """Least-squares slope of log y against log x."""
    xs = [math.log(x) for x, _ in points]
    ys = [math.log(y) for _, y in points]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    sxx = sum((x - mx) ** 2 for x in xs)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx if sxx > 0 else float("nan")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("json")
    parser.add_argument("--out", default=".")
    parser.add_argument("--peer", help="output of fem_cloth_peer_bullet, included verbatim")
    parser.add_argument("--node", help="output of bench_node.py, included verbatim")
    args = parser.parse_args()
    context, runs = load(args.json)
    os.makedirs(args.out, exist_ok=True)
    lines = []

    def say(text=""):
        print(text)
        lines.append(text)

    say(f"Machine: {context.get('num_cpus', '?')} CPUs at {context.get('mhz_per_cpu', '?')} MHz, "
        f"load average {', '.join('%.2f' % l for l in context.get('load_avg', []))}; {context.get('date', '')}")
    say()
    steps = {}
    for b in runs:
        m = re.match(r"Step/(\w+)/(\d+)", b["name"])
        if m and "error_occurred" not in b:
            steps.setdefault(m.group(1), {})[int(m.group(2))] = b
    say("| integrator | grid | vertices | dt (s) | substeps | ms/step | steps/s | real-time factor | mean stretch | max stretch |")
    say("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, sizes in steps.items():
        for n, b in sorted(sizes.items()):
            t = ms(b)
            say(f"| {name} | {n}x{n} | {int(b['vertices'])} | {b['dt']:.4g} | {b['substeps']:.3g} | "
                f"{t:.3f} | {1e3 / t:.1f} | {b['dt'] * 1e3 / t:.2f} | {100 * b['mean_stretch']:.3f} % | "
                f"{100 * b['max_stretch']:.2f} % |")
    say()
    say("Scaling of the cost in the vertex count n, 33x33 to 129x129 (slope of log time against log n):")
    say()
    say("| integrator | per step | per substep |")
    say("| --- | --- | --- |")
    exponents = {}
    for name, sizes in steps.items():
        pts = [(b["vertices"], ms(b)) for n, b in sizes.items() if n >= 33]
        sub = [(b["vertices"], ms(b) / b["substeps"]) for n, b in sizes.items() if n >= 33]
        if len(pts) >= 2:
            exponents[name] = (slope(pts), slope(sub))
            say(f"| {name} | n^{exponents[name][0]:.2f} | n^{exponents[name][1]:.2f} |")
    say()
    say("Element kernels (one cloth element, 3 x 2 F) and assembly:")
    say()
    say("| benchmark | time |")
    say("| --- | --- |")
    for b in runs:
        if b["name"].startswith(("Kernel", "Assembly")):
            t = ms(b)
            shown = f"{t * 1e6:.0f} ns" if t < 1e-2 else f"{t * 1e3:.1f} µs" if t < 1 else f"{t:.3f} ms"
            say(f"| {b['name']} | {shown} |")
    for b in runs:
        if b["name"].startswith("HangingCloth65"):
            say()
            say(f"HangingCloth65 (config/hanging_cloth_fast.yaml, 2 s simulated): {ms(b) / 1e3:.3f} s wall, "
                f"real-time factor {b['simulated_s'] / (ms(b) / 1e3):.2f}, mean stretch "
                f"{100 * b['mean_stretch']:.3f} %, max {100 * b['max_stretch']:.2f} %")
    if args.peer and os.path.exists(args.peer):
        say()
        say("Side by side with Bullet (fem_cloth_peer_bullet):")
        say()
        say("```")
        with open(args.peer) as f:
            for line in f.read().rstrip().split("\n"):
                say(line)
        say("```")
    if args.node and os.path.exists(args.node):
        say()
        say("The node at 60 Hz (scripts/bench_node.py):")
        say()
        say("```")
        with open(args.node) as f:
            for line in f.read().rstrip().split("\n"):
                say(line)
        say("```")
    with open(os.path.join(args.out, "performance.md"), "w") as f:
        f.write("\n".join(lines) + "\n")

    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("bench_report.py: matplotlib missing: no plot (install python3-matplotlib)", file=sys.stderr)
        return
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for name, sizes in steps.items():
        pts = sorted((b["vertices"], ms(b)) for b in sizes.values())
        label = name + (f" (n^{exponents[name][0]:.2f})" if name in exponents else "")
        ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", label=label)
    ref = sorted({int(b["vertices"]) for s in steps.values() for b in s.values()})
    if ref:
        ax.loglog(ref, [0.01 * (v / ref[0]) for v in ref], "k:", label="linear (n^1)")
    ax.set_xlabel("vertices n")
    ax.set_ylabel("wall time per step (ms)")
    ax.set_title("Cost per step of the hanging cloth, 17x17 to 129x129")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = os.path.join(args.out, "scaling.png")
    fig.savefig(path, dpi=110)
    print(f"wrote {path} and {os.path.join(args.out, 'performance.md')}")


if __name__ == "__main__":
    main()
