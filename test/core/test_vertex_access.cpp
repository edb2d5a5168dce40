// Per-vertex access of the energy terms (EnergyTerm::vertexDerivatives, PotentialTerm's for the
// air and the contact) at every vertex of a deformed sheet, with checkVertexAccess
// (vertex_access_check.h): for every material (planar and cloth meshes), every bending model,
// the air and the contact. The potential's other terms are checked in test_potential.cpp.
#include <gtest/gtest.h>

#include <functional>
#include <limits>
#include <random>

#include "bending_test_support.h"
#include "fem_cloth/core/air.h"
#include "fem_cloth/core/contact/contact_model.h"
#include "fem_cloth/core/materials/materials.h"
#include "fem_cloth/core/membrane.h"
#include "fem_cloth/core/model.h"
#include "fem_cloth/core/potential/terms.h"
#include "vertex_access_check.h"

using namespace fem_cloth;
using namespace fem_cloth::test;

namespace {

Probe probeOf(EnergyTerm& term, const Mesh& mesh) {
  return test::probeOf<EvalRequest>(term, std::make_shared<SparseHessian>(patternFor(mesh, term)), mesh.dim);
}

// A 5 x 5 grid, 0.2 m: in 3D curved (z = 0.8 x^2 - 0.5 x y) and jittered by up to 4 mm; in 2D
// stretched along y and compressed along x by an affine map and jittered (compression makes
// the non-convex materials' Hessians indefinite). No element inverts.
VectorX deformed(const Mesh& mesh, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  VectorX x = mesh.restPositions;
  for (Index i = 0; i < mesh.numVertices(); ++i) {
    if (mesh.dim == 3) {
      const double px = x[3 * i], py = x[3 * i + 1];
      x[3 * i + 2] = 0.8 * px * px - 0.5 * px * py;
      for (int k = 0; k < 3; ++k) x[3 * i + k] += 4e-3 * u(rng);
    } else {
      const double px = x[2 * i], py = x[2 * i + 1];
      x[2 * i] = 0.75 * px + 0.2 * py + 4e-3 * u(rng);
      x[2 * i + 1] = -0.1 * px + 1.2 * py + 4e-3 * u(rng);
    }
  }
  return x;
}

// A backward Euler substep of 10 ms from x0 (c^2 = h^2, gamma = 1/h, xc = x0).
SubstepFrame backwardEulerFrame(const VectorX& x0, const std::vector<char>& pinned) {
  SubstepFrame frame;
  frame.x0 = &x0;
  frame.xc = &x0;
  frame.h = 0.01;
  frame.c2 = 1e-4;
  frame.gamma = 100.0;
  frame.pinned = &pinned;
  return frame;
}

Cloth sheet(int dim) {
  GridSpec spec;
  spec.rows = 5;
  spec.cols = 5;
  spec.width = 0.2;
  spec.height = 0.2;
  spec.dim = dim;
  return withRest(*makeGrid(spec));
}

}  // namespace

// The table, against stencils worked out by hand.
TEST(VertexIncidence, ListsEachVertexsElementsAndSlots) {
  const std::vector<std::vector<Index>> stencils = {{0, 1, 2}, {2, 1, 3}, {3, 4}};
  const VertexIncidence table(6, stencils);
  ASSERT_EQ(table.numVertices(), 6);
  auto uses = [&](Index v) {
    std::vector<std::pair<Index, int>> out;
    for (const auto& use : table.uses(v)) out.emplace_back(use.element, use.slot);
    return out;
  };
  using U = std::vector<std::pair<Index, int>>;
  EXPECT_EQ(uses(0), (U{{0, 0}}));
  EXPECT_EQ(uses(1), (U{{0, 1}, {1, 1}}));
  EXPECT_EQ(uses(2), (U{{0, 2}, {1, 0}}));
  EXPECT_EQ(uses(3), (U{{1, 2}, {2, 0}}));
  EXPECT_EQ(uses(4), (U{{2, 1}}));
  EXPECT_TRUE(uses(5).empty());  // a vertex no element uses
}

