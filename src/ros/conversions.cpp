#include "fem_cloth/ros/conversions.h"

#include <tf2_eigen/tf2_eigen.h>

#include <algorithm>

namespace fem_cloth {

namespace {

// Vertex i of a coordinate vector with d values per vertex (positions, velocities, forces) as
// a 3D message (z = 0 in 2D).
template <class M>
M vertexMessage(const VectorX& values, int d, Index i) {
  M m;
  m.x = values[d * i];
  m.y = values[d * i + 1];
  m.z = d == 3 ? values[d * i + 2] : 0.0;
  return m;
}

template <class M>
VectorX fromVertexMessages(const std::vector<M>& values, int d) {
  VectorX out(d * static_cast<Index>(values.size()));
  for (std::size_t i = 0; i < values.size(); ++i) {
    const double c[3] = {values[i].x, values[i].y, values[i].z};
    for (int k = 0; k < d; ++k) out[d * static_cast<Index>(i) + k] = c[k];
  }
  return out;
}

geometry_msgs::Pose poseMessage(const Eigen::Isometry3d& T) {
  // Not tf2::toMsg: that one flips the quaternion's sign for w < 0 (the same rotation, but other
  // marker values than before).
  geometry_msgs::Pose p;
  const Eigen::Quaterniond q(T.linear());
  p.position.x = T.translation().x();
  p.position.y = T.translation().y();
  p.position.z = T.translation().z();
  p.orientation.x = q.x();
  p.orientation.y = q.y();
  p.orientation.z = q.z();
  p.orientation.w = q.w();
  return p;
}

// Side (m) of the square slab that stands for an infinite plane in RViz, and its thickness.
constexpr double kPlaneMarkerSide = 4.0, kPlaneMarkerThickness = 0.002;

// The marker(s) of one obstacle shape at `pose`: one, or three for a capsule; a shape without a
// marker primitive of its own is a triangle list of its surface (its entry's triangulation).
void addShapeMarkers(visualization_msgs::Marker m, const Shape& shape, const Eigen::Isometry3d& pose,
                     visualization_msgs::MarkerArray* array) {
  m.pose = poseMessage(pose);
  switch (shape.type) {
    case ShapeType::Plane:
      // The slab's top face is the plane (its own z = 0, normal +z).
      m.type = visualization_msgs::Marker::CUBE;
      m.pose = poseMessage(pose * Eigen::Translation3d(0.0, 0.0, -0.5 * kPlaneMarkerThickness));
      m.scale.x = m.scale.y = kPlaneMarkerSide;
      m.scale.z = kPlaneMarkerThickness;
      break;
    case ShapeType::Box:
      m.type = visualization_msgs::Marker::CUBE;
      m.scale.x = 2.0 * shape.halfExtents.x();
      m.scale.y = 2.0 * shape.halfExtents.y();
      m.scale.z = 2.0 * shape.halfExtents.z();
      break;
    case ShapeType::Sphere:
      m.type = visualization_msgs::Marker::SPHERE;
      m.scale.x = m.scale.y = m.scale.z = 2.0 * shape.radius;
      break;
    case ShapeType::Capsule:
      m.type = visualization_msgs::Marker::CYLINDER;
      m.scale.x = m.scale.y = 2.0 * shape.radius;
      m.scale.z = 2.0 * shape.halfLength;
      for (int end = 0; end < 2; ++end) {
        visualization_msgs::Marker cap = m;
        cap.id = m.id + 1 + end;
        cap.type = visualization_msgs::Marker::SPHERE;
        cap.scale.z = 2.0 * shape.radius;
        cap.pose = poseMessage(pose * Eigen::Translation3d(0.0, 0.0, end == 0 ? -shape.halfLength
                                                                              : shape.halfLength));
        array->markers.push_back(cap);
      }
      break;
    default: {
      const ShapeMesh surface = shapeEntry(shape.type).triangulate(shape, kPlaneMarkerSide, 24);
      m.type = visualization_msgs::Marker::TRIANGLE_LIST;
      m.scale.x = m.scale.y = m.scale.z = 1.0;
      for (const auto& triangle : surface.triangles) {
        for (const int v : triangle) m.points.push_back(tf2::toMsg(surface.positions[static_cast<std::size_t>(v)]));
      }
      break;
    }
  }
  array->markers.push_back(m);
}

}  // namespace

std_msgs::Header header(const ros::Time& stamp, const std::string& frame) {
  std_msgs::Header h;
  h.stamp = stamp;
  h.frame_id = frame;
  return h;
}

shape_msgs::Mesh toMsg(const Mesh& mesh) {
  shape_msgs::Mesh msg;
  msg.triangles.resize(mesh.triangles.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      msg.triangles[t].vertex_indices[k] = static_cast<std::uint32_t>(mesh.triangles[t][k]);
    }
  }
  msg.vertices.resize(static_cast<std::size_t>(mesh.numVertices()));
  for (Index i = 0; i < mesh.numVertices(); ++i) {
    msg.vertices[static_cast<std::size_t>(i)] =
        vertexMessage<geometry_msgs::Point>(mesh.restPositions, mesh.dim, i);
  }
  return msg;
}

