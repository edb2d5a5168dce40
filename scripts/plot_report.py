#!/usr/bin/python3
"""Plots the CSV files written by `fem_cloth_report` (scripts/report runs it).

    plot_report.py DIR [--out DIR]

Reads DIR/work_precision.csv, references.csv, error_over_time.csv and stability.csv (whichever
exist) and writes PNG files next to them (or to --out):
  work_precision.png   RMS position error over time (relative to the cloth size) against wall
                       time, log-log, one line per integrator setting, a marker per dt
  convergence.png      RMS position error at the end against dt, with slopes 1 and 2
  error_over_time.png  RMS position error over time at one dt per setting
  stability.png        the stability matrix as a coloured table, one panel per extreme case

Run it with Debian's /usr/bin/python3 (python3-matplotlib). Exit status 3 if matplotlib is missing.
"""
import argparse
import csv
import math
import os
import sys
from collections import OrderedDict

try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
except ImportError as e:  # pragma: no cover - depends on the machine
    print(f"plot_report.py: {e}; install python3-matplotlib (scripts/install-deps) and run with "
          "/usr/bin/python3", file=sys.stderr)
    sys.exit(3)

# One colour per integrator (integrators the script does not know get the next free colour), one
# dash pattern per setting of an integrator, one marker per dt (coarse to fine).
INTEGRATOR_COLORS = OrderedDict([
    ("symplectic_euler", "#1f77b4"),
    ("backward_euler", "#d62728"),
    ("bdf2", "#2ca02c"),
    ("xpbd", "#ff7f0e"),
    ("projective_dynamics", "#9467bd"),
])
SPARE_COLORS = ["#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"]
DASHES = ["-", "--", ":", "-."]
DT_MARKERS = ["o", "s", "^", "D", "v", "P", "X"]
VERDICT_COLORS = OrderedDict([
    ("stable", "#4caf50"),
    ("recovered", "#cddc39"),
    ("failed", "#ff7043"),
    ("too_slow", "#ab47bc"),
    ("n/a", "#bdbdbd"),
    ("wrong", "#d50000"),
    ("non_finite", "#000000"),
])


def read_csv(path):
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def color_of(integrator, colors):
    if integrator not in colors:
        colors[integrator] = SPARE_COLORS[(len(colors) - len(INTEGRATOR_COLORS)) % len(SPARE_COLORS)]
    return colors[integrator]


def dt_label(dt):
    """1e-4 s, 0.01 s, 1/30 s: decimals when they are short, else the fraction."""
    if abs(dt * 1e4 - round(dt * 1e4)) < 1e-9:
        return f"{dt:g} s"
    inverse = 1.0 / dt
    if abs(inverse - round(inverse)) < 1e-6 * inverse:
        return f"1/{round(inverse)} s"
    return f"{dt:.3g} s"


def group(rows):
    """{scene: {label: [rows sorted coarse to fine]}} of the runs that completed."""
    out = OrderedDict()
    for r in rows:
        if r["status"] != "ok":
            continue
        out.setdefault(r["scene"], OrderedDict()).setdefault(r["label"], []).append(r)
    for labels in out.values():
        for runs in labels.values():
            runs.sort(key=lambda r: -float(r["dt"]))
    return out


def styles(rows):
    """(colour, dash) per label: dashes number the settings of one integrator."""
    colors = dict(INTEGRATOR_COLORS)
    seen, out = {}, {}
    for r in rows:
        if r["label"] in out:
            continue
        k = seen.get(r["integrator"], 0)
        seen[r["integrator"]] = k + 1
        out[r["label"]] = (color_of(r["integrator"], colors), DASHES[k % len(DASHES)])
    return out


def subplot_grid(n):
    cols = 2 if n > 1 else 1
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(6.4 * cols, 4.6 * rows), squeeze=False)
    for ax in axes.flat[n:]:
        ax.axis("off")
    return fig, list(axes.flat)


def all_dts(rows):
    return sorted({float(r["dt"]) for r in rows if r["status"] == "ok"}, reverse=True)


def dt_legend(count):
    """One marker per position in each panel's (coarse to fine) dt list; the panel titles list
    the steps."""
    names = ["coarsest dt"] + [f"dt no. {i + 1}" for i in range(1, count)]
    names[-1] = "finest dt" if count > 1 else names[-1]
    return [Line2D([], [], color="black", marker=DT_MARKERS[i % len(DT_MARKERS)], linestyle="",
                   label=names[i]) for i in range(count)]


def dts_title(scene, dts):
    return f"{scene} (dt {', '.join(dt_label(d).replace(' s', '') for d in dts)} s)"


def label_axes(ax, xlabel, ylabel, title, logx=True):
    if logx:
        ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.25)