TEST(VertexAccess, MembraneOfEveryMaterialPlanarAndCloth) {
  for (int dim : {2, 3}) {
    const Cloth c = sheet(dim);
    const VectorX x = deformed(*c.mesh, 11);
    double projected = 0.0;
    for (const std::string& name : materialNames()) {
      const Expected<Material> material = makeMaterial(name, Lame{30.0, 50.0});
      ASSERT_TRUE(material.ok()) << name;
      std::unique_ptr<EnergyTerm> term = makeMembraneTerm(c.mesh, c.rest, *material);
      ASSERT_TRUE(term->hasVertexDerivatives()) << name;
      projected = std::max(projected, checkVertexAccess(probeOf(*term, *c.mesh), x));
    }
    // The projected path is exercised: some material is not convex at this deformation.
    EXPECT_GT(projected, 1e-3) << dim << "D";
  }
}

TEST(VertexAccess, EveryBendingModel) {
  const Cloth c = sheet(3);
  const VectorX x = deformed(*c.mesh, 12);
  for (const std::string& model : bendingModelNames()) {
    std::unique_ptr<EnergyTerm> term = makeTerm(c, model, 2e-3);
    ASSERT_TRUE(term->hasVertexDerivatives()) << model;
    Probe p = probeOf(*term, *c.mesh);
    // The mid-edge model projects the assembled Hessian per hinge, an element per element: its
    // projected block is only checked to be PSD.
    p.projectedIsAssembled = model != "midedge";
    const double projected = checkVertexAccess(p, x);
    if (model == "dihedral") {
      EXPECT_GT(projected, 1e-6) << "the projection is exercised";
    }
  }
}

// The air, a dissipative term: its share of Phi at v = gamma (x - xc), with normals and areas
// lagged at the start of the substep.
TEST(VertexAccess, Air) {
  const Cloth c = sheet(3);
  const VectorX x0 = deformed(*c.mesh, 13);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  VectorX x = x0;
  for (Index i = 0; i < x.size(); ++i) x[i] += 0.02 * u(rng);  // up to 2 m/s over 10 ms
  AirSettings settings;
  settings.wind = Eigen::Vector3d(0.5, -0.3, 0.2);
  AirModel air(c.mesh, settings);
  AirTerm term;
  term.bind(air);
  EXPECT_TRUE(term.capabilities().perVertex);
  const std::vector<char> pinned(static_cast<std::size_t>(x.size()), 0);
  term.beginSubstep(backwardEulerFrame(x0, pinned));
  std::vector<std::vector<Index>> triangles;
  for (const Triangle& t : c.mesh->triangles) triangles.push_back({t[0], t[1], t[2]});
  auto pattern = std::make_shared<SparseHessian>(c.mesh->numVertices(), 3, triangles);
  checkVertexAccess(probeOf<TermRequest>(term, pattern, 3), x);
}

// The Model sums its terms; it offers the access only when all of them do.
TEST(VertexAccess, ModelSumsItsTerms) {
  const Cloth c = sheet(3);
  const VectorX x = deformed(*c.mesh, 14);
  const VectorX masses = lumpedMasses(*c.mesh, *c.rest, 0.2);
  Model model(c.mesh, c.rest, masses);
  model.addTerm(makeMembraneTerm(c.mesh, c.rest, *makeMaterial("stvk", Lame{30.0, 50.0})),
                TermKind::Membrane);
  std::unique_ptr<EnergyTerm> bending = makeTerm(c, "dihedral", 2e-3);
  EnergyTerm& dihedral = *bending;
  model.addTerm(std::move(bending), TermKind::Bending);
  ASSERT_TRUE(model.hasVertexDerivatives());
  ElasticTerm elastic;
  elastic.bind(model);
  EXPECT_TRUE(elastic.capabilities().perVertex);
  elastic.prepareVertexAccess();  // the Model's terms
  for (Index v : {0, 7, 12, 24}) {
    VertexDerivatives sum, membrane, bend;
    ASSERT_TRUE(elastic.vertexDerivatives(x, v, HessianMode::Exact, sum));
    ASSERT_TRUE(model.term(0).vertexDerivatives(x, v, HessianMode::Exact, membrane));
    ASSERT_TRUE(dihedral.vertexDerivatives(x, v, HessianMode::Exact, bend));
    EXPECT_LE((sum.force - membrane.force - bend.force).norm(), 1e-14 * sum.force.norm());
    EXPECT_LE((sum.hessian - membrane.hessian - bend.hessian).norm(), 1e-14 * sum.hessian.norm());
  }
}

