#!/usr/bin/env python3
"""Does the node keep up with real time? Runs fem_cloth_node on a roscore of its own (a free
port), subscribes to ~state and ~stats the way a robot stack would, and prints what it measured
over a window of wall time:

  - ~state messages per second received (against the requested publish rate),
  - lag = arrival wall time - header stamp (simulation time; the node runs in real_time mode, so
    simulation time is wall time): its mean, maximum and its trend in ms per second - a node that
    falls behind shows a lag that keeps growing,
  - the share of real time the node spent stepping (sum of ~stats.wall_time / window).

A benchmark, not a test: it prints figures and a verdict and exits 0 unless the node failed to run.

  bench_node.py [--rows 129] [--seconds 20] [--rate 60] [--iterations N]
                [--scene config/hanging_cloth_fast.yaml] [--node PATH] [--set KEY=VALUE ...]

--iterations sets integrator.iterations (projective dynamics and XPBD only; the scene's own
value when not given); --set passes any other scene key as the node's parameter (for example
--set integrator.name=backward_euler --set material.model=stvk).

The ~state messages are taken as raw bytes (rospy.AnyMsg): decoding 16641 Points 60 times a
second in Python would cost more CPU than the simulation and disturb what is measured.
"""
import argparse
import os
import struct
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "scripts", "lib"))
import roscore  # noqa: E402  (the one way the scripts start a roscore)


