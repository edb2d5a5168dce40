#include "fem_cloth/core/contact/pinch.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>

#include "fem_cloth/core/contact/shapes.h"
#include "fem_cloth/core/scene.h"

namespace fem_cloth {

namespace {

constexpr int kSegments = 32;
constexpr double kPlaneSide = 4.0;  // m: the square standing for a plane (its corners)
constexpr int kMaxSamples = 100000;  // per interval of linear relative motion

// Sample points of a shape's surface in its own frame: the drawn mesh's vertices, each triangle's
// centroid and its edges' midpoints.
std::vector<Eigen::Vector3d> surfaceSamples(const Shape& shape) {
  const ShapeMesh m = shapeEntry(shape.type).triangulate(shape, kPlaneSide, kSegments);
  std::vector<Eigen::Vector3d> out = m.positions;
  for (const auto& t : m.triangles) {
    const Eigen::Vector3d &a = m.positions[static_cast<std::size_t>(t[0])],
                          &b = m.positions[static_cast<std::size_t>(t[1])],
                          &c = m.positions[static_cast<std::size_t>(t[2])];
    out.push_back((a + b + c) / 3.0);
    out.push_back(0.5 * (a + b));
    out.push_back(0.5 * (b + c));
    out.push_back(0.5 * (c + a));
  }
  return out;
}

// World pose of the shape at time t (the frame, if any, at the identity).
Eigen::Isometry3d poseAt(const Obstacle& o, double t) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  if (o.scripted()) pose.translate(o.offsetAt(t));
  return pose * o.geometry;
}

// The smallest signed distance of either shape's samples to the other at time t (m).
double gapAt(const Obstacle& a, const std::vector<Eigen::Vector3d>& sa, const Obstacle& b,
             const std::vector<Eigen::Vector3d>& sb, double t) {
  const Eigen::Isometry3d pa = poseAt(a, t), pb = poseAt(b, t);
  const Eigen::Isometry3d aInB = pb.inverse() * pa, bInA = pa.inverse() * pb;
  double smallest = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3d& p : sa) smallest = std::min(smallest, signedDistance(b.shape, aInB * p).distance);
  for (const Eigen::Vector3d& p : sb) smallest = std::min(smallest, signedDistance(a.shape, bInA * p).distance);
  return smallest;
}

}  // namespace

std::optional<ObstaclePinch> findPinch(const std::vector<Obstacle>& obstacles, double narrowest, double until) {
  std::vector<std::vector<Eigen::Vector3d>> samples;
  for (const Obstacle& o : obstacles) samples.push_back(o.scripted() ? surfaceSamples(o.shape) : std::vector<Eigen::Vector3d>());
  std::optional<ObstaclePinch> found;
  for (std::size_t i = 0; i < obstacles.size(); ++i) {
    for (std::size_t j = i + 1; j < obstacles.size(); ++j) {
      const Obstacle &a = obstacles[i], &b = obstacles[j];
      if (!a.frame.empty() || !b.frame.empty()) {
        const Obstacle& follower = a.frame.empty() ? b : a;
        if (!found) found = ObstaclePinch{follower.name, (&follower == &a ? b : a).name, 0.0, 0.0, follower.frame};
        continue;
      }
      if (!a.scripted() && !b.scripted()) continue;
      if (samples[i].empty()) samples[i] = surfaceSamples(a.shape);
      if (samples[j].empty()) samples[j] = surfaceSamples(b.shape);
      // The times where the relative motion may change its velocity.
      std::set<double> times = {0.0, until};
      for (const Obstacle* o : {&a, &b}) {
        for (const TrajectoryPoint& p : o->trajectory) {
          if (p.time > 0.0 && p.time < until) times.insert(p.time);
        }
      }
      auto relative = [&](double t) -> Eigen::Vector3d { return b.offsetAt(t) - a.offsetAt(t); };
      for (auto it = times.begin(); it != times.end(); ++it) {
        const double t0 = *it;
        const auto next = std::next(it);
        const double t1 = next == times.end() ? t0 : *next;
        const double speed = t1 > t0 ? (relative(t1) - relative(t0)).norm() / (t1 - t0) : 0.0;
        // Conservative advancement: the gap shrinks at most at the relative speed, so the next
        // time it can be below `narrowest` is (gap - narrowest) / speed away; and never more
        // than a quarter of `narrowest` is left to chance between two samples.
        double t = t0;
        for (int k = 0; k < kMaxSamples; ++k) {
          const double gap = gapAt(a, samples[i], b, samples[j], t);
          if (gap < narrowest && (!found || !found->frame.empty() || gap < found->gap)) {
            found = ObstaclePinch{a.name, b.name, gap, t, ""};
          }
          if (!(speed > 0.0)) break;
          t += std::max(gap - narrowest, 0.25 * narrowest) / speed;
          if (t >= t1) break;
        }
      }
    }
  }
  return found;
}

std::optional<ObstaclePinch> findScenePinch(const Scene& scene) {
  if (scene.obstacles.size() < 2) return std::nullopt;
  std::vector<Obstacle> obstacles;
  double until = scene.duration;
  for (std::size_t i = 0; i < scene.obstacles.size(); ++i) {
    Expected<Obstacle> o = makeObstacle(scene.obstacles[i], "obstacles[" + std::to_string(i) + "]");
    if (!o) return std::nullopt;  // refused elsewhere, naming the key
    if (!o->trajectory.empty()) until = std::max(until, o->trajectory.back().time);
    obstacles.push_back(std::move(o).value());
  }
  return findPinch(obstacles, 2.0 * scene.contact.distance, until);
}

std::string pinchText(const ObstaclePinch& pinch, double contactDistance) {
  const std::string pair = "obstacles '" + pinch.first + "' and '" + pinch.second + "'";
  if (!pinch.frame.empty()) {
    char width[32];
    std::snprintf(width, sizeof width, "%.2f mm", 2e3 * contactDistance);
    return pair + " may leave a slot narrower than 2 contact.distance (" + width + "): '" + pinch.first +
           "' follows tf frame '" + pinch.frame + "', whose motion is known only at run time";
  }
  char text[160];
  std::snprintf(text, sizeof text, " leave a slot of %.2f mm at t = %.2f s, narrower than 2 contact.distance (%.2f mm)",
                1e3 * pinch.gap, pinch.time, 2e3 * contactDistance);
  return pair + text;
}

}  // namespace fem_cloth