// Per-vertex access needs prepareVertexAccess() (EnergyTerm's contract): before it a term
// returns false and leaves `out` as it was; after it, the blocks of a term prepared at once.
// Preparing again changes nothing. The membrane, every bending model, the Model, the air.
TEST(VertexAccess, NeedsPreparation) {
  const Cloth c = sheet(3);
  const VectorX x = deformed(*c.mesh, 15);
  VertexDerivatives untouched;
  untouched.force = Eigen::Vector3d(1.0, -2.0, 3.0);
  untouched.hessian.setConstant(7.0);
  // `late` refuses before its preparation, then serves what `early` (prepared at once) does.
  auto expectPreparation = [&](const std::string& name, auto& early, auto& late, const auto& at) {
    early.prepareVertexAccess();
    for (Index v : {0, 12, 24}) {
      VertexDerivatives d = untouched;
      EXPECT_FALSE(at(late, v, d)) << name << " vertex " << v;
      EXPECT_EQ(d.force, untouched.force) << name;
      EXPECT_EQ(d.hessian, untouched.hessian) << name;
    }
    for (int round = 0; round < 2; ++round) {
      late.prepareVertexAccess();
      for (Index v : {0, 12, 24}) {
        VertexDerivatives expected, d = untouched;
        ASSERT_TRUE(at(early, v, expected)) << name;
        ASSERT_TRUE(at(late, v, d)) << name << " vertex " << v;
        EXPECT_EQ(d.force, expected.force) << name;
        EXPECT_EQ(d.hessian, expected.hessian) << name;
      }
    }
  };
  auto energyTermAt = [&x](EnergyTerm& term, Index v, VertexDerivatives& d) {
    return term.vertexDerivatives(x, v, HessianMode::Projected, d);
  };
  const Material stvk = *makeMaterial("stvk", Lame{30.0, 50.0});
  expectPreparation("membrane", *makeMembraneTerm(c.mesh, c.rest, stvk),
                    *makeMembraneTerm(c.mesh, c.rest, stvk), energyTermAt);
  for (const std::string& model : bendingModelNames()) {
    expectPreparation(model, *makeTerm(c, model, 2e-3), *makeTerm(c, model, 2e-3), energyTermAt);
  }
  const VectorX masses = lumpedMasses(*c.mesh, *c.rest, 0.2);
  auto modelOf = [&] {
    auto model = std::make_unique<Model>(c.mesh, c.rest, masses);
    model->addTerm(makeMembraneTerm(c.mesh, c.rest, stvk), TermKind::Membrane);
    model->addTerm(makeTerm(c, "dihedral", 2e-3), TermKind::Bending);
    return model;
  };
  expectPreparation("model", *modelOf(), *modelOf(), [&x](Model& model, Index v, VertexDerivatives& d) {
    return model.vertexDerivatives(x, v, HessianMode::Exact, d);
  });
  const std::vector<char> pinned(static_cast<std::size_t>(x.size()), 0);
  const SubstepFrame frame = backwardEulerFrame(c.mesh->restPositions, pinned);
  AirModel earlyAir(c.mesh, AirSettings{}), lateAir(c.mesh, AirSettings{});
  AirTerm early, late;
  early.bind(earlyAir);
  late.bind(lateAir);
  early.beginSubstep(frame);
  late.beginSubstep(frame);
  expectPreparation("air", early, late, [&x](AirTerm& air, Index v, VertexDerivatives& d) {
    return air.vertexDerivatives(x, v, HessianMode::Exact, d);
  });
}

// Outside the domain (an inverted Neo-Hookean triangle) the vertices of the bad element get
// false; a vertex away from it is still served.
TEST(VertexAccess, RefusesAVertexOfAnElementOutsideItsDomain) {
  const Cloth c = sheet(2);
  VectorX x = c.mesh->restPositions;
  const Triangle& bad = c.mesh->triangles[0];
  // Mirror the first triangle's first vertex through its opposite edge: the triangle inverts.
  const Eigen::Vector2d p1 = x.segment<2>(2 * bad[1]), p2 = x.segment<2>(2 * bad[2]);
  const Eigen::Vector2d e = (p2 - p1).normalized();
  const Eigen::Vector2d p0 = x.segment<2>(2 * bad[0]);
  const Eigen::Vector2d foot = p1 + e * e.dot(p0 - p1);
  x.segment<2>(2 * bad[0]) = 2.0 * foot - p0;
  std::unique_ptr<EnergyTerm> term =
      makeMembraneTerm(c.mesh, c.rest, *makeMaterial("neo_hookean", Lame{30.0, 50.0}));
  term->prepareVertexAccess();
  VertexDerivatives d;
  for (Index v : bad) EXPECT_FALSE(term->vertexDerivatives(x, v, HessianMode::Exact, d)) << v;
  EXPECT_TRUE(term->vertexDerivatives(x, c.mesh->numVertices() - 1, HessianMode::Exact, d));
}

