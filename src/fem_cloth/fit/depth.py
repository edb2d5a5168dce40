"""Depth-camera observations for fem_cloth_fit (docs/fitting.md): a sensor_msgs/Image (32FC1 metres
or 16UC1 millimetres, NaN or 0 where nothing is seen) with its CameraInfo, or a PointCloud2 made
from one (in the camera's frame), from a camera fixed in the simulation frame (/tf_static).

The observed pixels are back-projected to points (pinhole, REP-118 depth along the optical axis,
the pixel centre (i, j) at u = i, v = j as docs/perception.md gives it). A simulated run is seen
by the same camera: its mesh is rendered by a z-buffer at the image's pixel centres (a coarser
grid for large images), which keeps the triangles the camera sees; each observed point's
distance to the nearest of those visible triangles is its residual, made robust by the
pseudo-Huber transform (points off the cloth — a table, a gripper, outliers — count as sqrt of
their distance, not its square).
"""

import numpy as np

from fem_cloth.fit.data import DEPTH_ENCODINGS, FitError, _where

# At most this many observed points per frame (an even subsample of the valid pixels).
POINTS_PER_FRAME = 300
# The visibility z-buffer's largest width (pixels); larger images are seen on a coarser grid.
VISIBILITY_WIDTH = 64
# The pseudo-Huber scale (m): distances below it count as themselves, above as their root.
ROBUST_SCALE = 0.02
# Candidate triangles per point for the exact distance: the nearest by centroid.
NEAREST_TRIANGLES = 8


class Camera:
    def __init__(self, info, topic):
        k = info.K
        if not (k[0] > 0 and k[4] > 0 and info.width > 0 and info.height > 0):
            raise FitError(f"{topic}: the CameraInfo has no pinhole model (K = {list(k)}, "
                           f"{info.width} x {info.height})")
        self.fx, self.fy, self.cx, self.cy = k[0], k[4], k[2], k[5]
        self.width, self.height = info.width, info.height
        self.frame_id = info.header.frame_id.lstrip("/")


class DepthFrames:
    """Observed points per frame (metres, in the simulation frame once placed) and the camera."""

    kind = "depth"
    components = 1  # one residual per observed point: its robust distance to the surface
    loss_name = "RMS robust point-to-surface distance (m)"

    def __init__(self, topic, camera, stamps, points, triangles):
        self.topic, self.camera, self.stamps, self.points = topic, camera, stamps, points
        self.frame_id = camera.frame_id
        self.triangles = triangles
        self.rotation, self.translation = np.eye(3), np.zeros(3)  # camera in the simulation frame

    def __len__(self):
        return len(self.stamps)

    def count(self):
        return sum(len(p) for p in self.points)

    def residual_size(self):
        return self.count()

    def check_vertices(self, vertex_count, where):
        if self.triangles is not None and self.triangles.max() >= vertex_count:
            raise FitError(f"the recording's mesh has triangles on {self.triangles.max() + 1} vertices, "
                           f"but the mesh of {where} has {vertex_count}: the recording does not match the scene")

    def transformed(self, frames, target):
        placed = DepthFrames(self.topic, self.camera, self.stamps, self.points, self.triangles)
        if self.frame_id not in ("", target):
            placed.rotation, placed.translation = frames.transform(target, self.frame_id, self.topic)
        placed.points = [p @ placed.rotation.T + placed.translation for p in self.points]
        return placed

    def residuals(self, states):
        out = []
        for stamp, observed in zip(self.stamps, self.points):
            vertices = states[stamp]
            visible = visible_triangles(vertices, self.triangles, self.camera, self.rotation, self.translation)
            d = point_to_triangles(observed, vertices, self.triangles[visible])
            out.append(robust(d))
        return np.concatenate(out)


def robust(d, scale=ROBUST_SCALE):
    """The pseudo-Huber transform: r with r^2 = 2 c^2 (sqrt(1 + (d/c)^2) - 1), about d below c."""
    return np.sqrt(2.0 * scale * scale * (np.sqrt(1.0 + (d / scale) ** 2) - 1.0))


def back_project(depth, camera, stride):
    """Points (optical frame) of the valid pixels on every stride-th row and column."""
    rows, cols = np.mgrid[0:camera.height:stride, 0:camera.width:stride]
    z = depth[rows, cols]
    valid = np.isfinite(z) & (z > 0)
    z, u, v = z[valid], cols[valid], rows[valid]
    return np.column_stack([(u - camera.cx) * z / camera.fx, (v - camera.cy) * z / camera.fy, z])


