// Live changes of a running simulation's parameters (docs/scenes.md, Live changes): the scene is
// changed (io/live_change.h checks which keys may change and validates the result like any
// scene), the simulation is built anew from it — so whatever depended on the old parameters
// (factorisations, prefactored projective-dynamics matrices, CFL estimates, Hessian patterns,
// contact set-up) is redone — and the new one takes over where the old one is: state, history,
// time, pins, forces, timed events and energy bookkeeping. The energy a change puts in at the
// instant (a stiffer cloth holds more strain energy at the same shape) is booked as
// EnergyReport::liveWork, so the balance runs on unbroken. Applied between steps only.
#pragma once

#include "fem_cloth/core/expected.h"
#include "fem_cloth/core/scene.h"

namespace fem_cloth {

/// `changed` built and continuing `running` (left as it was on error). The mesh must be the one
/// `running` was built with (live keys do not change it): the error says so otherwise. The
/// obstacles are checked against the running cloth, not the scene's initial state: a free vertex
/// inside one (or, with the barriers, a point of the surface) refuses the change.
Expected<Simulation> changeLive(Simulation& running, const Scene& changed);

/// buildSimulation without checking the obstacles against the scene's initial state (scene.cpp):
/// what a live change builds, before it checks them against the running state.
Expected<Simulation> buildSimulationToContinue(const Scene& scene);

}  // namespace fem_cloth
