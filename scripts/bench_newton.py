#!/usr/bin/env python3
"""The implicit (Newton) path's profile, run by scripts/bench: for each contact scene and for the
hanging cloth at growing sizes, fem_cloth_sim's summary (real-time factor, Newton iterations and
backtracks per step, where the Newton time went), as a table (newton.md), JSON (newton.json) and
the cost of one Newton iteration against the mesh with its fitted exponent (newton_scaling.png).

    scripts/bench_newton.py --sim BIN --out DIR [--quick]
"""
import argparse
import json
import math
import os
import re
import subprocess
import sys

# (label, arguments after --scene): the contact scenes of issue 28, then the scaling runs.
SCENES = [
    ("pinch_lift 13x13", ["config/pinch_lift.yaml"]),
    ("pinch_lift 33x33", ["config/pinch_lift_33.yaml"]),
    ("fold 33x33, 1 s", ["config/fold.yaml", "--set", "mesh.rows=33", "--set", "mesh.cols=33", "--duration", "1"]),
    ("table_drape", ["config/table_drape.yaml"]),
    ("sphere_drape", ["config/sphere_drape.yaml"]),
]
HANGING = ["config/hanging_cloth.yaml", "--integrator", "backward_euler"]


def scaling_runs(quick):
    sizes = [17, 33, 65] if quick else [17, 33, 65, 129]
    return [(f"hanging BE {n}x{n}", HANGING + ["--set", f"mesh.rows={n}", "--set", f"mesh.cols={n}",
                                               "--duration", "0.3" if n <= 65 else "0.03"], n) for n in sizes]


def run(sim, root, args):
    proc = subprocess.run([sim, "--scene"] + args + ["--no-output"], cwd=root, capture_output=True, text=True)
    text = proc.stdout
    row = {"exit": proc.returncode}
    m = re.search(r"steps:\s+(\d+) of \d+ \((\d+) substeps\), simulated ([\d.e+-]+) s in ([\d.e+-]+) s wall "
                  r"\(real-time factor ([\d.e+-]+)\)", text)
    if m:
        row.update(steps=int(m[1]), substeps=int(m[2]), simulated=float(m[3]), wall=float(m[4]), rtf=float(m[5]))
    m = re.search(r"solver:\s+(\d+) Newton iterations .* (\d+) line-search backtracks, (\d+) rollbacks, (\d+) failures", text)
    if m:
        row.update(iterations=int(m[1]), backtracks=int(m[2]), rollbacks=int(m[3]), failures=int(m[4]))
    m = re.search(r"Newton time:\s+([\d.e+-]+) s, ([\d.e+-]+) ms per iteration: assembly (\d+) %, factorisation (\d+) %, "
                  r"solve (\d+) %, step bound (\d+) %, line search (\d+) %", text)
    if m:
        row.update(newton_s=float(m[1]), ms_per_iteration=float(m[2]), assembly=int(m[3]), factorisation=int(m[4]),
                   solve=int(m[5]), bound=int(m[6]), search=int(m[7]))
    if proc.returncode != 0 or "rtf" not in row:
        row["error"] = (proc.stderr or text).strip().splitlines()[-1:] or ["no summary"]
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sim", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args()
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    rows = []
    for label, args in SCENES:
        print(f"   {label} ...", flush=True)
        rows.append(dict(label=label, **run(a.sim, root, args)))
    scaling = []
    for label, args, n in scaling_runs(a.quick):
        print(f"   {label} ...", flush=True)
        r = dict(label=label, n=n, **run(a.sim, root, args))
        rows.append(r)
        if "ms_per_iteration" in r:
            scaling.append((n * n, r["ms_per_iteration"]))
    lines = ["| run | × real time | Newton it./step | backtracks/step | ms/iteration | assembly | factorisation | solve | step bound | line search |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['label']} | failed: {r['error'][0]} | | | | | | | | |")
            continue
        per = lambda k: f"{r[k] / r['steps']:.2f}" if r.get("steps") else "-"
        lines.append(f"| {r['label']} | {r['rtf']:.3g} | {per('iterations')} | {per('backtracks')} | "
                     f"{r.get('ms_per_iteration', 0):.3g} | {r.get('assembly', 0)} % | {r.get('factorisation', 0)} % | "
                     f"{r.get('solve', 0)} % | {r.get('bound', 0)} % | {r.get('search', 0)} % |")
    exponent = None
    if len(scaling) >= 2:
        xs = [math.log(v) for v, _ in scaling]
        ys = [math.log(t) for _, t in scaling]
        mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
        exponent = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)
        lines.append("")
        lines.append(f"Cost of one Newton iteration on the hanging cloth against its vertices n: n^{exponent:.2f} "
                     f"(least squares over {', '.join(str(v) for v, _ in scaling)} vertices).")
    os.makedirs(a.out, exist_ok=True)
    with open(os.path.join(a.out, "newton.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    with open(os.path.join(a.out, "newton.json"), "w") as f:
        json.dump({"runs": rows, "exponent": exponent}, f, indent=1)
    if scaling:
        try:
            import matplotlib
            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
            fig, ax = plt.subplots(figsize=(5, 3.6))
            ax.loglog([v for v, _ in scaling], [t for _, t in scaling], "o-", label="measured")
            if exponent is not None:
                v0, t0 = scaling[0]
                ax.loglog([v for v, _ in scaling], [t0 * (v / v0) ** exponent for v, _ in scaling], "--",
                          label=f"fit n^{exponent:.2f}")
            ax.set_xlabel("vertices n")
            ax.set_ylabel("ms per Newton iteration")
            ax.set_title("backward Euler, hanging cloth")
            ax.legend()
            fig.tight_layout()
            fig.savefig(os.path.join(a.out, "newton_scaling.png"), dpi=110)
        except ImportError:
            print("bench_newton: matplotlib missing, no plot", file=sys.stderr)
    print("\n".join(lines))
    return 1 if any("error" in r for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
