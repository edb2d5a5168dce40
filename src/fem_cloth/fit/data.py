"""What fem_cloth_fit reads from a recording (docs/fitting.md): the observations — a marker set (a
sensor_msgs/PointCloud2 of labelled points: fields x, y, z and vertex, the mesh vertex each marker
sits on) or a depth camera (sensor_msgs/Image 32FC1 or 16UC1 with its CameraInfo; depth.py) — and the
fixed frames (/tf_static) that place them in the simulation frame. The commands that drove the
cloth stay in the bag: fem_cloth_sim --commands reads them there.

Every error names its culprit: the topic, the message (by its place and stamp), the vertex.
"""

import collections
import math

import numpy as np

NODE = "/fem_cloth_node"
DEPTH_ENCODINGS = {"32FC1": (np.float32, 1.0), "16UC1": (np.uint16, 1e-3)}  # dtype, metres per unit


class FitError(Exception):
    """A recording, scene or command line that cannot be fitted; the message names the culprit."""


def _open(path):
    import rosbag
    try:
        return rosbag.Bag(path)
    except (OSError, rosbag.ROSBagException) as error:
        raise FitError(f"cannot read the recording '{path}': {error}") from None


def _where(topic, index, stamp_ns):
    return f"{topic} message {index + 1} (stamp {stamp_ns // 1_000_000_000}.{stamp_ns % 1_000_000_000:09d} s)"


class Markers:
    """Marker frames: stamps (ns), and per frame the vertices and the observed points (metres, in
    the frame `frame_id`)."""

    kind = "markers"
    components = 3  # residuals per observed point: the marker's offset in x, y, z
    loss_name = "RMS marker distance (m)"

    def __init__(self, topic, frame_id, stamps, vertices, points):
        self.topic, self.frame_id = topic, frame_id
        self.stamps, self.vertices, self.points = stamps, vertices, points

    def __len__(self):
        return len(self.stamps)

    def count(self):
        return sum(len(v) for v in self.vertices)

    def residuals(self, states):
        """Simulated minus observed marker positions, all frames, flattened."""
        parts = [states[s][v] - p for s, v, p in zip(self.stamps, self.vertices, self.points)]
        return np.concatenate(parts).ravel()

    def check_vertices(self, vertex_count, where):
        """Every marker must sit on a vertex of the mesh the simulation runs."""
        for i, vertices in enumerate(self.vertices):
            if len(vertices) and vertices.max() >= vertex_count:
                bad = int(vertices.max())
                raise FitError(f"{_where(self.topic, i, self.stamps[i])}: marker on vertex {bad}, but "
                               f"the mesh of {where} has {vertex_count} vertices (0 to {vertex_count - 1}): "
                               f"the markers do not match the mesh")

    def transformed(self, frames, target):
        """The markers in frame `target`, through the fixed frames `frames`."""
        if self.frame_id in ("", target):
            return self
        rotation, translation = frames.transform(target, self.frame_id, self.topic)
        points = [p @ rotation.T + translation for p in self.points]
        return Markers(self.topic, target, self.stamps, self.vertices, points)


def _cloud_field(msg, name):
    for field in msg.fields:
        if field.name == name:
            return field
    return None


def read_markers(msg, topic, index, stamp_ns):
    """One marker frame: (vertices, points) from a PointCloud2 with fields x, y, z, vertex."""
    from sensor_msgs import point_cloud2
    missing = [n for n in ("x", "y", "z", "vertex") if _cloud_field(msg, n) is None]
    if missing:
        raise FitError(f"{_where(topic, index, stamp_ns)}: a marker cloud needs the fields x, y, z and "
                       f"vertex (the mesh vertex each marker sits on); missing: {', '.join(missing)} "
                       f"(a cloud from a depth camera: --cloud TOPIC with its --camera-info)")
    rows = list(point_cloud2.read_points(msg, field_names=("x", "y", "z", "vertex"), skip_nans=False))
    data = np.array(rows, dtype=np.float64).reshape(-1, 4)
    keep = np.all(np.isfinite(data[:, :3]), axis=1)  # a marker the tracker lost in this frame
    data = data[keep]
    vertex = data[:, 3]
    if np.any(vertex < 0) or np.any(vertex != np.round(vertex)):
        bad = vertex[(vertex < 0) | (vertex != np.round(vertex))][0]
        raise FitError(f"{_where(topic, index, stamp_ns)}: vertex {bad:g} is not a vertex index")
    vertices = vertex.astype(np.int64)
    if len(np.unique(vertices)) != len(vertices):
        raise FitError(f"{_where(topic, index, stamp_ns)}: two markers on the same vertex")
    return vertices, data[:, :3]


