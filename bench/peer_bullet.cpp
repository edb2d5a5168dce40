// fem_cloth_peer_bullet: fem_cloth's fast path and Bullet's soft-body cloth, side by side on
// the same problem in one run (built only when Bullet is installed: scripts/install-deps --bullet).
//
// The problem (docs/performance.md): a 65 x 65 cloth, 1 m square, 1 kg, pinned at the two
// corners of one edge, g = 9.81 m/s^2, starting flat, 2 s simulated. Bullet steps at fixed
// 1/240 s with its position-based solver at several iteration counts (piterations) and maximal
// link stiffness; fem_cloth runs config/hanging_cloth_fast.yaml. For each run: wall time and the
// edge stretch l/L - 1 at the end (mean of the positive part, and the largest), measured the same
// way for both (on Bullet's links, which include its diagonals, and on fem_cloth's mesh edges).
//
//   fem_cloth_peer_bullet [--resolution 65] [--duration 2] [--max-iterations 160]
#include <BulletSoftBody/btDefaultSoftBodySolver.h>
#include <BulletSoftBody/btSoftBodyHelpers.h>
#include <BulletSoftBody/btSoftBodyRigidBodyCollisionConfiguration.h>
#include <BulletSoftBody/btSoftRigidDynamicsWorld.h>
#include <btBulletDynamicsCommon.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "fem_cloth/core/metrics.h"
#include "fem_cloth/io/scene_yaml.h"
#include "fem_cloth/core/threads.h"

namespace {

struct Result {
  std::string name;
  double wall = 0.0;  // s
  int steps = 0;
  double meanStretch = 0.0, maxStretch = 0.0;
  bool finite = true;
};

Result runBullet(int resolution, int iterations, double duration) {
  const double dt = 1.0 / 240.0;
  btSoftBodyRigidBodyCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDefaultSoftBodySolver softSolver;
  btSoftRigidDynamicsWorld world(&dispatcher, &broadphase, &solver, &config, &softSolver);
  world.setGravity(btVector3(0, 0, -9.81));
  btSoftBodyWorldInfo& info = world.getWorldInfo();
  info.m_gravity = btVector3(0, 0, -9.81);
  info.air_density = 0;
  info.water_density = 0;
  info.m_sparsesdf.Initialize();
  // Node (ix, iy) at index iy * resolution + ix: corners (0, 0) and (1, 0) are nodes 0 and
  // resolution - 1, as in fem_cloth's grid.
  btSoftBody* cloth = btSoftBodyHelpers::CreatePatch(info, btVector3(0, 0, 0), btVector3(1, 0, 0),
                                                     btVector3(0, 1, 0), btVector3(1, 1, 0),
                                                     resolution, resolution, 0, true);
  cloth->m_cfg.piterations = iterations;
  cloth->m_materials[0]->m_kLST = 1.0;
  cloth->setTotalMass(1.0);
  cloth->setMass(0, 0);  // pinned
  cloth->setMass(resolution - 1, 0);
  world.addSoftBody(cloth);
  const int steps = static_cast<int>(std::lround(duration / dt));
  const auto start = std::chrono::steady_clock::now();
  for (int k = 0; k < steps; ++k) world.stepSimulation(dt, 0);
  Result r;
  r.name = "bullet, " + std::to_string(iterations) + " iterations, 1/240 s";
  r.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  r.steps = steps;
  double sum = 0.0;
  r.maxStretch = -1e300;
  for (int i = 0; i < cloth->m_links.size(); ++i) {
    const btSoftBody::Link& l = cloth->m_links[i];
    const double length = (l.m_n[0]->m_x - l.m_n[1]->m_x).length();
    const double stretch = length / l.m_rl - 1.0;
    if (!std::isfinite(stretch)) r.finite = false;
    sum += std::max(stretch, 0.0);
    r.maxStretch = std::max(r.maxStretch, stretch);
  }
  r.meanStretch = sum / cloth->m_links.size();
  world.removeSoftBody(cloth);
  delete cloth;
  return r;
}

Result runFemCloth(int resolution, double duration) {
  const std::string scene = std::string(FEM_CLOTH_SOURCE_DIR) + "/config/hanging_cloth_fast.yaml";
  fem_cloth::Expected<fem_cloth::Scene> s =
      fem_cloth::loadScene(scene, {"mesh.rows=" + std::to_string(resolution),
                                   "mesh.cols=" + std::to_string(resolution)});
  if (!s) {
    std::fprintf(stderr, "fem_cloth_peer_bullet: %s\n", s.error().c_str());
    std::exit(2);
  }
  fem_cloth::Expected<fem_cloth::Simulation> sim = fem_cloth::buildSimulation(*s);
  const int steps = static_cast<int>(std::lround(duration / s->dt));
  const auto start = std::chrono::steady_clock::now();
  Result r;
  for (int k = 0; k < steps; ++k) {
    if (!sim->simulator->step().ok) r.finite = false;
  }
  r.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  r.name = "fem_cloth projective_dynamics, " + std::to_string(s->iterations) + " iterations, 1/60 s";
  r.steps = steps;
  const fem_cloth::EdgeStretch st = fem_cloth::EdgeStretchMeter(*sim->mesh).measure(sim->simulator->state().x);
  r.meanStretch = st.mean;
  r.maxStretch = st.max;
  r.finite = r.finite && sim->simulator->state().x.allFinite();
  return r;
}

void print(const Result& r, double duration) {
  std::printf("%-52s %8.3f %9.3f %8.2f %10.3f %9.2f%s\n", r.name.c_str(), r.wall,
              1e3 * r.wall / r.steps, duration / r.wall, 100 * r.meanStretch, 100 * r.maxStretch,
              r.finite ? "" : "  NON-FINITE");
}

}  // namespace