def read_image(msg, topic, index, stamp):
    if msg.encoding not in DEPTH_ENCODINGS:
        raise FitError(f"{_where(topic, index, stamp)}: encoding '{msg.encoding}' is not a depth image "
                       f"(32FC1 metres or 16UC1 millimetres)")
    dtype, scale = DEPTH_ENCODINGS[msg.encoding]
    itemsize = np.dtype(dtype).itemsize
    if msg.step < msg.width * itemsize or len(msg.data) < msg.step * msg.height:
        raise FitError(f"{_where(topic, index, stamp)}: {len(msg.data)} bytes do not hold "
                       f"{msg.height} rows of {msg.width} {msg.encoding} pixels (step {msg.step})")
    order = ">" if msg.is_bigendian else "<"
    rows = np.frombuffer(bytes(msg.data[:msg.step * msg.height]), dtype=np.uint8).reshape(msg.height, msg.step)
    image = rows[:, :msg.width * itemsize].copy().view(np.dtype(dtype).newbyteorder(order))
    image = image.astype(np.float64) * scale
    if msg.encoding == "16UC1":
        image[image == 0] = np.nan
    return image


def _camera_and_mesh(recording, bag, topics, topic, camera_info):
    """The CameraInfo of the camera that saw `topic`, and the recording's mesh triangles."""
    info_topic = camera_info or topic.rsplit("/", 1)[0] + "/camera_info"
    infos = [msg for _, msg, _ in bag.read_messages(topics=[info_topic])] if info_topic in topics else []
    if not infos:
        raise FitError(f"{topic}: no CameraInfo on {info_topic} (give it with --camera-info): the "
                       f"simulated cloth is seen from the same camera")
    triangles = None
    for _, msg, _ in bag.read_messages(topics=[f"{recording.node}/mesh"]):
        triangles = np.array([t.vertex_indices for t in msg.triangles], dtype=np.int64)
    if triangles is None:
        raise FitError(f"the recording '{recording.path}' has no {recording.node}/mesh: a camera's "
                       f"points are compared with the mesh's triangles")
    return Camera(infos[0], info_topic), info_topic, triangles


