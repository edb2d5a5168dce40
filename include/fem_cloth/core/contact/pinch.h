// Pinching between obstacles, found before a run (issue 30, finding 3).
//
// The explicit steppers' projection (projection_contact.h) moves a vertex out to the contact
// distance dHat from each obstacle in turn. Between two obstacles less than 2 dHat apart no point
// is dHat from both: each substep pushes the vertex from one pad into the other, and the
// displacement becomes velocity (config/pinch_lift.yaml with symplectic Euler sent the cloth up
// at 17 m/s). So a scene whose obstacles close to a slot narrower than 2 dHat is refused for them,
// up front (integrators/registry.cpp, the `obstacles` requirement), naming the integrators whose
// barriers handle a pinch.
//
// Which obstacles are looked at: pairs of which at least one moves by a scripted motion
// (velocity or trajectory; a static wedge, a ball resting on the floor, squeezes nothing), over
// [0, until]. A frame-following obstacle moves as tf says at run time, which is not known here:
// a pair with one cannot be cleared, and is reported as a possible pinch (ObstaclePinch::frame)
// unless a scripted pair closes for certain.
// How: the relative motion of two scripted obstacles is linear between the trajectories'
// points, so their distance changes at most by the relative speed times the time; it is sampled
// often enough that it cannot dip by more than dHat / 4 between samples. The distance at a time
// is the smallest signed distance of either shape's sample points (its drawn surface, 32 segments
// around, with each triangle's centroid and edge midpoints) to the other shape: exact for flat
// faces meeting at their corners, within a few tenths of a millimetre for round shapes of
// centimetre size.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "fem_cloth/core/contact/obstacle.h"

namespace fem_cloth {

struct Scene;

struct ObstaclePinch {
  std::string first, second;  ///< the obstacles' names
  double gap = 0.0;           ///< m, the narrowest slot between them (negative: overlapping)
  double time = 0.0;          ///< s, when
  /// Non-empty: `first` follows this tf frame, so the slot is known only at run time (gap and
  /// time are not set).
  std::string frame;
};

/// The narrowest slot below `narrowest` (m) between two obstacles, one of them scripted, over
/// [0, until] s; else the first pair with a frame-following obstacle (a possible pinch); nothing
/// if every slot stays at least that wide.
std::optional<ObstaclePinch> findPinch(const std::vector<Obstacle>& obstacles, double narrowest, double until);

/// A scene's pinch: its obstacles' narrowest slot below 2 contact.distance over its duration (or
/// to its last trajectory point, if later). The scene's obstacle entries must be valid.
std::optional<ObstaclePinch> findScenePinch(const Scene& scene);

/// "obstacles 'a' and 'b' leave a slot of 1.2 mm at t = 0.80 s, narrower than 2 contact.distance
/// (4 mm)", or for a frame-following one "obstacles 'a' and 'b' may leave a slot narrower than 2
/// contact.distance (4.00 mm): 'a' follows tf frame 'f', whose motion is known only at run time".
std::string pinchText(const ObstaclePinch& pinch, double contactDistance);

}  // namespace fem_cloth