// The contact: two sheets 0.6 mm apart (self-contact, with friction) resting 0.5 mm above a
// plane and touching a sphere (barriers and friction), dHat = 1 mm; the obstacles, the
// self-contact, or both.
struct ContactFixture {
  Cloth cloth;
  std::unique_ptr<Model> model;
  std::unique_ptr<ContactModel> contact;
  BarrierTerm barriers;
  FrictionTerm friction;
  VectorX x0, x;
  std::vector<char> pinned;
  SubstepFrame frame;
  std::shared_ptr<SparseHessian> pattern;

  ContactFixture(bool obstacles, bool self) {
    const Cloth lower = sheet(3);
    Mesh both = *lower.mesh;
    const Index n = lower.mesh->numVertices();
    both.restPositions.conservativeResize(6 * n);
    for (Index i = 0; i < n; ++i) {
      both.restPositions.segment<3>(3 * (n + i)) =
          lower.mesh->restPositions.segment<3>(3 * i) + Eigen::Vector3d(0.013, 0.007, 6e-4);
    }
    for (const Triangle& t : lower.mesh->triangles) both.triangles.push_back({t[0] + n, t[1] + n, t[2] + n});
    cloth = withRest(both);
    model = std::make_unique<Model>(cloth.mesh, cloth.rest, lumpedMasses(*cloth.mesh, *cloth.rest, 0.2));
    std::vector<Obstacle> shapes;
    if (obstacles) {
      Obstacle plane;
      plane.name = "table";
      plane.shape.type = ShapeType::Plane;
      plane.geometry.translation() = Eigen::Vector3d(0.0, 0.0, -5e-4);
      plane.friction = 0.5;
      Obstacle ball;
      ball.name = "ball";
      ball.shape.type = ShapeType::Sphere;
      ball.shape.radius = 0.05;
      // 0.5 mm above the upper sheet's middle vertex (n + 12).
      ball.geometry.translation() = Eigen::Vector3d(0.113, 0.107, 0.05 + 1.1e-3);
      ball.friction = 0.4;
      shapes = {plane, ball};
    }
    ContactSettings settings;
    settings.distance = 1e-3;
    settings.selfCollision = self;
    settings.selfFriction = 0.3;
    contact = std::make_unique<ContactModel>(*model, shapes, settings, 9.81);
    std::mt19937 rng(9);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    x0 = cloth.mesh->restPositions;
    for (Index i = 0; i < x0.size(); ++i) x0[i] += 5e-5 * u(rng);
    x = x0;
    for (Index i = 0; i < x.size(); ++i) x[i] += 5e-5 * u(rng);
    pinned.assign(static_cast<std::size_t>(x.size()), 0);
    contact->obstacles().beginStep(0.0, 0.01);
    barriers.bind(*contact);
    friction.bind(*contact);
    frame = backwardEulerFrame(x0, pinned);
    barriers.beginSubstep(frame);  // the contact's substep (the potential adds it first)
    friction.beginSubstep(frame);
    barriers.prepareStep(x, VectorX::Zero(x.size()), nullptr);
    barriers.prepareVertexAccess();  // after the pairs changed (nothing to prepare yet)
    friction.prepareVertexAccess();
    std::unique_ptr<EnergyTerm> membrane =
        makeMembraneTerm(cloth.mesh, cloth.rest, *makeMaterial("stvk", Lame{1.0, 1.0}));
    pattern = std::make_shared<SparseHessian>(patternFor(*cloth.mesh, *membrane));
  }

  template <class Term>
  Probe probe(Term& term) {
    Probe p = probeOf<TermRequest>(term, pattern, 3);
    p.exactBlocks = false;
    p.step = 2e-8;  // m: the barriers vary on the scale of the distances (0.5 mm)
    return p;
  }