class FixedFrames:
    """The fixed transforms of the recording (/tf_static): enough to place a marker set or a fixed
    camera in the simulation frame. A frame that only /tf connects (a moving camera) is named in
    the error: it is not supported."""

    def __init__(self):
        self.edges = collections.defaultdict(dict)  # frame -> {neighbour: (R, t) of neighbour in frame}
        self.moving = set()

    def add(self, transform):
        t, q = transform.transform.translation, transform.transform.rotation
        rotation = _rotation(q.x, q.y, q.z, q.w)
        translation = np.array([t.x, t.y, t.z])
        parent, child = transform.header.frame_id.lstrip("/"), transform.child_frame_id.lstrip("/")
        # p_parent = R p_child + t, and back.
        self.edges[parent][child] = (rotation, translation)
        self.edges[child][parent] = (rotation.T, -rotation.T @ translation)

    def transform(self, target, source, who):
        """(R, t) with p_target = R p_source + t."""
        target, source = target.lstrip("/"), source.lstrip("/")
        best = {source: (np.eye(3), np.zeros(3))}
        queue = collections.deque([source])
        while queue:
            frame = queue.popleft()
            r_src, t_src = best[frame]  # p_frame = r_src p_source + t_src
            for neighbour, (r, t) in self.edges[frame].items():
                if neighbour not in best:
                    # p_neighbour = R' p_frame + t' where (R', t') is frame in neighbour
                    r_back, t_back = self.edges[neighbour][frame]
                    best[neighbour] = (r_back @ r_src, r_back @ t_src + t_back)
                    queue.append(neighbour)
        if target not in best:
            moving = " (it is on /tf: a moving frame, which fem_cloth_fit does not follow)" \
                if source in self.moving else ""
            raise FitError(f"{who}: frame '{source}' is not connected to the simulation frame '{target}' "
                           f"by /tf_static{moving}; record the fixed transform, or give the observations "
                           f"in '{target}'")
        return best[target]


def _rotation(x, y, z, w):
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if not n > 0:
        raise FitError("a /tf_static transform has a zero quaternion")
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


class Recording:
    """A recording: its path, the node whose topics it holds, its fixed frames and the observations
    found on the topic(s) given (or found by their type)."""

    def __init__(self, path, node=NODE, markers=None, depth=None, camera_info=None, cloud=None):
        self.path, self.node = path, node.rstrip("/")
        with _open(path) as bag:
            topics = bag.get_type_and_topic_info()[1]
            self.frames = FixedFrames()
            for _, msg, _ in bag.read_messages(topics=["/tf_static"]):
                for transform in msg.transforms:
                    self.frames.add(transform)
            for _, msg, _ in bag.read_messages(topics=["/tf"]):
                self.frames.moving.update(t.child_frame_id.lstrip("/") for t in msg.transforms)
            self.mesh_vertices = None
            for _, msg, _ in bag.read_messages(topics=[f"{self.node}/mesh"]):
                self.mesh_vertices = len(msg.vertices)
                break
            if markers is None and depth is None and cloud is None:
                markers, depth = self._find(topics)
            self._refuse_exact_cloud(markers or depth or cloud)
            if markers is not None:
                self.observations = self._read_markers(bag, topics, markers)
            else:
                from fem_cloth.fit import depth as camera
                self.observations = (camera.read_depth(self, bag, topics, depth, camera_info) if depth
                                     else camera.read_cloud(self, bag, topics, cloud, camera_info))

    def _find(self, topics):
        """The observation topic when none is given: the one marker cloud or depth image topic."""
        found = [(t, i.msg_type) for t, i in topics.items()
                 if i.msg_type in ("sensor_msgs/PointCloud2", "sensor_msgs/Image")
                 and t != f"{self.node}/points" and not t.startswith(f"{self.node}/camera/color")]
        if not found:
            raise FitError(f"the recording '{self.path}' has no observations: no marker cloud "
                           f"(sensor_msgs/PointCloud2 with a vertex field) and no depth image "
                           f"(sensor_msgs/Image); name the topic with --markers or --depth")
        if len(found) > 1:
            raise FitError(f"the recording '{self.path}' has several observation topics "
                           f"({', '.join(t for t, _ in sorted(found))}): choose one with --markers or --depth")
        topic, kind = found[0]
        return (topic, None) if kind == "sensor_msgs/PointCloud2" else (None, topic)

    def _refuse_exact_cloud(self, topic):
        if topic == f"{self.node}/points":
            raise FitError(f"{topic} is the node's exact vertex cloud (point k = vertex k), not an "
                           f"observation: a real camera has no such thing (give a marker set or a depth camera)")

    def _messages(self, bag, topics, topic, kind):
        if topic not in topics or topics[topic].message_count == 0:
            raise FitError(f"the recording '{self.path}' has no observations on {topic} (no messages)")
        if topics[topic].msg_type != kind:
            raise FitError(f"{topic} holds {topics[topic].msg_type}, not {kind}")
        for index, (_, msg, _) in enumerate(bag.read_messages(topics=[topic])):
            yield index, msg, msg.header.stamp.to_nsec()

    def _read_markers(self, bag, topics, topic):
        stamps, vertices, points, frame_ids = [], [], [], set()
        for index, msg, stamp in self._messages(bag, topics, topic, "sensor_msgs/PointCloud2"):
            v, p = read_markers(msg, topic, index, stamp)
            if stamps and stamp <= stamps[-1]:
                raise FitError(f"{_where(topic, index, stamp)}: stamps must increase (the one before "
                               f"has {stamps[-1] / 1e9:.9f} s)")
            stamps.append(stamp)
            vertices.append(v)
            points.append(p)
            frame_ids.add(msg.header.frame_id.lstrip("/"))
        if len(frame_ids) > 1:
            raise FitError(f"{topic}: the markers change frame ({', '.join(sorted(frame_ids))})")
        markers = Markers(topic, frame_ids.pop(), np.array(stamps, dtype=np.int64), vertices, points)
        if markers.count() == 0:
            raise FitError(f"the recording '{self.path}' has no observations: every marker on {topic} is NaN")
        if self.mesh_vertices is not None:
            markers.check_vertices(self.mesh_vertices, f"the recording ({self.node}/mesh)")
        return markers
