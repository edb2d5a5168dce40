#include "fem_cloth/core/pin_set.h"

#include <algorithm>

#include "fem_cloth/core/mesh.h"

namespace fem_cloth {

std::string verticesText(const std::vector<Index>& vertices) {
  constexpr std::size_t kListed = 6;
  std::string text = vertices.size() == 1 ? "vertex " : "vertices ";
  for (std::size_t k = 0; k < vertices.size() && k < kListed; ++k) {
    if (k > 0) text += k + 1 == vertices.size() ? " and " : ", ";
    text += std::to_string(vertices[k]);
  }
  if (vertices.size() > kListed) text += " and " + std::to_string(vertices.size() - kListed) + " more";
  return text;
}

Status PinSet::checkJumps(const Simulator& sim, const std::vector<Index>& vertices,
                          const std::vector<Eigen::Vector3d>& targets) const {
  const Mesh& mesh = sim.model().mesh();
  for (std::size_t k = 0; k < vertices.size(); ++k) {
    const double jump = (targets[k] - vertex3(mesh, sim.state().x, vertices[k])).norm();
    if (!(jump <= maxJump_)) {
      return Error{"the target of vertex " + std::to_string(vertices[k]) + " is " + numberText(jump) +
                   " m from where the vertex is (max_pin_jump = " + numberText(maxJump_) +
                   " m): a pin would move it there within one step; pin it where it is and move "
                   "the target in smaller steps"};
    }
  }
  return Status::success();
}

Status PinSet::pin(Simulator& sim, const std::vector<Index>& vertices,
                   const std::vector<Eigen::Vector3d>& targets, const std::string& frame,
                   const Eigen::Isometry3d& frameNow) {
  const Mesh& mesh = sim.model().mesh();
  std::vector<Eigen::Vector3d> locals, placed;
  for (std::size_t k = 0; k < vertices.size(); ++k) {
    const Eigen::Vector3d local = targets.empty()
                                      ? Eigen::Vector3d(frameNow.inverse() * vertex3(mesh, sim.state().x, vertices[k]))
                                      : targets[k];
    Eigen::Vector3d target = frameNow * local;
    if (sim.dim() == 2) target.z() = 0.0;
    locals.push_back(local);
    placed.push_back(target);
  }
  // Checked for every vertex before any is pinned: a command is applied whole or not at all.
  if (Status s = checkJumps(sim, vertices, placed); !s) return s;
  for (std::size_t k = 0; k < vertices.size(); ++k) {
    if (frame.empty()) {
      follow_.erase(vertices[k]);
      if (Status s = sim.pin(vertices[k], placed[k]); !s) return s;
    } else {
      follow_[vertices[k]] = Follow{frame, locals[k], placed[k]};
    }
  }
  return Status::success();
}

void PinSet::release(Simulator& sim, const std::vector<Index>& vertices) {
  if (vertices.empty()) {
    sim.releaseAll();
    follow_.clear();
  }
  for (Index v : vertices) {
    static_cast<void>(sim.release(v));  // the caller checked the vertex
    follow_.erase(v);
  }
}

std::vector<std::string> PinSet::follow(Simulator& sim,
                                        const std::function<FramePose(const std::string&)>& poseAtEnd) {
  std::vector<std::string> problems;
  std::map<std::string, std::vector<Index>> byFrame;
  for (const auto& [vertex, f] : follow_) byFrame[f.frame].push_back(vertex);
  for (const auto& [frame, vertices] : byFrame) {
    const FramePose end = poseAtEnd(frame);
    std::vector<Eigen::Vector3d> targets;
    for (Index v : vertices) {
      if (!end.pose) break;
      targets.push_back(*end.pose * follow_.at(v).local);
      if (sim.dim() == 2) targets.back().z() = 0.0;
    }
    const Status moved = end.pose ? checkJumps(sim, vertices, targets) : Status(Error{end.why});
    if (!moved) {
      // They stay where they are: a pin applied this step is put where it was applied.
      for (Index v : vertices) {
        if (const std::optional<Eigen::Vector3d>& at = follow_.at(v).unwritten) static_cast<void>(sim.pin(v, *at));
        follow_.erase(v);
      }
      problems.push_back("the pins of " + verticesText(vertices) + " stop following frame '" + frame +
                         "' and stay where they are: " + moved.error());
      continue;
    }
    if (!end.inexact.empty()) {
      problems.push_back("the pins of " + verticesText(vertices) + ": " + end.inexact +
                         " (a replay of this run may differ)");
    }
    for (std::size_t k = 0; k < vertices.size(); ++k) {
      static_cast<void>(sim.pin(vertices[k], targets[k]));  // finite: checkJumps passed
      follow_.at(vertices[k]).unwritten.reset();
    }
  }
  return problems;
}

std::vector<GraspWrench> PinSet::wrenches(const Simulator& sim, const VectorX& reactions,
                                          const std::string& fixedFrame,
                                          const std::function<FramePose(const std::string&)>& poseNow) const {
  const Mesh& mesh = sim.model().mesh();
  std::map<std::string, GraspWrench> sums;  // in the simulation frame until the end
  std::map<std::string, Eigen::Isometry3d> poses;
  for (Index v : sim.pinnedVertices()) {
    const std::string* followed = frameOf(v);
    const std::string& frame = followed != nullptr ? *followed : fixedFrame;
    if (!poses.count(frame)) {
      const FramePose pose = followed != nullptr ? poseNow(frame) : FramePose(Eigen::Isometry3d::Identity());
      if (!pose.pose) continue;
      poses[frame] = *pose.pose;
      sums[frame].frame = frame;
    }
    const Eigen::Vector3d f = vertex3(mesh, reactions, v), p = vertex3(mesh, sim.state().x, v);
    GraspWrench& w = sums[frame];
    w.force += f;
    w.torque += (p - poses[frame].translation()).cross(f);
  }
  std::vector<GraspWrench> out;
  for (auto& [frame, w] : sums) {
    const Eigen::Matrix3d Rt = poses[frame].linear().transpose();
    w.force = Rt * w.force;
    w.torque = Rt * w.torque;
    out.push_back(w);
  }
  return out;
}

const std::string* PinSet::frameOf(Index vertex) const {
  auto it = follow_.find(vertex);
  return it == follow_.end() ? nullptr : &it->second.frame;
}

std::vector<std::string> PinSet::frames() const {
  std::vector<std::string> out;
  for (const auto& [vertex, f] : follow_) {
    if (std::find(out.begin(), out.end(), f.frame) == out.end()) out.push_back(f.frame);
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace fem_cloth
