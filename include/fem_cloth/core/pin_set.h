// Pins that follow frames (docs/architecture.md, "A pin command from the topic to the solver").
//
// A pin given in the simulation frame is a fixed target. A pin given in another frame (a
// gripper's link) keeps its target in that frame and is moved before every step to where the
// frame will be at the end of the step, so the vertex rides with the frame. The set writes each
// pin into the Simulator once per step: a pin that starts following a frame is written when the
// frame's pose for the end of the step is known (follow()), not also when it is applied.
//
// ROS-free: frames are names, and their poses come from the caller (tf, on the ROS side).
#pragma once

#include <Eigen/Geometry>

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "fem_cloth/core/expected.h"
#include "fem_cloth/core/simulator.h"

namespace fem_cloth {

/// Where a frame is at some time: its pose in the simulation frame, or nothing and `why`. When
/// a nearby transform stood in for the exact one, `inexact` says which.
struct FramePose {
  FramePose() = default;
  /// Known (`inexactText`: what stood in for the exact transform, if anything did).
  FramePose(const Eigen::Isometry3d& known, std::string inexactText = "")
      : pose(known), inexact(std::move(inexactText)) {}
  /// Not known, and why.
  static FramePose unknown(std::string whyText) {
    FramePose p;
    p.why = std::move(whyText);
    return p;
  }
  std::optional<Eigen::Isometry3d> pose;
  std::string why, inexact;
};

/// The summed pin reaction of one grasp (the pins that follow one frame, or the fixed pins):
/// the force the cloth exerts on them and its torque about the frame's origin, both expressed in
/// that frame — what a wrist force sensor reads.
struct GraspWrench {
  std::string frame;
  Eigen::Vector3d force = Eigen::Vector3d::Zero(), torque = Eigen::Vector3d::Zero();
};

class PinSet {
 public:
  /// `maxJump` (m): a target farther than this from its vertex is refused (the pin would move
  /// the vertex there within one step), when pinned and whenever a frame moves its pins.
  explicit PinSet(double maxJump) : maxJump_(maxJump) {}

  /// Pins `vertices` at `targets` given in `frame`, whose pose in the simulation frame now is
  /// `frameNow` (an empty `frame` is the simulation frame: fixed targets). No targets: the
  /// vertices are pinned where they are. Whole or not at all: the error names the first target
  /// farther than maxJump from its vertex.
  Status pin(Simulator& sim, const std::vector<Index>& vertices,
             const std::vector<Eigen::Vector3d>& targets, const std::string& frame,
             const Eigen::Isometry3d& frameNow);
  /// Releases `vertices` (none listed: every pin).
  void release(Simulator& sim, const std::vector<Index>& vertices);
  /// Before a step: moves the pins of each followed frame to `poseAtEnd(frame)` (called once per
  /// frame). A frame without a pose, or one that would make a pin jump, loses its pins: they
  /// stay where they are, fixed in the simulation frame. Returns what went wrong, one line each.
  std::vector<std::string> follow(Simulator& sim,
                                  const std::function<FramePose(const std::string&)>& poseAtEnd);
  /// One wrench per frame with pins (sorted by name; the fixed pins under `fixedFrame`), from the
  /// simulator's pin reactions, each frame placed by `poseNow` (called once per frame; a frame
  /// without a pose is left out).
  std::vector<GraspWrench> wrenches(const Simulator& sim, const VectorX& reactions,
                                    const std::string& fixedFrame,
                                    const std::function<FramePose(const std::string&)>& poseNow) const;
  /// The frame a vertex's pin follows (nullptr: none).
  const std::string* frameOf(Index vertex) const;
  /// The frames pins follow, each once, sorted.
  std::vector<std::string> frames() const;
  /// Forgets every follower (the simulator's own pins are reset by Simulator::reset()).
  void clear() { follow_.clear(); }

 private:
  struct Follow {
    std::string frame;
    Eigen::Vector3d local;  // the target in that frame
    // Where the pin was put when applied, until follow() writes it into the simulator.
    std::optional<Eigen::Vector3d> unwritten;
  };
  /// The error naming the first vertex whose target is farther than maxJump from it.
  Status checkJumps(const Simulator& sim, const std::vector<Index>& vertices,
                    const std::vector<Eigen::Vector3d>& targets) const;

  double maxJump_;
  std::map<Index, Follow> follow_;
};

/// "vertex 3" or "vertices 3, 7 and 12" (the first few of a long list, then how many more).
std::string verticesText(const std::vector<Index>& vertices);

}  // namespace fem_cloth
