#!/usr/bin/python3
"""Re-makes the synthetic recording fem_cloth_fit's test and docs/fitting.md fit:
test/data/fit/grasp_markers.bag.

The commands of test/data/small_grasp.bag (the small test cloth grasped and lifted by
fem_cloth_grasp_demo) are re-simulated by fem_cloth_sim --commands with the parameters of
truth.yaml (on the commands bag's scene with truth.yaml's scene changes); a motion-capture marker set is then "seen" on that run: markers on every
grid_step-th row and column of the grid, in a frame of their own (placed by a /tf_static
transform), each coordinate with Gaussian noise, some markers missing (NaN) in some frames. The
recording holds the commands bag's topics (scene, mesh, applied pins, tf) without its states
(~state is not an observation) and the markers on /mocap/markers.

  test/data/fit/make_recording.py [--sim PATH] [--out FILE.bag]
  test/data/fit/make_recording.py --depth --out FILE.bag     (the depth-camera recording)

Needs a built fem_cloth_sim (scripts/test builds it).
"""
import argparse
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(HERE)))
sys.path.insert(0, os.path.join(ROOT, "src"))

from fem_cloth.batch.batch import find_program  # noqa: E402
from fem_cloth.fit.data import NODE, _rotation  # noqa: E402

COMMANDS = os.path.join(ROOT, "test", "data", "small_grasp.bag")
MARKERS_TOPIC = "/mocap/markers"


def truth():
    with open(os.path.join(HERE, "truth.yaml"), encoding="utf-8") as f:
        return yaml.safe_load(f)


def truth_values(spec):
    """The fitted parameters' true values: truth.yaml's scene keys outside its sections."""
    return {k: v for k, v in spec.items() if k not in ("markers", "scene", "depth")}


def simulate(sim, commands, values, out):
    argv = [sim, "--commands", commands, "--quiet", "--out", out]
    for key, value in values.items():
        argv += ["--set", f"{key}={value!r}"]
    subprocess.run(argv, check=True, stdout=subprocess.DEVNULL)


def base_scene(sim, bag, changes, out):
    """The commands bag's scene with `changes` (scene key: value) applied, as a file and as text."""
    from std_msgs.msg import String
    recorded = next(msg for _, msg, _ in bag.read_messages(topics=[f"{NODE}/scene"]))
    with open(out + ".recorded", "w", encoding="utf-8") as f:
        f.write(recorded.data)
    argv = [sim, "--scene", out + ".recorded", "--check", "--write-scene", out]
    for key, value in changes.items():
        argv += ["--set", f"{key}={value}"]
    subprocess.run(argv, check=True, stdout=subprocess.DEVNULL)
    with open(out, encoding="utf-8") as f:
        return String(f.read())


def run_start(states, dt=0.01):
    """The ROS time of step 0 of a recorded run (dt: the commands bag's integrator.dt). A node
    started paused publishes its step-0 state when it starts, but its time origin moves to the
    moment it is resumed (docs/node.md, Time): the first state after step 0 tells when that was,
    its stamp less its steps' time. Without one, the step-0 state's stamp."""
    import rospy
    first = None
    for state in states:
        first = first or state
        if state.step > 0:
            return state.header.stamp - rospy.Duration.from_sec(state.step * dt)
    return first.header.stamp


def write_commands(sim, out, scene_changes, scene_path):
    """The commands of small_grasp.bag without its states, starting where its run started: the
    node was started paused, and a replay of a bag without states starts at its first message
    (scene, mesh and /tf_static are moved to that time, /tf keeps its last message before it)."""
    import rosbag
    with rosbag.Bag(COMMANDS) as source, rosbag.Bag(out, "w", compression="lz4") as bag:
        start = run_start(msg for _, msg, _ in source.read_messages(topics=[f"{NODE}/state"]))
        scene = base_scene(sim, source, scene_changes, scene_path)
        last_tf = None
        for topic, msg, t in source.read_messages():
            if topic == f"{NODE}/state":
                continue
            if topic == f"{NODE}/scene":
                msg = scene
            if t < start and topic == "/tf":
                last_tf = msg
                continue
            if last_tf is not None and t >= start:
                bag.write("/tf", last_tf, start)
                last_tf = None
            bag.write(topic, msg, max(t, start))


