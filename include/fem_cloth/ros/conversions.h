// The simulation's state and outputs as ROS messages, and back: free, stateless functions in the
// manner of grid_map_ros's GridMapRosConverter (docs/architecture.md, the ROS side). Each toMsg
// has a fromMsg where a message is read back (bags, tests), and the pair round-trips what the
// message holds. The perception messages (point cloud, camera, cloth frames, marker) are in
// perception_messages.h.
#pragma once

#include <geometry_msgs/WrenchStamped.h>
#include <shape_msgs/Mesh.h>
#include <std_msgs/Header.h>
#include <visualization_msgs/MarkerArray.h>

#include <string>
#include <vector>

#include "fem_cloth/ClothEnergy.h"
#include "fem_cloth/ClothState.h"
#include "fem_cloth/PinForces.h"
#include "fem_cloth/StepStats.h"
#include "fem_cloth/core/contact/obstacle_set.h"
#include "fem_cloth/core/mesh.h"
#include "fem_cloth/core/metrics.h"
#include "fem_cloth/core/pin_set.h"
#include "fem_cloth/core/simulator.h"

namespace fem_cloth {

std_msgs::Header header(const ros::Time& stamp, const std::string& frame);

/// The rest mesh: triangles and rest positions (z = 0 in 2D).
shape_msgs::Mesh toMsg(const Mesh& mesh);
/// A mesh of dimension `dim` (2: z dropped) from a message; its triangles must name vertices it
/// has (the error names the first that does not).
Expected<Mesh> fromMsg(const shape_msgs::Mesh& msg, int dim);

/// Positions (and velocities when `withVelocities`) of a state of d values per vertex, its
/// step and its state hash (stateHash below).
ClothState toMsg(const std_msgs::Header& header, const State& state, int d, bool withVelocities);
/// Positions and velocities (zero when the message has none) of d values per vertex.
State fromMsg(const ClothState& msg, int d);

ClothEnergy toMsg(const std_msgs::Header& header, std::uint64_t step, const EnergyReport& energy);
/// The energies a ClothEnergy holds: every term of the balance and its works (a message recorded
/// before contact_work, air_work, live_work and initial_total existed reads them as 0).
EnergyReport fromMsg(const ClothEnergy& msg);

/// A step's statistics; min_area_ratio and the command counts are filled by the caller.
StepStats toMsg(const std_msgs::Header& header, std::uint64_t step, const std::string& integrator,
                double dt, const StepReport& report, double wallTime, double realTimeFactor);

/// The reactions (d values per vertex) of the pinned vertices, in vertex order.
PinForces toMsg(const std_msgs::Header& header, const std::vector<Index>& pinned,
                const VectorX& reactions, int d);

/// A grasp's wrench, in the grasp's frame (header.frame_id is replaced by it).
geometry_msgs::WrenchStamped toMsg(const std_msgs::Header& header, const GraspWrench& wrench);
GraspWrench fromMsg(const geometry_msgs::WrenchStamped& msg);

/// Per obstacle (scene order): the force the cloth exerts on it in the simulation frame, torque
/// about the origin of its shape (a sphere's or box's centre, a plane's point).
std::vector<geometry_msgs::WrenchStamped> obstacleWrenches(const std_msgs::Header& header,
                                                           const ObstacleSet& obstacles);
/// The obstacles as RViz markers at their current poses: a plane as a thin square slab of side
/// kPlaneMarkerSide whose top is the plane, a box, a sphere, a capsule as a cylinder and two
/// spheres; namespace "obstacles", ids 3k to 3k+2.
visualization_msgs::MarkerArray obstacleMarkers(const std_msgs::Header& header, const ObstacleSet& obstacles);

}  // namespace fem_cloth
