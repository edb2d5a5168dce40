#include "fem_cloth/core/live_change.h"

namespace fem_cloth {

Expected<Simulation> changeLive(Simulation& running, const Scene& changed) {
  Expected<Simulation> next = buildSimulation(changed);
  if (!next) return Error{next.error()};
  const Mesh& before = *running.mesh;
  const Mesh& after = *next->mesh;
  if (after.dim != before.dim || after.restPositions != before.restPositions || after.triangles != before.triangles) {
    return Error{"the changed scene has another mesh: a running simulation keeps its mesh"};
  }
  next->simulator->continueFrom(*running.simulator);
  next->script = running.script;
  return next;
}

}  // namespace fem_cloth