def slope(xs, ys):
    n = len(xs)
    if n < 2:
        return 0.0
    mx, my = sum(xs) / n, sum(ys) / n
    sxx = sum((x - mx) ** 2 for x in xs)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx if sxx > 0 else 0.0


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rows", type=int, default=129, help="grid rows = cols (default 129)")
    parser.add_argument("--seconds", type=float, default=20.0, help="measured wall time (s)")
    parser.add_argument("--rate", type=float, default=60.0, help="publish_rate (Hz)")
    parser.add_argument("--iterations", type=int, default=None,
                        help="integrator.iterations (projective_dynamics, xpbd; default: the scene's)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="a scene key for the node, e.g. integrator.name=backward_euler (repeatable)")
    parser.add_argument("--scene", default=os.path.join(ROOT, "config", "hanging_cloth_fast.yaml"))
    parser.add_argument("--node", default=None, help="the fem_cloth_node binary")
    parser.add_argument("--log-dir", default=None, help="where roscore and node logs go")
    args = parser.parse_args()

    node_bin = args.node or os.path.join(
        os.environ.get("FEM_CLOTH_BUILD", os.path.join(ROOT, "catkin_build")),
        "devel", "lib", "fem_cloth", "fem_cloth_node")
    if not os.path.exists(node_bin):
        sys.exit("bench_node: no node binary at %s (build it first: scripts/bench builds it)" % node_bin)
    log_dir = args.log_dir or os.path.join(ROOT, "output", "bench", "node_logs")
    os.makedirs(log_dir, exist_ok=True)

    core = node = None
    try:
        try:
            core, port = roscore.start(log_dir)
        except RuntimeError as e:
            sys.exit("bench_node: %s" % e)
        env = dict(os.environ)
        env["ROS_MASTER_URI"] = "http://127.0.0.1:%d" % port
        env["ROS_LOG_DIR"] = log_dir
        env["ROS_HOME"] = log_dir
        os.environ.update(env)

        command = [node_bin, "__name:=cloth", "_scene_file:=" + args.scene,
                   "_mesh/rows:=%d" % args.rows, "_mesh/cols:=%d" % args.rows,
                   "_publish_rate:=%g" % args.rate]
        if args.iterations is not None:
            command.append("_integrator/iterations:=%d" % args.iterations)
        for item in args.set:
            key, sep, value = item.partition("=")
            if not sep or not key:
                sys.exit("bench_node: --set wants KEY=VALUE, got %r" % item)
            command.append("_%s:=%s" % (key.replace(".", "/"), value))
        print("== %s" % " ".join(os.path.relpath(c, ROOT) if c.startswith(ROOT) else c for c in command))
        node = subprocess.Popen(command, env=env, start_new_session=True,
                                stdout=open(os.path.join(log_dir, "node.log"), "w"),
                                stderr=subprocess.STDOUT)

        import rospy
        from fem_cloth.msg import StepStats
        rospy.init_node("bench_node", anonymous=True, disable_signals=True)
        arrivals = []  # (wall arrival, stamp)
        stats = []     # (wall arrival, wall_time, real_time_factor, integrator, dt)
        measuring = [False]

        def on_state(raw):
            now = time.time()
            # std_msgs/Header leads the message: uint32 seq, uint32 secs, uint32 nsecs.
            _, secs, nsecs = struct.unpack_from("<III", raw._buff, 0)
            if measuring[0]:
                arrivals.append((now, secs + 1e-9 * nsecs))

        def on_stats(msg):
            if measuring[0]:
                stats.append((time.time(), msg.wall_time, msg.real_time_factor, msg.integrator, msg.dt))

        rospy.Subscriber("/cloth/state", rospy.AnyMsg, on_state, queue_size=100, tcp_nodelay=True)
        rospy.Subscriber("/cloth/stats", StepStats, on_stats, queue_size=100)

        # Start-up (mesh, factorisation) ends with the first published state.
        first = time.time()
        started = [False]

        def first_state(_):
            started[0] = True
        probe = rospy.Subscriber("/cloth/state", rospy.AnyMsg, first_state, queue_size=1)
        while not started[0]:
            if node.poll() is not None:
                sys.exit("bench_node: the node exited (status %d); see %s/node.log"
                         % (node.returncode, log_dir))
            if time.time() - first > 60:
                sys.exit("bench_node: no ~state within 60 s; see %s/node.log" % log_dir)
            time.sleep(0.05)
        probe.unregister()
        print("   first state after %.2f s; settling 2 s, then measuring %.0f s" % (time.time() - first, args.seconds))
        time.sleep(2.0)
        measuring[0] = True
        t0 = time.time()
        while time.time() - t0 < args.seconds:
            if node.poll() is not None:
                sys.exit("bench_node: the node exited during the run (status %d); see %s/node.log"
                         % (node.returncode, log_dir))
            time.sleep(0.1)
        measuring[0] = False
        window = time.time() - t0
    finally:
        roscore.stop(node)
        roscore.stop(core)

    if len(arrivals) < 2:
        sys.exit("bench_node: too few ~state messages (%d) to measure" % len(arrivals))
    lags = [a - s for a, s in arrivals]
    rate = (len(arrivals) - 1) / (arrivals[-1][0] - arrivals[0][0])
    trend = slope([a for a, _ in arrivals], lags)  # s of lag per s
    busy = sum(s[1] for s in stats) / window
    simulated = arrivals[-1][1] - arrivals[0][1]
    elapsed = arrivals[-1][0] - arrivals[0][0]
    integrator = stats[-1][3] if stats else "?"
    dt = stats[-1][4] if stats else float("nan")
    settings = "".join(", %s" % s for s in args.set)
    if args.iterations is not None:
        settings += ", %d iterations" % args.iterations
    print("node, %dx%d cloth (%d vertices), %s%s, dt %.4g s, publish_rate %g Hz, %.0f s measured"
          % (args.rows, args.rows, args.rows * args.rows, integrator, settings, dt, args.rate, window))
    print("  ~state received          %.1f /s (requested %g)" % (rate, args.rate))
    print("  simulated / wall time    %.3f" % (simulated / elapsed))
    print("  lag (arrival - stamp)    mean %.1f ms, first %.1f ms, last %.1f ms, max %.1f ms"
          % (1e3 * sum(lags) / len(lags), 1e3 * lags[0], 1e3 * lags[-1], 1e3 * max(lags)))
    print("  lag trend                %+.2f ms per s" % (1e3 * trend))
    print("  time spent stepping      %.0f %% of real time" % (100 * busy))
    keeps_up = trend < 2e-3 and simulated / elapsed > 0.98 and rate > 0.95 * args.rate
    print("  verdict: %s" % ("keeps up with real time" if keeps_up else "FALLS BEHIND real time"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
