#include "fem_cloth/core/live_change.h"

#include "fem_cloth/core/contact/contact_model.h"
#include "fem_cloth/core/contact/obstacle_set.h"

namespace fem_cloth {

namespace {

// A change must leave the running cloth outside every obstacle: a free vertex inside one (an
// obstacle added or moved into the cloth) would be thrown out by the next step's contact (the
// explicit steppers' projection put 575 J into the node's default cloth when a ball was added
// where it swung) or stop the barriers, and the step would fail again and again. Refused here,
// naming the obstacle and the vertex, so that the running simulation goes on unchanged.
// Obstacles on tf frames are placed only when a step starts, by the ROS layer: not checked.
// The obstacles' poses are those at the start of the step from the running time
// (ObstacleSet::beginStep, which changeLive calls).
Status checkClothOutsideObstacles(const Simulator& s, const ObstacleSet& obstacles) {
  const VectorX& x = s.state().x;
  const double t = s.time();
  for (std::size_t k = 0; k < obstacles.size(); ++k) {
    const Obstacle& o = obstacles[k];
    if (!o.frame.empty()) continue;
    const Eigen::Isometry3d inverse = obstacles.shapePoseAt(k, 0.0).inverse();
    Index deepest = -1, inside = 0;
    double least = 0.0;
    for (Index v = 0; v < static_cast<Index>(x.size() / 3); ++v) {
      if (s.isPinned(v)) continue;
      const double d = signedDistance(o.shape, inverse * Eigen::Vector3d(x.segment<3>(3 * v))).distance;
      if (d > 0.0) continue;
      ++inside;
      if (deepest < 0 || d < least) deepest = v, least = d;
    }
    if (deepest < 0) continue;
    return Error{"obstacles[" + std::to_string(k) + "] ('" + o.name + "'): the running cloth has " +
                 std::to_string(inside) + (inside == 1 ? " vertex" : " vertices") +
                 " inside it, the deepest vertex " + std::to_string(deepest) +
                 " (distance " + numberText(least) + " m at t = " + numberText(t) +
                 " s); place the obstacle clear of the cloth where it is now (~state)"};
  }
  return Status::success();
}

}  // namespace

Expected<Simulation> changeLive(Simulation& running, const Scene& changed) {
  // The scene's start checks look at its initial state, where the running cloth no longer is (an
  // obstacle added where the cloth lay at t = 0 was refused: "vertex 444 starts inside it").
  Expected<Simulation> next = buildSimulationToContinue(changed);
  if (!next) return Error{next.error()};
  const Mesh& before = *running.mesh;
  const Mesh& after = *next->mesh;
  if (after.dim != before.dim || after.restPositions != before.restPositions || after.triangles != before.triangles) {
    return Error{"the changed scene has another mesh: a running simulation keeps its mesh"};
  }
  next->simulator->continueFrom(*running.simulator);
  next->script = running.script;
  Simulator& s = *next->simulator;
  ObstacleSet* obstacles = s.obstacles();
  if (obstacles == nullptr) return next;
  obstacles->beginStep(s.time(), s.settings().dt);  // where they are at the running time
  if (Status st = checkClothOutsideObstacles(s, *obstacles); !st) return Error{st.error()};
  if (ContactModel* barriers = s.contact(); barriers != nullptr) {
    // The barriers' surface samples too (round obstacles between vertices, box edges through
    // triangles).
    if (Status st = barriers->checkSurfaceAtStart(s.state().x, s.pinnedVertices()); !st) {
      // Its message is worded for a scene's start.
      std::string text = st.error();
      const std::string atStart = " at the start; move the obstacle or the cloth";
      if (const std::size_t at = text.find(atStart); at != std::string::npos) text.erase(at, atStart.size());
      return Error{text + " where the running cloth is (t = " + numberText(s.time()) +
                   " s); place the obstacle clear of the cloth where it is now (~state)"};
    }
  }
  return next;
}

}  // namespace fem_cloth