def marker_cloud(stamp, frame, vertices, points):
    from sensor_msgs import point_cloud2
    from sensor_msgs.msg import PointField
    from std_msgs.msg import Header
    fields = [PointField("x", 0, PointField.FLOAT32, 1), PointField("y", 4, PointField.FLOAT32, 1),
              PointField("z", 8, PointField.FLOAT32, 1), PointField("vertex", 12, PointField.UINT32, 1)]
    header = Header(stamp=stamp, frame_id=frame)
    return point_cloud2.create_cloud(header, fields, [(*p, int(v)) for v, p in zip(vertices, points)])


def static_frame(parent, child, position, rotation, stamp):
    from geometry_msgs.msg import TransformStamped
    from tf2_msgs.msg import TFMessage
    t = TransformStamped()
    t.header.stamp, t.header.frame_id, t.child_frame_id = stamp, parent, child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = position
    r = t.transform.rotation
    r.x, r.y, r.z, r.w = rotation
    return TFMessage([t])


def camera_pose(position, look_at):
    """The optical frame looking from position at look_at with the simulation's +z up in the image
    (docs/perception.md): columns x (right), y (down), z (forward) in the simulation frame."""
    position, look_at = np.asarray(position, float), np.asarray(look_at, float)
    z = (look_at - position) / np.linalg.norm(look_at - position)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z]), position


def quaternion(r):
    """x y z w of a rotation matrix (its trace is > -1 for the poses used here)."""
    w = 0.5 * np.sqrt(1.0 + np.trace(r))
    return [(r[2, 1] - r[1, 2]) / (4 * w), (r[0, 2] - r[2, 0]) / (4 * w), (r[1, 0] - r[0, 1]) / (4 * w), w]