Expected<Mesh> fromMsg(const shape_msgs::Mesh& msg, int dim) {
  Mesh mesh;
  mesh.dim = dim;
  mesh.restPositions = fromVertexMessages(msg.vertices, dim);
  for (std::size_t t = 0; t < msg.triangles.size(); ++t) {
    Triangle tri;
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = msg.triangles[t].vertex_indices[k];
      if (v >= msg.vertices.size()) {
        return Error{"mesh triangle " + std::to_string(t) + " names vertex " + std::to_string(v) +
                     ", but the mesh has " + std::to_string(msg.vertices.size())};
      }
      tri[k] = static_cast<Index>(v);
    }
    mesh.triangles.push_back(tri);
  }
  return mesh;
}

ClothState toMsg(const std_msgs::Header& header, const State& s, int d, bool withVelocities) {
  const Index n = static_cast<Index>(s.x.size() / d);
  ClothState msg;
  msg.header = header;
  msg.step = s.step;
  msg.positions.resize(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) {
    msg.positions[static_cast<std::size_t>(i)] = vertexMessage<geometry_msgs::Point>(s.x, d, i);
  }
  if (withVelocities) {
    msg.velocities.resize(static_cast<std::size_t>(n));
    for (Index i = 0; i < n; ++i) {
      msg.velocities[static_cast<std::size_t>(i)] = vertexMessage<geometry_msgs::Vector3>(s.v, d, i);
    }
  }
  msg.state_hash = stateHash(s.x, s.v);
  return msg;
}

State fromMsg(const ClothState& msg, int d) {
  State s;
  s.step = msg.step;
  s.x = fromVertexMessages(msg.positions, d);
  s.v = msg.velocities.empty() ? VectorX(VectorX::Zero(s.x.size())) : fromVertexMessages(msg.velocities, d);
  return s;
}

ClothEnergy toMsg(const std_msgs::Header& header, std::uint64_t step, const EnergyReport& e) {
  ClothEnergy msg;
  msg.header = header;
  msg.step = step;
  msg.kinetic = e.kinetic;
  msg.strain = e.strain;
  msg.bending = e.bending;
  msg.gravity = e.gravity;
  msg.external_work = e.externalWork;
  msg.pin_work = e.pinWork;
  msg.contact_work = e.contactWork;
  msg.air_work = e.airWork;
  msg.live_work = e.liveWork;
  msg.dissipated = e.dissipated;
  msg.total = e.total;
  msg.initial_total = e.initialTotal;
  msg.balance_error = e.balanceError;
  return msg;
}