def finish(fig, axes, title, path, extra_handles=()):
    """One legend below all panels (each label once), a title, tight layout, PNG."""
    handles, labels = [], []
    for ax in axes:
        for h, l in zip(*ax.get_legend_handles_labels()):
            if l not in labels:
                handles.append(h)
                labels.append(l)
    handles += list(extra_handles)
    labels += [h.get_label() for h in extra_handles]
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=7, frameon=False)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout(rect=(0, 0.025 * ((len(labels) + 2) // 3) + 0.02, 1, 0.97))
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot_work_precision(rows, refs, path):
    data = group(rows)
    if not data:
        return False
    style = styles(rows)
    fig, axes = subplot_grid(len(data))
    dts_by_scene = []
    for ax, (scene, labels) in zip(axes, data.items()):
        dts = all_dts([r for r in rows if r["scene"] == scene])
        dts_by_scene.append(dts)
        for label, runs in labels.items():
            color, dash = style[label]
            x = [float(r["wall_s"]) for r in runs]
            y = [float(r["rms_over_time"]) for r in runs]
            ax.plot(x, y, color=color, linestyle=dash, linewidth=1.4, label=label)
            for r, xi, yi in zip(runs, x, y):
                ax.plot(xi, yi, color=color, marker=DT_MARKERS[dts.index(float(r["dt"])) % len(DT_MARKERS)],
                        markersize=5, linestyle="")
        for ref in refs:
            # The reference against itself at twice its step: errors near this line are not
            # resolved by the reference.
            if ref["scene"] == scene and float(ref["check_rms_over_time"]) > 0:
                ax.axhline(float(ref["check_rms_over_time"]), color="grey", linewidth=0.8, linestyle="--")
                ax.annotate("reference check", (0.01, float(ref["check_rms_over_time"])),
                            xycoords=("axes fraction", "data"), fontsize=7, color="grey", va="bottom")
        label_axes(ax, "wall time (s, median of repeats)", "RMS position error over time / cloth size",
                   dts_title(scene, dts))
    finish(fig, axes, "Work precision: error against wall time (lower left is better)", path,
           dt_legend(max(len(d) for d in dts_by_scene)))
    return True


def plot_convergence(rows, path):
    data = group(rows)
    if not data:
        return False
    style = styles(rows)
    fig, axes = subplot_grid(len(data))
    for ax, (scene, labels) in zip(axes, data.items()):
        dts = all_dts([r for r in rows if r["scene"] == scene])
        for label, runs in labels.items():
            color, dash = style[label]
            ax.plot([float(r["dt"]) for r in runs], [float(r["rms_end"]) for r in runs], color=color,
                    linestyle=dash, marker="o", markersize=3, linewidth=1.2, label=label)
        # Slopes 1 and 2 through the middle of the plot, for the eye.
        lo, hi = min(dts), max(dts)
        ys = [float(r["rms_end"]) for runs in labels.values() for r in runs if float(r["rms_end"]) > 0]
        if ys:
            mid = math.exp(0.5 * (math.log(min(ys)) + math.log(max(ys))))
            for p, text in ((1, "order 1"), (2, "order 2")):
                ax.plot([lo, hi], [mid * (lo / hi) ** p, mid], color="black", linewidth=0.8,
                        linestyle=(0, (1, 2 * p)))
                ax.text(lo, mid * (lo / hi) ** p, text, fontsize=7, va="top")
        label_axes(ax, "dt (s)", "RMS position error at the end / cloth size", scene)
    finish(fig, axes, "Convergence: error against dt", path)
    return True


def plot_error_over_time(rows, series, path):
    """The default setting of each integrator (its first label) at the second coarsest dt of
    each scene, and the reference against itself at twice its step."""
    if not series:
        return False
    style = styles(rows)
    first = OrderedDict()
    for r in rows:
        first.setdefault(r["integrator"], r["label"])
    shown = set(first.values())
    scenes = list(OrderedDict.fromkeys(s["scene"] for s in series))
    fig, axes = subplot_grid(len(scenes))
    for ax, scene in zip(axes, scenes):
        dts = all_dts([r for r in rows if r["scene"] == scene])
        if not dts:
            continue
        dt = dts[1] if len(dts) > 1 else dts[0]
        curves = OrderedDict()
        for s in series:
            if s["scene"] != scene or float(s["t"]) <= 0.0:
                continue
            if s["label"] == "reference check" or (s["label"] in shown and
                                                   abs(float(s["dt"]) - dt) <= 1e-12 * dt):
                curves.setdefault(s["label"], ([], []))
                curves[s["label"]][0].append(float(s["t"]))
                curves[s["label"]][1].append(max(float(s["rms"]), 1e-16))
        for label, (t, e) in curves.items():
            if label == "reference check":
                ax.plot(t, e, color="black", linestyle="--", linewidth=1.0, label=label)
            elif label in style:
                color, dash = style[label]
                ax.plot(t, e, color=color, linestyle=dash, linewidth=1.2, label=label)
        label_axes(ax, "t (s)", "RMS position error / cloth size", f"{scene}, dt = {dt_label(dt)}",
                   logx=False)
    finish(fig, axes, "Error over time (default settings; dashed: the reference against itself)", path)
    return True


def plot_stability(cells, path):
    if not cells:
        return False
    cases = list(OrderedDict.fromkeys(c["case"] for c in cells))
    materials = list(OrderedDict.fromkeys(c["material"] for c in cells))
    levels = list(OrderedDict.fromkeys(c["stiffness"] for c in cells))
    integrators = list(OrderedDict.fromkeys(c["integrator"] for c in cells))
    dts = sorted({float(c["dt"]) for c in cells})
    rows = [(m, s) for m in materials for s in levels]
    cols = [(i, d) for i in integrators for d in dts]
    index = {(c["case"], c["material"], c["stiffness"], c["integrator"], float(c["dt"])): c for c in cells}
    ncols = 2 if len(cases) > 1 else 1
    nrows = (len(cases) + ncols - 1) // ncols
    cell_w, cell_h = 0.24, 0.2
    fig_w = ncols * (len(cols) * cell_w + 2.2)
    fig_h = nrows * (len(rows) * cell_h + 1.6) + 0.8
    fig, axes = plt.subplots(nrows, ncols, figsize=(fig_w, fig_h), squeeze=False)
    for ax in axes.flat[len(cases):]:
        ax.axis("off")
    for ax, case in zip(axes.flat, cases):
        for y, (m, s) in enumerate(rows):
            for x, (i, d) in enumerate(cols):
                c = index.get((case, m, s, i, d))
                if c is None:
                    continue
                color = VERDICT_COLORS.get(c["verdict"], "#ffffff")
                ax.add_patch(plt.Rectangle((x, y), 1, 1, facecolor=color, edgecolor="white", linewidth=0.6))
                if c["verdict"] == "recovered":
                    ax.text(x + 0.5, y + 0.5, c["rollbacks"], ha="center", va="center", fontsize=5)
                elif c["verdict"] == "n/a":
                    ax.text(x + 0.5, y + 0.5, "n/a", ha="center", va="center", fontsize=3.5, color="#616161")
        ax.set_xlim(0, len(cols))
        ax.set_ylim(len(rows), 0)
        ax.set_yticks([y + 0.5 for y in range(len(rows))])
        ax.set_yticklabels([f"{m} {s}" for m, s in rows], fontsize=6)
        ax.set_xticks([x + 0.5 for x in range(len(cols))])
        ax.set_xticklabels([dt_label(d).replace(" s", "") for _, d in cols], fontsize=5, rotation=90)
        for k, integrator in enumerate(integrators):
            ax.text((k + 0.5) * len(dts), -0.3, integrator.replace("_", " "), ha="center", va="bottom",
                    fontsize=6.5)
            if k:
                ax.axvline(k * len(dts), color="black", linewidth=1.0)
        for k in range(1, len(materials)):
            ax.axhline(k * len(levels), color="black", linewidth=0.6)
        ax.set_title(case, fontsize=9, pad=16, fontweight="bold")
        ax.tick_params(length=0)
    legend = [Patch(facecolor=v, label=k.replace("_", " ")) for k, v in VERDICT_COLORS.items()]
    fig.legend(handles=legend, loc="lower center", ncol=len(legend), fontsize=7, frameon=False)
    fig.suptitle("Stability matrix (numbers: rollbacks of recovered cells; n/a: the integrator\n"
                 "does not take the scene; columns: dt in s)", fontsize=10)
    fig.tight_layout(rect=(0, 0.03, 1, 0.97))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("dir", help="the folder fem_cloth_report wrote")
    parser.add_argument("--out", help="where to write the PNG files (default: the same folder)")
    args = parser.parse_args()
    out = args.out or args.dir
    os.makedirs(out, exist_ok=True)
    wp = read_csv(os.path.join(args.dir, "work_precision.csv"))
    refs = read_csv(os.path.join(args.dir, "references.csv"))
    series = read_csv(os.path.join(args.dir, "error_over_time.csv"))
    cells = read_csv(os.path.join(args.dir, "stability.csv"))
    if not (wp or cells):
        sys.exit(f"plot_report.py: no work_precision.csv or stability.csv in {args.dir}")
    written = []
    for name, ok in (("work_precision.png", lambda p: plot_work_precision(wp, refs, p)),
                     ("convergence.png", lambda p: plot_convergence(wp, p)),
                     ("error_over_time.png", lambda p: plot_error_over_time(wp, series, p)),
                     ("stability.png", lambda p: plot_stability(cells, p))):
        path = os.path.join(out, name)
        if ok(path):
            written.append(path)
    for path in written:
        print(path)


if __name__ == "__main__":
    main()