def depth_recording(sim, render, out, tmp):
    """The depth-camera recording: the truth run (states at the camera's rate) rendered by
    fem_cloth_render (the node's camera renderer, 16-bit millimetres) from the fixed camera of
    truth.yaml's depth section, with the perception module's noise model (sigma(z) = a + b z^2,
    dropout; docs/perception.md) drawn here, as 32FC1 images with their CameraInfo; the camera's
    optical frame on /tf_static."""
    import rosbag
    from matplotlib import image as mpimg
    from sensor_msgs.msg import CameraInfo, Image
    spec = truth()
    d = spec["depth"]
    values = truth_values(spec)
    commands = os.path.join(tmp, "commands.bag")
    write_commands(sim, commands, spec["scene"], os.path.join(tmp, "scene.yaml"))
    run = os.path.join(tmp, "truth.bag")
    dt = 0.01  # the commands bag's integrator.dt
    subprocess.run([sim, "--commands", commands, "--quiet", "--out", run, "--every", str(round(1 / (d["fps"] * dt)))]
                   + [a for k, v in values.items() for a in ("--set", f"{k}={v!r}")], check=True,
                   stdout=subprocess.DEVNULL)
    view = os.path.join(tmp, "view.yaml")
    with open(view, "w", encoding="utf-8") as f:
        yaml.safe_dump({"camera": {"frame_id": "fit_camera", "pose": {"position": d["position"], "look_at": d["look_at"]},
                                   "width": d["width"], "height": d["height"], "horizontal_fov": d["horizontal_fov"],
                                   "min_range": 0.1, "max_range": 8.0}}, f)
    frames = os.path.join(tmp, "frames")
    subprocess.run([render, run, "--out", frames, "--view", view, "--fps", str(d["fps"]), "--depth", "--quiet"],
                   check=True, stdout=subprocess.DEVNULL)
    every = round(1 / (d["fps"] * dt))
    with rosbag.Bag(run) as bag:  # the last state of the run is written too, off the camera's rate
        states = [msg for _, msg, _ in bag.read_messages(topics=[f"{NODE}/state"]) if msg.step % every == 0]
    pictures = sorted(n for n in os.listdir(frames) if n.startswith("depth_"))
    if len(pictures) != len(states):
        raise SystemExit(f"{len(pictures)} depth frames for {len(states)} states")
    fx = 0.5 * d["width"] / np.tan(0.5 * d["horizontal_fov"])
    info = CameraInfo(width=d["width"], height=d["height"], distortion_model="plumb_bob", D=[0.0] * 5,
                      K=[fx, 0, 0.5 * (d["width"] - 1), 0, fx, 0.5 * (d["height"] - 1), 0, 0, 1],
                      R=[1, 0, 0, 0, 1, 0, 0, 0, 1],
                      P=[fx, 0, 0.5 * (d["width"] - 1), 0, 0, fx, 0.5 * (d["height"] - 1), 0, 0, 0, 1, 0])
    info.header.frame_id = "fit_camera"
    rotation, position = camera_pose(d["position"], d["look_at"])
    noise = d["noise"]
    rng = np.random.default_rng(noise["seed"])
    shutil.copy(commands, out)
    with rosbag.Bag(out, "a") as bag:
        first = states[0].header.stamp
        bag.write("/tf_static", static_frame(states[0].header.frame_id, "fit_camera", position,
                                             quaternion(rotation), first), first)
        for state, name in zip(states, pictures):
            millimetres = np.rint(mpimg.imread(os.path.join(frames, name)) * 65535.0)
            z = np.where(millimetres > 0, millimetres / 1000.0, np.nan)
            z = z + rng.normal(0.0, 1.0, z.shape) * (noise["a"] + noise["b"] * z * z)
            z[rng.random(z.shape) < noise["dropout"]] = np.nan
            image = Image(height=d["height"], width=d["width"], encoding="32FC1", is_bigendian=0,
                          step=4 * d["width"], data=z.astype("<f4").tobytes())
            image.header.stamp, image.header.frame_id = state.header.stamp, "fit_camera"
            info.header.stamp = state.header.stamp
            bag.write("/camera/depth/image", image, state.header.stamp)
            bag.write("/camera/depth/camera_info", info, state.header.stamp)
    return len(states)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sim", help="fem_cloth_sim (default: this tree's build)")
    parser.add_argument("--out", default=os.path.join(HERE, "grasp_markers.bag"))
    parser.add_argument("--depth", action="store_true", help="the depth-camera recording instead "
                        "(the test makes it; about 1 MB), to --out")
    args = parser.parse_args()
    if args.depth:
        with tempfile.TemporaryDirectory() as tmp:
            frames = depth_recording(find_program("fem_cloth_sim", args.sim), find_program("fem_cloth_render"),
                                     args.out, tmp)
        print(f"{args.out}: {frames} depth frames")
        return
    import rosbag
    spec = truth()
    m = spec["markers"]
    values = truth_values(spec)
    rng = np.random.default_rng(m["seed"])
    sim = find_program("fem_cloth_sim", args.sim)
    with tempfile.TemporaryDirectory() as tmp:
        commands = os.path.join(tmp, "commands.bag")
        write_commands(sim, commands, spec["scene"], os.path.join(tmp, "scene.yaml"))
        run = os.path.join(tmp, "truth.bag")
        simulate(sim, commands, values, run)
        with rosbag.Bag(run) as bag:
            states = [msg for _, msg, _ in bag.read_messages(topics=[f"{NODE}/state"])]
            mesh = next(msg for _, msg, _ in bag.read_messages(topics=[f"{NODE}/mesh"]))
        shutil.copy(commands, args.out)
    cols = int(round(np.sqrt(len(mesh.vertices))))  # the square test grid
    grid = range(0, cols, m["grid_step"])
    vertices = np.array([r * cols + c for r in grid for c in grid])
    rotation = _rotation(*m["frame_rotation"])
    position = np.array(m["frame_position"])
    sim_frame = states[0].header.frame_id
    with rosbag.Bag(args.out, "a") as out:
        first = states[0].header.stamp
        out.write("/tf_static", static_frame(sim_frame, m["frame"], position, m["frame_rotation"], first), first)
        for state in states:
            if state.step % m["every"]:
                continue
            p = np.array([(q.x, q.y, q.z) for q in state.positions])[vertices]
            seen = (p - position) @ rotation  # p_mocap = R^T (p_sim - t)
            seen += rng.normal(0.0, m["noise"], seen.shape)
            seen[rng.random(len(vertices)) < m["lost"]] = np.nan
            out.write(MARKERS_TOPIC, marker_cloud(state.header.stamp, m["frame"], vertices, seen),
                      state.header.stamp)
    print(f"{args.out}: {len(vertices)} markers, {sum(1 for s in states if s.step % m['every'] == 0)} frames")


if __name__ == "__main__":
    main()