EnergyReport fromMsg(const ClothEnergy& msg) {
  EnergyReport e;
  e.kinetic = msg.kinetic;
  e.strain = msg.strain;
  e.bending = msg.bending;
  e.gravity = msg.gravity;
  e.externalWork = msg.external_work;
  e.pinWork = msg.pin_work;
  e.contactWork = msg.contact_work;
  e.airWork = msg.air_work;
  e.liveWork = msg.live_work;
  e.dissipated = msg.dissipated;
  e.total = msg.total;
  e.initialTotal = msg.initial_total;
  e.balanceError = msg.balance_error;
  return e;
}

StepStats toMsg(const std_msgs::Header& header, std::uint64_t step, const std::string& integrator,
                double dt, const StepReport& r, double wallTime, double realTimeFactor) {
  StepStats msg;
  msg.header = header;
  msg.step = step;
  msg.integrator = integrator;
  msg.dt = dt;
  msg.wall_time = wallTime;
  msg.real_time_factor = realTimeFactor;
  msg.substeps = static_cast<std::uint32_t>(r.substeps);
  msg.newton_iterations = static_cast<std::uint32_t>(r.newtonIterations);
  msg.residual = r.residual;
  msg.line_search_backtracks = static_cast<std::uint32_t>(r.lineSearchBacktracks);
  msg.rollbacks = static_cast<std::uint32_t>(r.rollbacks);
  msg.contacts = static_cast<std::uint32_t>(std::max(r.contacts, 0));
  return msg;
}

PinForces toMsg(const std_msgs::Header& header, const std::vector<Index>& pinned,
                const VectorX& reactions, int d) {
  PinForces msg;
  msg.header = header;
  for (Index v : pinned) {
    msg.vertices.push_back(static_cast<std::uint32_t>(v));
    msg.forces.push_back(vertexMessage<geometry_msgs::Vector3>(reactions, d, v));
  }
  return msg;
}

geometry_msgs::WrenchStamped toMsg(const std_msgs::Header& header, const GraspWrench& wrench) {
  geometry_msgs::WrenchStamped w;
  w.header = header;
  w.header.frame_id = wrench.frame;
  tf2::toMsg(wrench.force, w.wrench.force);
  tf2::toMsg(wrench.torque, w.wrench.torque);
  return w;
}

GraspWrench fromMsg(const geometry_msgs::WrenchStamped& msg) {
  GraspWrench w;
  w.frame = msg.header.frame_id;
  tf2::fromMsg(msg.wrench.force, w.force);
  tf2::fromMsg(msg.wrench.torque, w.torque);
  return w;
}

std::vector<geometry_msgs::WrenchStamped> obstacleWrenches(const std_msgs::Header& header,
                                                           const ObstacleSet& obstacles) {
  std::vector<geometry_msgs::WrenchStamped> out;
  for (std::size_t k = 0; k < obstacles.size(); ++k) {
    const ObstacleWrench& w = obstacles.wrenches()[k];
    // The model gives the torque about the simulation frame's origin; move it to the shape's.
    const Eigen::Vector3d origin = obstacles.shapePose(k).translation();
    GraspWrench moved{header.frame_id, w.force, w.torque - origin.cross(w.force)};
    out.push_back(toMsg(header, moved));
  }
  return out;
}

visualization_msgs::MarkerArray obstacleMarkers(const std_msgs::Header& header, const ObstacleSet& obstacles) {
  visualization_msgs::MarkerArray array;
  for (std::size_t k = 0; k < obstacles.size(); ++k) {
    visualization_msgs::Marker m;
    m.header = header;
    m.ns = "obstacles";
    m.id = static_cast<int>(3 * k);
    m.action = visualization_msgs::Marker::ADD;
    m.color.r = m.color.g = m.color.b = 0.6f;
    m.color.a = 0.8f;
    addShapeMarkers(m, obstacles[k].shape, obstacles.shapePose(k), &array);
  }
  return array;
}

}  // namespace fem_cloth