int main(int argc, char** argv) {
  fem_cloth::preferPassiveThreadWaiting(argv);
  int resolution = 65, maxIterations = 160;
  double duration = 2.0;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--resolution") resolution = std::atoi(argv[i + 1]);
    else if (flag == "--duration") duration = std::atof(argv[i + 1]);
    else if (flag == "--max-iterations") maxIterations = std::atoi(argv[i + 1]);
    else {
      std::fprintf(stderr, "fem_cloth_peer_bullet: unknown option %s\n", flag.c_str());
      return 2;
    }
  }
  const double meanTarget = 0.002, maxTarget = 0.10;
  std::printf("hanging cloth %d x %d, 1 m, 1 kg, pinned at two corners, %.1f s simulated\n",
              resolution, resolution, duration);
  std::printf("%-52s %8s %9s %8s %10s %9s\n", "run", "wall (s)", "ms/step", "x real", "mean str.%",
              "max str.%");
  const Result ours = runFemCloth(resolution, duration);
  print(ours, duration);
  const Result* cheapest = nullptr;
  std::vector<Result> bullet;
  bullet.reserve(16);
  for (int it = 10; it <= maxIterations; it *= 2) {
    bullet.push_back(runBullet(resolution, it, duration));
    print(bullet.back(), duration);
    if (!cheapest && bullet.back().meanStretch <= meanTarget && bullet.back().maxStretch <= maxTarget) {
      cheapest = &bullet.back();
    }
  }
  const bool oursMeets = ours.meanStretch <= meanTarget && ours.maxStretch <= maxTarget;
  std::printf("\ntarget: mean stretch <= %.1f %%, worst <= %.0f %% after %.1f s\n", 100 * meanTarget,
              100 * maxTarget, duration);
  std::printf("fem_cloth: %s, %.3f s wall (%.2f x real time)\n",
              oursMeets ? "meets it" : "MISSES it", ours.wall, duration / ours.wall);
  if (cheapest) {
    std::printf("bullet: cheapest setting that meets it: %s, %.3f s wall; fem_cloth takes %.2f of "
                "that\n", cheapest->name.c_str(), cheapest->wall, ours.wall / cheapest->wall);
  } else {
    std::printf("bullet: no setting up to %d iterations meets it (the best reached: mean %.2f %%, "
                "worst %.1f %% in %.3f s); fem_cloth takes %.2f of the time of that one\n",
                maxIterations, 100 * bullet.back().meanStretch, 100 * bullet.back().maxStretch,
                bullet.back().wall, ours.wall / bullet.back().wall);
  }
  return oursMeets ? 0 : 1;
}
