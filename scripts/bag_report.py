#!/usr/bin/python3
"""Summarises a fem_cloth bag and renders what happened in it.

    bag_report.py RUN.bag [--out DIR] [--snapshots N] [--node /fem_cloth_node]

Prints the simulated duration, the real-time factor, the energies at the start and the end,
and writes to DIR:
  snapshots.png  N views of the cloth over the run, shaded and coloured by strain
                 (largest principal stretch - 1 of each triangle, computed here from the
                 recorded rest mesh and positions)
  energy.png     kinetic, strain, gravity, total, pin and contact work and the energy-balance
                 error over time (balance error = total - the five works + dissipated - initial
                 total, every term from ClothEnergy)

Runs with Debian's /usr/bin/python3 (python3-rosbag, python3-matplotlib, python3-numpy).
Exit status: 0; 2 on bad input (a missing, unreadable or damaged bag, one without a mesh or
states, states that do not fit the mesh or hold non-finite positions, an output folder that
cannot be made); 3 on an unexpected error. Every error is one line on stderr. The pictures are
written next to their names and renamed when complete.
"""
import argparse
import contextlib
import io
import os
import sys
import types

try:
    import numpy as np
    import rosbag
except ImportError as e:  # pragma: no cover - depends on the machine
    sys.exit(f"bag_report.py: {e}; install python3-rosbag and python3-numpy "
             "(scripts/install-deps) and run with /usr/bin/python3")


class BadInput(Exception):
    """A problem with the bag or the options: exit status 2."""


# The work terms of ClothEnergy's balance. A bag recorded before contact_work, air_work,
# live_work and initial_total were in the message (its energies are read with the definition
# stored in the bag) has none of them: the works read as 0 there, initial_total as None.
WORKS = ("external_work", "pin_work", "contact_work", "air_work", "live_work")
NEWER = ("contact_work", "air_work", "live_work")


def energy_record(msg):
    """The fields of a ClothEnergy this report uses, read while the bag is (a definition without
    one of the older fields is a damaged bag: bad input)."""
    e = {f: getattr(msg, f) for f in ("kinetic", "strain", "gravity", "total", "external_work",
                                      "pin_work", "dissipated", "balance_error")}
    e.update({f: getattr(msg, f, 0.0) for f in NEWER})
    e["initial_total"] = getattr(msg, "initial_total", None)
    e["stamp"] = msg.header.stamp.to_sec()
    return types.SimpleNamespace(**e)


def recomputed_balance(e):
    """ClothEnergy's balance error from its own fields (None for a message without initial_total)."""
    if e.initial_total is None:
        return None
    return e.total - sum(getattr(e, w) for w in WORKS) + e.dissipated - e.initial_total


def read_bag(path, node):
    mesh, states, energies, stats = None, [], [], []
    # rosbag prints its own warnings to stderr (a definition it cannot parse): not a second line.
    try:
        with contextlib.redirect_stderr(io.StringIO()), rosbag.Bag(path) as bag:
            for topic, msg, _ in bag.read_messages(topics=[node + "/mesh", node + "/state",
                                                           node + "/energy", node + "/stats"]):
                if topic.endswith("/mesh") and mesh is None:
                    mesh = msg
                elif topic.endswith("/state"):
                    states.append((msg.header.stamp.to_sec(), msg.step,
                                   np.array([[p.x, p.y, p.z] for p in msg.positions], dtype=float)))
                elif topic.endswith("/energy"):
                    energies.append(energy_record(msg))
                elif topic.endswith("/stats"):
                    stats.append((msg.real_time_factor, msg.wall_time))
    except Exception as e:  # noqa: BLE001 - rosbag, genpy, struct and lz4 errors of a damaged bag
        raise BadInput(f"cannot read bag '{path}': {type(e).__name__}: {e}")
    return mesh, states, energies, stats