def read_cloud(recording, bag, topics, topic, camera_info):
    """A point cloud made from a depth camera (PointCloud2 with x, y, z in the camera's frame, no
    correspondence to the mesh): every k-th finite point, k the same for every frame."""
    from sensor_msgs import point_cloud2
    camera, info_topic, triangles = _camera_and_mesh(recording, bag, topics, topic, camera_info)
    stamps, clouds = [], []
    for index, msg, stamp in recording._messages(bag, topics, topic, "sensor_msgs/PointCloud2"):
        if msg.header.frame_id.lstrip("/") != camera.frame_id:
            raise FitError(f"{_where(topic, index, stamp)}: frame '{msg.header.frame_id}', but the camera's "
                           f"(CameraInfo on {info_topic}) is '{camera.frame_id}'")
        points = np.array(list(point_cloud2.read_points(msg, field_names=("x", "y", "z"), skip_nans=True)),
                          dtype=np.float64).reshape(-1, 3)
        stamps.append(stamp)
        clouds.append(points)
    largest = max(len(c) for c in clouds)
    if largest == 0:
        raise FitError(f"the recording '{recording.path}' has no observations: every cloud on {topic} is empty")
    step = -(-largest // POINTS_PER_FRAME)
    return DepthFrames(topic, camera, np.array(stamps, dtype=np.int64), [c[::step] for c in clouds], triangles)


def read_depth(recording, bag, topics, topic, camera_info):
    camera, info_topic, triangles = _camera_and_mesh(recording, bag, topics, topic, camera_info)
    stamps, points = [], []
    stride = 1
    for index, msg, stamp in recording._messages(bag, topics, topic, "sensor_msgs/Image"):
        if (msg.width, msg.height) != (camera.width, camera.height):
            raise FitError(f"{_where(topic, index, stamp)}: {msg.width} x {msg.height} pixels, but the "
                           f"CameraInfo on {info_topic} says {camera.width} x {camera.height}")
        if msg.header.frame_id.lstrip("/") != camera.frame_id:
            raise FitError(f"{_where(topic, index, stamp)}: frame '{msg.header.frame_id}', but the "
                           f"CameraInfo's is '{camera.frame_id}'")
        image = read_image(msg, topic, index, stamp)
        valid = int(np.count_nonzero(np.isfinite(image)))
        while valid / (stride * stride) > POINTS_PER_FRAME:
            stride += 1  # the same stride for every frame: a fixed residual size
        stamps.append(stamp)
        points.append(image)
    if not stamps:
        raise FitError(f"the recording '{recording.path}' has no observations on {topic}")
    clouds = [back_project(image, camera, stride) for image in points]
    if sum(len(c) for c in clouds) == 0:
        raise FitError(f"the recording '{recording.path}' has no observations: every pixel on {topic} is empty")
    return DepthFrames(topic, camera, np.array(stamps, dtype=np.int64), clouds, triangles)


def visible_triangles(vertices, triangles, camera, rotation, translation):
    """Indices of the triangles the camera sees at some pixel centre of a grid at most
    VISIBILITY_WIDTH wide (a z-buffer, 1/z interpolated linearly in the image)."""
    scale = min(1.0, VISIBILITY_WIDTH / camera.width)
    local = (vertices - translation) @ rotation  # optical frame
    z = local[:, 2]
    u = camera.fx * local[:, 0] / np.where(z > 1e-9, z, np.nan) + camera.cx
    v = camera.fy * local[:, 1] / np.where(z > 1e-9, z, np.nan) + camera.cy
    width, height = max(1, int(camera.width * scale)), max(1, int(camera.height * scale))
    pu = (np.arange(width) + 0.5) / scale - 0.5
    pv = (np.arange(height) + 0.5) / scale - 0.5
    pu, pv = np.meshgrid(pu, pv)
    pu, pv = pu.ravel(), pv.ravel()
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    ax, ay, bx, by, cx, cy = u[a], v[a], u[b], v[b], u[c], v[c]
    area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    ok = np.isfinite(area) & (np.abs(area) > 1e-12)
    best = np.full(pu.shape, np.inf)
    owner = np.full(pu.shape, -1)
    for t in np.nonzero(ok)[0]:
        w1 = ((pu - ax[t]) * (cy[t] - ay[t]) - (pv - ay[t]) * (cx[t] - ax[t])) / area[t]
        w2 = ((bx[t] - ax[t]) * (pv - ay[t]) - (by[t] - ay[t]) * (pu - ax[t])) / area[t]
        w0 = 1.0 - w1 - w2
        inside = (w0 >= 0) & (w1 >= 0) & (w2 >= 0)
        if not inside.any():
            continue
        inv_z = w0[inside] / z[a[t]] + w1[inside] / z[b[t]] + w2[inside] / z[c[t]]
        depth = 1.0 / inv_z
        idx = np.nonzero(inside)[0]
        closer = depth < best[idx]
        best[idx[closer]] = depth[closer]
        owner[idx[closer]] = t
    return np.unique(owner[owner >= 0])


def point_to_triangles(points, vertices, triangles):
    """Each point's distance to the nearest of the triangles (exact, among the
    NEAREST_TRIANGLES nearest by centroid); a large distance when no triangle is visible."""
    if len(triangles) == 0:
        return np.full(len(points), 10.0)
    from scipy.spatial import cKDTree
    centroids = vertices[triangles].mean(axis=1)
    k = min(NEAREST_TRIANGLES, len(triangles))
    _, near = cKDTree(centroids).query(points, k=k)
    near = near.reshape(len(points), k)
    tri = vertices[triangles[near]]  # (P, k, 3, 3)
    p = np.repeat(points[:, None, :], k, axis=1)
    return np.sqrt(closest_distance_sq(p, tri[..., 0, :], tri[..., 1, :], tri[..., 2, :])).min(axis=1)


def closest_distance_sq(p, a, b, c):
    """Squared distance of points p to triangles (a, b, c), elementwise over leading axes: the
    closest point by the Voronoi regions of the triangle (Ericson, Real-Time Collision Detection
    5.1.5), written out for arrays."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = np.sum(ab * ap, -1), np.sum(ac * ap, -1)
    bp = p - b
    d3, d4 = np.sum(ab * bp, -1), np.sum(ac * bp, -1)
    cp = p - c
    d5, d6 = np.sum(ab * cp, -1), np.sum(ac * cp, -1)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = va + vb + vc
        v_in, w_in = vb / denom, vc / denom
        t_ab = d1 / (d1 - d3)
        t_ac = d2 / (d2 - d6)
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
    closest = a + v_in[..., None] * ab + w_in[..., None] * ac
    regions = [
        ((d1 <= 0) & (d2 <= 0), a),
        ((d3 >= 0) & (d4 <= d3), b),
        ((d6 >= 0) & (d5 <= d6), c),
        ((vc <= 0) & (d1 >= 0) & (d3 <= 0), a + t_ab[..., None] * ab),
        ((vb <= 0) & (d2 >= 0) & (d6 <= 0), a + t_ac[..., None] * ac),
        ((va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0), b + t_bc[..., None] * (c - b)),
    ]
    for mask, point in reversed(regions):  # the first region that holds wins
        closest = np.where(mask[..., None], point, closest)
    diff = p - closest
    return np.sum(diff * diff, -1)
