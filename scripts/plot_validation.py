#!/usr/bin/env python3
"""Plots and tables of the physical validation (scripts/validate runs it).

    plot_validation.py OUT_DIR [--docs DOCS_DIR]

Reads the CSV files fem_cloth_validate wrote to OUT_DIR, writes validation_convergence.png,
validation_peirce.png and tables.md there; with --docs also copies the figures to
DOCS_DIR/images/ and replaces the generated blocks of DOCS_DIR/validation.md and
DOCS_DIR/bending.md (between their BEGIN/END markers).
"""
import argparse
import csv
import math
import os
import re
import shutil
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read(path):
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        for key in ("cells", "dt", "value", "reference", "error", "tolerance", "residual"):
            r[key] = float(r[key]) if r[key] != "" else float("nan")
        r["cells"] = int(r["cells"])
        r["order"] = float(r["order"]) if r["order"] not in ("", None) else float("nan")
    return rows


def pct(x):
    return "n/a" if math.isnan(x) else f"{100 * x:+.3g} %"


def err(r):
    """The row's error, or "not converged": a solve that failed has no value to compare."""
    return "not converged" if r["status"] == "NOT CONVERGED" else pct(r["error"])


def resid(r):
    """A static row's force residual / largest nodal load (dynamic rows have none)."""
    return f"{r['residual']:.2g}" if r["residual"] > 0 else ""


def series(rows, **match):
    """(cells, |error|) of the rows matching every key, sorted by cells."""
    pts = [(r["cells"], abs(r["error"])) for r in rows
           if r["status"] != "NOT CONVERGED" and all(r[k] == v for k, v in match.items())]
    return sorted(p for p in pts if p[0] > 0 and p[1] > 0)