  // The largest force on the vertices [first, last) (N).
  double largestForce(Index first, Index last) const {
    double f = 0.0;
    VertexDerivatives d;
    for (Index v = first; v < last; ++v) {
      EXPECT_TRUE(barriers.vertexDerivatives(x, v, HessianMode::Exact, d));
      f = std::max(f, d.force.norm());
    }
    return f;
  }
};

TEST(VertexAccess, ContactBarriersAndFriction) {
  for (const auto& [obstacles, self] : {std::pair{true, false}, {false, true}, {true, true}}) {
    ContactFixture f(obstacles, self);
    EXPECT_TRUE(f.barriers.capabilities().perVertex);
    EXPECT_TRUE(f.friction.capabilities().perVertex);
    checkVertexAccess(f.probe(f.barriers), f.x);
    checkVertexAccess(f.probe(f.friction), f.x);
    // The friction continues the barriers' sum (continuesSum): the two give the bits of the
    // contact's energy summed as one.
    TermRequest r;
    r.energyStart = f.barriers.evaluate(f.x, TermRequest{}).energy;
    EXPECT_EQ(f.friction.evaluate(f.x, r).energy,
              f.contact->evaluate(f.x, nullptr, nullptr, nullptr, 1.0));
    EXPECT_GT(f.friction.evaluate(f.x, TermRequest{}).energy, 0.0) << "friction takes part";
    // Every part it has takes part: without self-contact only the obstacles push (the lower
    // sheet on the table, the ball's vertices of the upper sheet); with it both sheets.
    const Index n = f.cloth.mesh->numVertices() / 2;
    EXPECT_GT(f.largestForce(0, n), 0.0) << obstacles << self;
    EXPECT_GT(f.largestForce(n, 2 * n), 0.0) << obstacles << self;
  }
}

// The contact's per-vertex tables go stale when its pairs change (a new broad phase in
// prepareStep, a new substep's friction in beginSubstep): per-vertex access refuses, leaving `out`
// alone, until prepareVertexAccess() rebuilds them, and then gives what it gave before (the
// same pairs here). The Newton solver, which never asks, never builds them.
TEST(VertexAccess, ContactNeedsPreparationAfterItsPairsChange) {
  ContactFixture f(true, true);
  const Index v = f.cloth.mesh->numVertices() / 2 + 12;  // the upper sheet's, under the ball
  VertexDerivatives barrier, friction;
  ASSERT_TRUE(f.barriers.vertexDerivatives(f.x, v, HessianMode::Projected, barrier));
  ASSERT_TRUE(f.friction.vertexDerivatives(f.x, v, HessianMode::Projected, friction));
  ASSERT_GT(barrier.force.norm(), 0.0);
  ASSERT_GT(friction.force.norm(), 0.0);
  VertexDerivatives untouched;
  untouched.force = Eigen::Vector3d(1.0, 2.0, 3.0);
  auto expectStaleThenFresh = [&](const std::string& change) {
    VertexDerivatives d = untouched;
    EXPECT_FALSE(f.barriers.vertexDerivatives(f.x, v, HessianMode::Projected, d)) << change;
    EXPECT_FALSE(f.friction.vertexDerivatives(f.x, v, HessianMode::Projected, d)) << change;
    EXPECT_EQ(d.force, untouched.force) << change;
    f.barriers.prepareVertexAccess();
    ASSERT_TRUE(f.barriers.vertexDerivatives(f.x, v, HessianMode::Projected, d)) << change;
    EXPECT_EQ(d.force, barrier.force) << change;
    EXPECT_EQ(d.hessian, barrier.hessian) << change;
    ASSERT_TRUE(f.friction.vertexDerivatives(f.x, v, HessianMode::Projected, d)) << change;
    EXPECT_EQ(d.force, friction.force) << change;
  };
  f.barriers.prepareStep(f.x, VectorX::Zero(f.x.size()), nullptr);
  expectStaleThenFresh("prepareStep");
  f.barriers.beginSubstep(f.frame);
  f.friction.beginSubstep(f.frame);
  f.barriers.prepareStep(f.x, VectorX::Zero(f.x.size()), nullptr);
  expectStaleThenFresh("beginSubstep");
}