def check_run(path, mesh, states):
    """The states must fit the mesh: the renderer indexes their positions by its triangles."""
    n = len(mesh.vertices)
    if n == 0 or not mesh.triangles:
        raise BadInput(f"{path}: the mesh holds no vertices or no triangles")
    for t in mesh.triangles:
        if max(t.vertex_indices) >= n:
            raise BadInput(f"{path}: a mesh triangle names vertex {max(t.vertex_indices)} of {n}")
    for _, step, x in states:
        if x.shape != (n, 3):
            raise BadInput(f"{path}: the state of step {step} has {len(x)} vertices, the mesh {n}")
        if not np.isfinite(x).all():
            raise BadInput(f"{path}: the state of step {step} has non-finite positions")


def save(fig, path):
    """Writes the figure next to its name, then renames it: no half-written picture."""
    partial = f"{path}.partial-{os.getpid()}"
    try:
        fig.savefig(partial, format="png", dpi=110)
        os.replace(partial, path)
    finally:
        if os.path.exists(partial):
            os.remove(partial)


def triangle_strains(rest, tris, x):
    """s1 - 1 per triangle, s1 the largest singular value of F = Ds Dm^-1."""
    X0, X1, X2 = rest[tris[:, 0]], rest[tris[:, 1]], rest[tris[:, 2]]
    e1, e2 = X1 - X0, X2 - X0
    l1 = np.linalg.norm(e1, axis=1)
    a = np.einsum("ij,ij->i", e1, e2) / l1
    b = np.linalg.norm(np.cross(e1, e2), axis=1) / l1
    d1, d2 = x[tris[:, 1]] - x[tris[:, 0]], x[tris[:, 2]] - x[tris[:, 0]]
    # Dm = [[l1, a], [0, b]], so F = [d1 / l1, (d2 - a d1 / l1) / b].
    f1 = d1 / l1[:, None]
    f2 = (d2 - a[:, None] * f1) / b[:, None]
    c11 = np.einsum("ij,ij->i", f1, f1)
    c22 = np.einsum("ij,ij->i", f2, f2)
    c12 = np.einsum("ij,ij->i", f1, f2)
    lam = 0.5 * (c11 + c22) + np.sqrt(0.25 * (c11 - c22) ** 2 + c12 ** 2)
    return np.sqrt(lam) - 1.0


def render(mesh, states, out, count, strain_max=0.05):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    rest = np.array([[p.x, p.y, p.z] for p in mesh.vertices])
    tris = np.array([t.vertex_indices for t in mesh.triangles], dtype=int)
    picks = np.linspace(0, len(states) - 1, count).round().astype(int)
    all_x = np.concatenate([states[i][2] for i in picks])
    lo, hi = all_x.min(axis=0), all_x.max(axis=0)
    centre, half = 0.5 * (lo + hi), 0.5 * max((hi - lo).max(), 1e-3)
    cmap = plt.get_cmap("coolwarm")
    light = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    cols = min(count, 3)
    rows = (count + cols - 1) // cols
    fig = plt.figure(figsize=(4.2 * cols, 4.0 * rows))
    for k, i in enumerate(picks):
        t, step, x = states[i]
        ax = fig.add_subplot(rows, cols, k + 1, projection="3d")
        strain = triangle_strains(rest, tris, x)
        colours = cmap(np.clip(strain / strain_max, 0.0, 1.0) * 0.5 + 0.5)
        n = np.cross(x[tris[:, 1]] - x[tris[:, 0]], x[tris[:, 2]] - x[tris[:, 0]])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
        shade = 0.45 + 0.55 * np.abs(n @ light)  # two-sided
        colours[:, :3] *= shade[:, None]
        poly = Poly3DCollection(x[tris], facecolors=colours, edgecolors="none")
        ax.add_collection3d(poly)
        for axis, c in zip("xyz", centre):
            getattr(ax, f"set_{axis}lim")(c - half, c + half)
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=18, azim=-60)
        ax.set_title(f"t = {t - states[0][0]:.2f} s   max strain {100 * strain.max():.1f} %",
                     fontsize=9)
        ax.set_xlabel("x (m)", fontsize=7)
        ax.set_ylabel("y (m)", fontsize=7)
        ax.set_zlabel("z (m)", fontsize=7)
        ax.tick_params(labelsize=6)
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(-strain_max, strain_max))
    cbar = fig.colorbar(sm, ax=fig.axes, shrink=0.6, pad=0.05)
    cbar.set_label("strain: largest principal stretch - 1 (compression shows as 0)")
    path = os.path.join(out, "snapshots.png")
    save(fig, path)
    plt.close(fig)
    return path