def convergence_figure(rows, path):
    fig, ax = plt.subplots(figsize=(7, 4.8))
    curves = [
        ("Peirce strip, gamma 1", dict(validation="peirce", parameter="gamma=1", quantity="tip drop / l")),
        ("Peirce strip, gamma 8", dict(validation="peirce", parameter="gamma=8", quantity="tip drop / l")),
        ("Peirce strip, gamma 20", dict(validation="peirce", parameter="gamma=20", quantity="tip drop / l")),
        ("clamped plate", dict(validation="plate_clamped")),
        ("simply supported plate", dict(validation="plate_simply")),
        ("clamped strip (beam)", dict(validation="beam_clamped")),
        ("pendulum period", dict(validation="pendulum")),
        ("hanging sheet, worst row", dict(validation="hanging_sheet", quantity="worst row's strain error / top strain")),
    ]
    for label, match in curves:
        pts = series(rows, **match)
        if pts:
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", label=label)
    ns = [8, 64]
    ax.loglog(ns, [0.5 * (8 / n) ** 2 for n in ns], "k--", lw=0.8, label="slope 2")
    ax.axhline(0.03, color="grey", lw=0.8, ls=":")
    ax.text(8.2, 0.032, "3 %", color="grey")
    ax.set_xlabel("cells along the governing length")
    ax.set_ylabel("|relative error| against the closed form")
    ax.set_title("fem_cloth (midedge bending) against closed forms")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def peirce_figure(out, rows, path):
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4.2))
    drops = [r for r in rows if r["validation"] == "peirce" and r["quantity"] == "tip drop / l"]
    ref = sorted({(float(r["parameter"].split("=")[1]), r["reference"]) for r in drops})
    a.plot([g for g, _ in ref], [d for _, d in ref], "k-", label="heavy elastica")
    models = {"midedge": rows, "quadratic": read(os.path.join(out, "peirce_quadratic.csv")),
              "dihedral": read(os.path.join(out, "peirce_dihedral.csv"))}
    for name, model_rows in models.items():
        pts = sorted((float(r["parameter"].split("=")[1]), r["value"], r["error"]) for r in model_rows
                     if r["validation"] == "peirce" and r["quantity"] == "tip drop / l" and r["cells"] == 16
                     and r["status"] != "NOT CONVERGED")
        if pts:
            a.plot([p[0] for p in pts], [p[1] for p in pts], "o", label=f"{name}, 16 cells")
            b.plot([p[0] for p in pts], [100 * p[2] for p in pts], "o-", label=name)
    a.set_xscale("log")
    a.set_xlabel("gamma = w l^3 / B")
    a.set_ylabel("tip drop / overhang")
    a.legend(fontsize=8)
    b.set_xscale("log")
    b.axhspan(-3, 3, color="green", alpha=0.1)
    b.set_xlabel("gamma = w l^3 / B")
    b.set_ylabel("tip drop error at 16 cells (%)")
    b.legend(fontsize=8)
    fig.suptitle("Peirce's cantilever (25 mm strip) against the heavy elastica")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def summary_table(rows):
    lines = ["| case | parameter | quantity | value | reference | error | tolerance | residual | status |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        if r["cells"] not in (0, 16):
            continue
        tol = "" if r["tolerance"] <= 0 else f"{100 * r['tolerance']:.3g} %"
        dt = f" (dt {r['dt']:g})" if r["dt"] > 0 and r["cells"] == 0 else ""
        lines.append(f"| {r['validation']} | {r['parameter']}{dt} | {r['quantity']} | {r['value']:.6g} | "
                     f"{r['reference']:.6g} | {err(r)} | {tol} | {resid(r)} | {r['status']} |")
    return "\n".join(lines)


def convergence_table(rows, validations):
    keyed = {}
    for r in rows:
        if r["validation"] in validations and r["cells"] > 0:
            keyed.setdefault((r["validation"], r["parameter"], r["quantity"]), {})[r["cells"]] = r
    cells = sorted({c for v in keyed.values() for c in v})
    lines = ["| case | parameter | quantity | " + " | ".join(f"{c} cells" for c in cells) + " | order |",
             "| --- | --- | --- | " + " | ".join("---" for _ in cells) + " | --- |"]
    for (v, p, q), by in keyed.items():
        last = by[max(by)]
        order = "" if math.isnan(last["order"]) else f"{last['order']:.2f}"
        lines.append(f"| {v} | {p} | {q} | " + " | ".join(err(by[c]) if c in by else "" for c in cells)
                     + f" | {order} |")
    return "\n".join(lines)


def models_table(out, midedge_rows):
    lines = ["| case | model | 8 cells | 16 cells | 32 cells | 64 cells |", "| --- | --- | --- | --- | --- | --- |"]
    for case, match in [("Peirce, gamma 1", dict(validation="peirce", parameter="gamma=1", quantity="tip drop / l")),
                        ("Peirce, gamma 8", dict(validation="peirce", parameter="gamma=8", quantity="tip drop / l")),
                        ("Peirce, gamma 20", dict(validation="peirce", parameter="gamma=20", quantity="tip drop / l")),
                        ("clamped plate", dict(validation="plate_clamped")),
                        ("simply supported plate", dict(validation="plate_simply"))]:
        for model in ("midedge", "quadratic", "dihedral"):
            if model == "midedge":
                rows = midedge_rows
            else:
                rows = read(os.path.join(out, f"peirce_{model}.csv")) + read(os.path.join(out, f"plates_{model}.csv"))
            by = {r["cells"]: r for r in rows if all(r[k] == v for k, v in match.items())}
            if by:
                lines.append(f"| {case} | {model} | " + " | ".join(err(by[c]) if c in by else "" for c in (8, 16, 32, 64)) + " |")
    return "\n".join(lines)


def replace_block(path, name, text):
    begin, end = f"<!-- BEGIN {name} -->", f"<!-- END {name} -->"
    with open(path) as f:
        doc = f.read()
    if begin not in doc or end not in doc:
        sys.exit(f"plot_validation: {path} has no {begin} ... {end} block")
    doc = re.sub(re.escape(begin) + ".*?" + re.escape(end), lambda _: f"{begin}\n{text}\n{end}", doc, flags=re.S)
    with open(path, "w") as f:
        f.write(doc)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out")
    parser.add_argument("--docs")
    args = parser.parse_args()
    rows = []
    for name in ("peirce", "plates", "membrane", "pendulum", "dynamics"):
        rows += read(os.path.join(args.out, f"{name}.csv"))
    if not rows:
        sys.exit(f"plot_validation: no CSV files in {args.out}")
    convergence_figure(rows, os.path.join(args.out, "validation_convergence.png"))
    peirce_figure(args.out, rows, os.path.join(args.out, "validation_peirce.png"))
    with open(os.path.join(args.out, "machine.txt")) as f:
        machine = " ".join(line.strip() for line in f)
    tables = {
        "summary": summary_table(rows),
        "convergence": convergence_table(rows, {"peirce", "plate_clamped", "plate_simply", "beam_clamped", "pendulum", "hanging_sheet"}),
        "membrane": convergence_table(rows, {"tension"}),
        "models": models_table(args.out, rows),
    }
    dynamic = [r for r in rows if r["validation"] in ("free_fall", "incline")]
    tables["dynamics"] = "\n".join(
        ["| case | parameter | dt (s) | quantity | value | reference | error | status |",
         "| --- | --- | --- | --- | --- | --- | --- | --- |"]
        + [f"| {r['validation']} | {r['parameter']} | {r['dt']:g} | {r['quantity']} | {r['value']:.6g} | "
           f"{r['reference']:.6g} | {err(r)} | {r['status']} |" for r in dynamic])
    with open(os.path.join(args.out, "tables.md"), "w") as f:
        for name, text in tables.items():
            f.write(f"## {name}\n\n{text}\n\n")
        f.write(f"machine: {machine}\n")
    if args.docs:
        os.makedirs(os.path.join(args.docs, "images"), exist_ok=True)
        for png in ("validation_convergence.png", "validation_peirce.png"):
            shutil.copy(os.path.join(args.out, png), os.path.join(args.docs, "images", png))
        validation = os.path.join(args.docs, "validation.md")
        for name in ("summary", "convergence", "membrane", "dynamics"):
            replace_block(validation, f"validation {name}", tables[name])
        replace_block(validation, "validation machine", f"Measured on: {machine}")
        replace_block(os.path.join(args.docs, "bending.md"), "bending model comparison", tables["models"])
    print(f"plot_validation: figures and tables.md in {args.out}")


if __name__ == "__main__":
    main()
