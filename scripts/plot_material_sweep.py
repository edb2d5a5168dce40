#!/usr/bin/python3
"""Plots the CSV written by `fem_cloth_materials sweep`: psi(s) and P22(s) along F = diag(1, s),
one line per material model, with the collapse (s = 0) and planar inversion (s < 0) marked.

    plot_material_sweep.py --csv material_sweep.csv --png material_sweep.png [--title TEXT]

Run it with Debian's /usr/bin/python3 (python3-matplotlib). Exit status 3 if matplotlib is missing.
"""
import argparse
import csv
import math
import sys
from collections import OrderedDict

# Linear, corotational and Stable Neo-Hookean coincide along F = diag(1, s): all three reduce to
# (mu + lambda/2) (s - 1)^2 there. Distinct dash patterns and widths keep each line visible.
STYLES = {
    "linear": dict(color="#555555", linestyle="-", linewidth=4.5, alpha=0.35),
    "stvk": dict(color="#d62728", linewidth=2.0),
    "corotational": dict(color="#1f77b4", linestyle=(0, (6, 3)), linewidth=2.0),
    "arap": dict(color="#17becf", linestyle="-.", linewidth=2.0),
    "neo_hookean": dict(color="#2ca02c", linewidth=2.0),
    "stable_neo_hookean": dict(color="#9467bd", linestyle=(0, (1.5, 2.5)), linewidth=2.5),
}


def read_sweep(path):
    """{model: (s, psi, P22)} from the long-format CSV, in file order."""
    curves = OrderedDict()
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        for column in ("model", "s", "psi_J_per_m2", "P22_N_per_m"):
            if column not in reader.fieldnames:
                sys.exit(f"plot_material_sweep: {path} has no column '{column}'")
        for row in reader:
            s, psi, p22 = curves.setdefault(row["model"], ([], [], []))
            s.append(float(row["s"]))
            psi.append(float(row["psi_J_per_m2"]))
            p22.append(float(row["P22_N_per_m"]))
    return curves


def axis_limits(values, margin=0.08):
    """Limits that show the finite values of the well-behaved bulk of the curves: the largest
    magnitudes (a barrier going to infinity) are cut at the 95th percentile, times 1.3."""
    finite = sorted(abs(v) for v in values if math.isfinite(v))
    if not finite:
        return -1.0, 1.0
    top = 1.3 * finite[int(0.95 * (len(finite) - 1))]
    low = min((v for v in values if math.isfinite(v)), default=0.0)
    bottom = max(low, -top) if low < 0 else -margin * top
    return bottom - margin * top * (low < 0), top


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--csv", required=True)
    parser.add_argument("--png", required=True)
    parser.add_argument("--title", default="")
    args = parser.parse_args()
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("plot_material_sweep: matplotlib is missing: install python3-matplotlib "
              "(scripts/install-deps) and run with /usr/bin/python3", file=sys.stderr)
        return 3

    curves = read_sweep(args.csv)
    s_all = [s for s, _, _ in curves.values() for s in s]
    s_lo, s_hi = min(s_all), max(s_all)
    fig, (ax_psi, ax_p) = plt.subplots(2, 1, sharex=True, figsize=(9, 9))
    for model, (s, psi, p22) in curves.items():
        style = dict(linewidth=1.8)
        style.update(STYLES.get(model, {}))
        ax_psi.plot(s, psi, label=model, **style)
        ax_p.plot(s, p22, label=model, **style)

    ax_psi.set_ylim(*axis_limits([v for _, psi, _ in curves.values() for v in psi]))
    bottom, top = axis_limits([v for _, _, p22 in curves.values() for v in p22])
    ax_p.set_ylim(min(bottom, -top), top)

    for ax in (ax_psi, ax_p):
        if s_lo < 0.0:
            ax.axvspan(s_lo, 0.0, color="#f4cccc", alpha=0.5, linewidth=0)
        ax.axvline(0.0, color="black", linewidth=1.2)
        ax.axvline(1.0, color="black", linewidth=0.8, linestyle=":")
        ax.axhline(0.0, color="black", linewidth=0.6)
        ax.grid(True, alpha=0.3)
        ax.set_xlim(s_lo, s_hi)
    label_box = dict(boxstyle="round,pad=0.2", facecolor="white", edgecolor="none", alpha=0.8)
    ax_psi.text(0.0, 1.01, "collapse\ns = 0", transform=ax_psi.get_xaxis_transform(),
                ha="center", va="bottom", fontsize=9)
    ax_psi.text(1.0, 1.01, "rest\ns = 1", transform=ax_psi.get_xaxis_transform(),
                ha="center", va="bottom", fontsize=9)
    if s_lo < 0.0:
        ax_psi.text(0.5 * s_lo, 0.97, "planar inversion (s < 0)",
                    transform=ax_psi.get_xaxis_transform(), ha="center", va="top", bbox=label_box)

    # Along F = diag(1, s) StVK's psi is (mu/4 + lambda/8) (s^2 - 1)^2, so its restoring stress is
    # largest at s = 1/sqrt(3) whatever mu and lambda, and fades as the element collapses: mark
    # where this sweep has it.
    if "stvk" in curves:
        s, _, p22 = curves["stvk"]
        compressed = [(p, x) for x, p in zip(s, p22) if 0.0 < x < 1.0 and math.isfinite(p)]
        if compressed:
            p_peak, s_peak = min(compressed)
            ax_p.plot([s_peak], [p_peak], "o", color=STYLES["stvk"]["color"])
            ax_p.annotate(f"StVK's largest restoring stress,\ns = {s_peak:.2f} (1/√3 = 0.577)",
                          (s_peak, p_peak), xytext=(s_peak + 0.05, p_peak + 0.3 * (top - p_peak)),
                          fontsize=9, arrowprops=dict(arrowstyle="->", linewidth=0.8))

    ax_psi.set_ylabel("energy density ψ (J/m²)")
    ax_p.set_ylabel("stress P₂₂ = ∂ψ/∂s (N/m)")
    ax_p.set_xlabel("s in F = diag(1, s)   (compression 0 < s < 1, stretch s > 1)")
    ax_p.text(0.01, 0.03, "P₂₂ < 0 pushes s up: restoring under compression and inversion",
              transform=ax_p.transAxes, fontsize=9, bbox=label_box)
    ax_p.legend(loc="lower right", fontsize=9, framealpha=0.95,
                title="linear, corotational and stable_neo_hookean\ncoincide on this path",
                title_fontsize=8)
    title = "fem_cloth membrane materials under uniaxial loading"
    fig.suptitle(title + (f"\n{args.title}" if args.title else ""), y=0.995)
    fig.tight_layout()
    fig.savefig(args.png, dpi=120)
    return 0


if __name__ == "__main__":
    sys.exit(main())