def plot_energy(energies, out):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t0 = energies[0].stamp
    t = np.array([e.stamp - t0 for e in energies])
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for field, style in [("kinetic", "-"), ("strain", "-"), ("gravity", "-"),
                         ("total", "k-"), ("pin_work", "--"), ("contact_work", "--"),
                         ("dissipated", ":"), ("balance_error", "r-")]:
        ax.plot(t, [getattr(e, field) for e in energies], style, label=field.replace("_", " "))
    ax.set_xlabel("simulated time (s)")
    ax.set_ylabel("energy (J)")
    ax.set_title("Energies; balance error = total - works + dissipated - initial total", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    path = os.path.join(out, "energy.png")
    fig.tight_layout()
    save(fig, path)
    plt.close(fig)
    return path


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("bag")
    parser.add_argument("--out", default=".")
    parser.add_argument("--snapshots", type=int, default=6)
    parser.add_argument("--node", default="/fem_cloth_node")
    args = parser.parse_args()
    if not os.path.isfile(args.bag):
        raise BadInput(f"no such bag: {args.bag}")
    try:
        os.makedirs(args.out, exist_ok=True)
    except OSError as e:
        raise BadInput(f"cannot create the output folder '{args.out}': {e}")
    mesh, states, energies, stats = read_bag(args.bag, args.node)
    if mesh is None or not states:
        raise BadInput(f"{args.bag} has no {args.node}/mesh or {args.node}/state")
    check_run(args.bag, mesh, states)
    duration = states[-1][0] - states[0][0]
    rtf = [factor for factor, _ in stats if factor > 0]
    step_ms = [1e3 * wall for _, wall in stats if wall > 0]
    print(f"cloth:        {len(mesh.vertices)} vertices, {len(mesh.triangles)} triangles")
    print(f"duration:     {duration:.2f} s simulated, {len(states)} states "
          f"(steps {states[0][1]} to {states[-1][1]})")
    if rtf:
        print(f"real time:    real-time factor {np.median(rtf):.2f} (median; "
              f"{min(rtf):.2f} to {max(rtf):.2f}), a step takes {np.median(step_ms):.2f} ms")
    if energies:
        for label, e in (("start", energies[0]), ("end", energies[-1])):
            print(f"energy {label:5s} kinetic {e.kinetic:.4g} J, strain {e.strain:.4g} J, "
                  f"gravity {e.gravity:.4g} J, total {e.total:.4g} J; work: "
                  + ", ".join(f"{w.replace('_work', '')} {getattr(e, w):.4g} J" for w in WORKS)
                  + f"; dissipated {e.dissipated:.4g} J, balance error {e.balance_error:.3g} J"
                  + ("" if recomputed_balance(e) is None
                     else f" (from the terms above: {recomputed_balance(e):.3g} J)"))
        if energies[-1].initial_total is None:
            print("energy:       recorded with the ClothEnergy of before contact, air and live-change work "
                  "were in it: those works are missing from the lines above (re-simulate the bag with "
                  "fem_cloth_sim --commands --out to get them)")
        print(f"wrote:        {plot_energy(energies, args.out)}")
    print(f"wrote:        {render(mesh, states, args.out, max(1, args.snapshots))}")


if __name__ == "__main__":
    try:
        main()
    except BadInput as e:
        print(f"bag_report.py: {e}", file=sys.stderr)
        sys.exit(2)
    except Exception as e:  # noqa: BLE001 - the last line of defence: one line, not a traceback
        print(f"bag_report.py: unexpected error: {type(e).__name__}: {e}", file=sys.stderr)
        sys.exit(3)
