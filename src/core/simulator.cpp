#include "fem_cloth/core/simulator.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>

namespace fem_cloth {

BalanceJudgement judgeBalance(const EnergyReport& energies, double tolerance) {
  BalanceJudgement j;
  // A NaN balance is never within tolerance: it counts as unbounded.
  j.created = std::isnan(energies.balanceError) ? std::numeric_limits<double>::infinity()
                                                : std::max(energies.balanceError, 0.0);
  j.scale = std::max(energies.energyScale, 1e-12);
  j.tolerance = tolerance;
  return j;
}

std::string BalanceJudgement::text() const {
  std::ostringstream msg;
  msg << std::setprecision(4) << "energy created (net) " << created << " J = " << 100.0 * fraction()
      << " % of the energy scale " << scale << " J (at most " << 100.0 * tolerance << " % accepted)";
  return msg.str();
}

std::string BalanceJudgement::warning() const {
  return "energy balance out of tolerance: " + text() +
         "; the run created energy it was not given, and its energies are not to be trusted (a "
         "smaller dt or more integrator.substeps may help; docs/integrators.md, \"Acceptance\")";
}

Simulator::Simulator(std::shared_ptr<Model> model, std::unique_ptr<Integrator> integrator,
                     SimulatorSettings settings)
    : model_(std::move(model)),
      integrator_(std::move(integrator)),
      settings_(settings),
      acceptance_(settings.acceptance) {
  const Index n = model_->numDofs();
  const int d = model_->dim();
  gravityForce_.resize(n);
  for (Index i = 0; i < model_->numVertices(); ++i) {
    for (int k = 0; k < d; ++k) {
      gravityForce_[d * i + k] = model_->vertexMasses()[i] * settings_.gravity[k];
    }
  }
  pinned_.assign(n, 0);
  pinTarget_ = VectorX::Zero(n);
  pinVelocity_ = VectorX::Zero(n);
  externalForce_ = VectorX::Zero(n);
  pinForce_ = VectorX::Zero(n);
  previousPinForce_ = VectorX::Zero(n);
  state_.x = model_->mesh().restPositions;
  state_.v = VectorX::Zero(n);
  lengthScale_ = restBoundingBoxDiagonal(model_->mesh());
  sizeScale_ = accelerationScale(settings_.gravity.norm()) * model_->totalMass() * lengthScale_;
  rebuildExternalForce();
  snapshotInitial();
}

void Simulator::setAcceptance(const AcceptanceSettings& settings) {
  settings_.acceptance = settings;
  acceptance_ = StepAcceptance(settings);
}

double Simulator::kineticEnergy(const VectorX& v) const {
  return 0.5 * v.dot(model_->dofMasses().cwiseProduct(v));
}

double Simulator::mechanicalEnergy() {
  const EvalResult elastic = model_->evaluate(state_.x, EvalRequest{});
  return kineticEnergy(state_.v) + elastic.energy - gravityForce_.dot(state_.x);
}

double Simulator::contactEnergyNow() {
  if (!contactNow_) contactNow_ = contact_ ? contact_->storedEnergy(state_.x, pinned_) : 0.0;
  return *contactNow_;
}

double Simulator::storedEnergy(const State& s) {
  return kineticEnergy(s.v) + model_->energies(s.x).total();
}

void Simulator::restartAccount() {
  book_ = EnergyBook{};
  pinForce_.setZero();
  previousPinForce_.setZero();
}

void Simulator::snapshotInitial() {
  initial_ = Initial{state_, pinned_, pinTarget_, pinVelocity_, forces_};
  restartAccount();
  initialTotal_ = storedEnergy(initial_.state);
}

Status Simulator::setInitialState(const VectorX& x, const VectorX& v) {
  const Index n = model_->numDofs();
  if (x.size() != n) {
    return Error{"initial positions have " + std::to_string(x.size()) + " entries, expected " +
                 std::to_string(n)};
  }
  if (v.size() != 0 && v.size() != n) {
    return Error{"initial velocities have " + std::to_string(v.size()) + " entries, expected " +
                 std::to_string(n)};
  }
  if (!x.allFinite() || (v.size() != 0 && !v.allFinite())) {
    return Error{"initial state has non-finite values"};
  }
  state_.x = x;
  state_.v = v.size() == 0 ? VectorX::Zero(n) : v;
  state_.clearHistory();
  forgetEnergy();
  state_.time = 0.0;
  state_.step = 0;
  for (Index i = 0; i < n; ++i) {
    if (pinned_[i]) pinTarget_[i] = x[i];
  }
  integrator_->invalidate();
  snapshotInitial();
  return Status::success();
}

void Simulator::reset() {
  state_ = initial_.state;
  forgetEnergy();
  pinned_ = initial_.pinned;
  pinTarget_ = initial_.pinTarget;
  pinVelocity_ = initial_.pinVelocity;
  forces_ = initial_.forces;
  rebuildExternalForce();
  integrator_->invalidate();
  if (obstacles_) obstacles_->reset();
  restartAccount();
  lastReport_ = StepReport();
  currentSubsteps_ = std::max(settings_.minSubsteps, 1);
  cleanSteps_ = 0;
}

void Simulator::continueFrom(Simulator& from) {
  const EnergyReport before = from.energies();
  state_ = from.state_;
  forgetEnergy();
  pinned_ = from.pinned_;
  pinTarget_ = from.pinTarget_;
  pinVelocity_ = from.pinVelocity_;
  forces_ = from.forces_;
  rebuildExternalForce();
  pinForce_ = from.pinForce_;
  previousPinForce_ = from.previousPinForce_;
  lastReport_ = from.lastReport_;
  currentSubsteps_ = from.currentSubsteps_;
  cleanSteps_ = from.cleanSteps_;
  initial_ = from.initial_;
  book_ = from.book_;
  // What reset() goes back to is measured with the new parameters; the balance runs on
  // unbroken: the change's energy, the jump of the total here less that of the initial total.
  initialTotal_ = storedEnergy(initial_.state);
  const EnergyReport after = energies();
  book_.liveWork = from.book_.liveWork + (after.total - before.total) - (initialTotal_ - from.initialTotal_);
  // The energy scale of the run's balance leaves out what the change put into the held energy.
  book_.liveHeld += (after.kinetic + after.strain + after.bending) - (before.kinetic + before.strain + before.bending);
}

Status Simulator::checkVertex(Index vertex) const {
  if (vertex < 0 || vertex >= model_->numVertices()) {
    return Error{"vertex " + std::to_string(vertex) + " does not exist (the mesh has " +
                 std::to_string(model_->numVertices()) + " vertices, 0 to " +
                 std::to_string(model_->numVertices() - 1) + ")"};
  }
  return Status::success();
}

Status Simulator::pin(Index vertex, const Eigen::Vector3d& target,
                      const Eigen::Vector3d& velocity) {
  if (Status s = checkVertex(vertex); !s) return s;
  const int d = dim();
  if (!target.head(d).allFinite() || !velocity.head(d).allFinite()) {
    return Error{"pin target of vertex " + std::to_string(vertex) + " is not finite"};
  }
  for (int k = 0; k < d; ++k) {
    pinned_[d * vertex + k] = 1;
    pinTarget_[d * vertex + k] = target[k];
    pinVelocity_[d * vertex + k] = velocity[k];
  }
  return Status::success();
}

Status Simulator::pinInPlace(Index vertex) {
  if (Status s = checkVertex(vertex); !s) return s;
  const int d = dim();
  Eigen::Vector3d here = Eigen::Vector3d::Zero();
  here.head(d) = state_.x.segment(d * vertex, d);
  return pin(vertex, here);
}

Status Simulator::release(Index vertex) {
  if (Status s = checkVertex(vertex); !s) return s;
  const int d = dim();
  for (int k = 0; k < d; ++k) {
    pinned_[d * vertex + k] = 0;
    pinVelocity_[d * vertex + k] = 0.0;
    pinForce_[d * vertex + k] = 0.0;
    previousPinForce_[d * vertex + k] = 0.0;
  }
  return Status::success();
}

void Simulator::releaseAll() {
  std::fill(pinned_.begin(), pinned_.end(), 0);
  pinVelocity_.setZero();
  pinForce_.setZero();
  previousPinForce_.setZero();
}

bool Simulator::isPinned(Index vertex) const {
  return vertex >= 0 && vertex < model_->numVertices() && pinned_[dim() * vertex] != 0;
}

std::vector<Index> Simulator::pinnedVertices() const {
  std::vector<Index> out;
  for (Index i = 0; i < model_->numVertices(); ++i) {
    if (pinned_[dim() * i]) out.push_back(i);
  }
  return out;
}

Eigen::Vector3d Simulator::pinTarget(Index vertex) const {
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  const int d = dim();
  for (int k = 0; k < d; ++k) t[k] = pinTarget_[d * vertex + k];
  return t;
}

Status Simulator::applyForce(Index vertex, const Eigen::Vector3d& force, double duration) {
  if (Status s = checkVertex(vertex); !s) return s;
  if (!force.allFinite()) {
    return Error{"force on vertex " + std::to_string(vertex) + " is not finite"};
  }
  if (!(duration > 0.0)) {
    return Error{"force duration must be positive (s), got " + std::to_string(duration)};
  }
  const double expiresAt = std::isinf(duration) ? duration : state_.time + duration;
  auto it = std::find_if(forces_.begin(), forces_.end(),
                         [&](const Force& f) { return f.vertex == vertex; });
  if (it != forces_.end()) {
    *it = Force{vertex, force, expiresAt};
  } else {
    forces_.push_back(Force{vertex, force, expiresAt});
  }
  rebuildExternalForce();
  return Status::success();
}

Status Simulator::clearForce(Index vertex) {
  if (Status s = checkVertex(vertex); !s) return s;
  forces_.erase(std::remove_if(forces_.begin(), forces_.end(),
                               [&](const Force& f) { return f.vertex == vertex; }),
                forces_.end());
  rebuildExternalForce();
  return Status::success();
}

void Simulator::clearForces() {
  forces_.clear();
  rebuildExternalForce();
}

void Simulator::rebuildExternalForce() {
  externalForce_.setZero();
  const int d = dim();
  for (const Force& f : forces_) externalForce_.segment(d * f.vertex, d) += f.force.head(d);
  referenceAcceleration_ = std::max(accelerationScale(settings_.gravity.norm()),
                                    externalForce_.lpNorm<1>() / model_->totalMass());
}

void Simulator::setAir(std::unique_ptr<AirModel> air) { air_ = std::move(air); }

void Simulator::setContact(std::shared_ptr<ObstacleSet> obstacles, std::unique_ptr<ContactModel> barriers,
                           std::unique_ptr<ProjectionContact> projection) {
  obstacles_ = std::move(obstacles);
  contact_ = std::move(barriers);
  projection_ = std::move(projection);
}

StepReport Simulator::step() { return step(settings_.dt); }

StepInput Simulator::stepInput(double dt) {
  // End-of-step pin targets: a pin is at pinTarget_ now and moves on with its velocity, so a
  // scripted pin follows p(t) = p0 + v t exactly at the end of every step.
  stepPinTarget_ = pinTarget_ + pinVelocity_ * dt;
  StepInput input;
  input.model = model_.get();
  input.gravityForce = &gravityForce_;
  input.externalForce = &externalForce_;
  input.pinned = &pinned_;
  input.pinTarget = &stepPinTarget_;
  input.damping = settings_.damping;
  input.residualScale.acceleration = referenceAcceleration_;
  input.residualScale.tolerance = settings_.acceptance.forceTolerance;
  input.displacement = settings_.acceptance.displacement;
  input.displacement.floor *= lengthScale_;
  if (obstacles_) obstacles_->beginStep(state_.time, dt);
  input.contact = contact_.get();
  input.projection = projection_.get();
  input.air = air_.get();
  return input;
}

Status Simulator::accept(const StepReport& r, double energyStart, EnergyStep& energy) {
  energyRefused_ = false;
  if (Status s = acceptance_.converged(r, dim()); !s) return s;
  if (Status s = acceptance_.valid(*model_, state_.x); !s) return s;
  const double kinetic = kineticEnergy(state_.v);
  const EvalResult end = model_->evaluate(state_.x, EvalRequest{});
  if (!end.inDomain) {
    return Error{"element " + std::to_string(end.firstBadElement) +
                 " left its material's domain in the step (inverted or collapsed)"};
  }
  const double elastic = end.energy;
  energy.start = energyStart;
  energy.end = kinetic + elastic - gravityForce_.dot(state_.x) + r.contactEnergy;
  energy.contactStored = r.contactEnergy - contactEnergyNow();
  energy.held = std::max(heldAtStart(energyStart), kinetic + elastic);
  energy.externalWork = externalForce_.dot(state_.x - backup_.x);
  energy.pinWork = r.pinWork;
  energy.contactWork = r.contactWork;
  energy.airWork = r.airWork;
  energy.dissipated = r.dissipated;
  energyRefused_ = true;
  if (Status s = acceptance_.energyConserved(energy, integrator_->energyTolerance(), sizeScale_); !s) {
    return s;
  }
  Status s = acceptance_.runEnergyConserved(book_.created - book_.numerical, energy, runEnergyScale(energy));
  energyRefused_ = !s.ok();
  return s;
}

double Simulator::runEnergyScale(const EnergyStep& step) const {
  const double work = std::abs(book_.externalWork + step.externalWork) + std::abs(book_.pinWork + step.pinWork) +
                      std::abs(book_.contactWork + step.contactWork) + std::abs(book_.airWork + step.airWork);
  return std::max({sizeScale_, book_.heldMost, step.held - std::max(book_.liveHeld, 0.0), work});
}

void Simulator::EnergyBook::add(const EnergyStep& step) {
  externalWork += step.externalWork;
  pinWork += step.pinWork;
  contactWork += step.contactWork;
  contactEnergy += step.contactStored;
  airWork += step.airWork;
  dissipated += step.dissipated;
  const double gained = step.created();
  if (gained > 0.0) {
    created += gained;
  } else {
    numerical -= gained;
  }
  heldMost = std::max(heldMost, step.held - std::max(liveHeld, 0.0));
}

void Simulator::flagPinJump(StepReport& r, double energyStart, double dt) {
  const double scale = std::max(sizeScale_, heldAtStart(energyStart));
  if (!(std::abs(r.pinWork) > kPinJumpWork * scale)) return;
  ++book_.pinJumps;
  const int d = dim();
  Index farthest = -1;
  double moved = 0.0;
  for (Index i = 0; i < model_->numVertices(); ++i) {
    if (!pinned_[d * i]) continue;
    const double m = (state_.x.segment(d * i, d) - backup_.x.segment(d * i, d)).norm();
    if (farthest < 0 || m > moved) {
      farthest = i;
      moved = m;
    }
  }
  std::ostringstream msg;
  msg << std::setprecision(3) << "pin jump in the step at t = " << backup_.time << " s: the pins did "
      << r.pinWork << " J of work in this one step, " << std::abs(r.pinWork) / scale
      << " times the cloth's energy scale " << scale
      << " J (the larger of weight x size and the energy it held); vertex " << farthest << " moved "
      << moved << " m in " << dt << " s (" << moved / dt
      << " m/s). The step is right for that motion (its work is booked), but it yanks the cloth: "
         "pin a vertex where it is and move its target gradually, or pin it in place in a moving "
         "frame (docs/node.md, Commands)";
  r.warning = msg.str();
}

void Simulator::commit(const StepReport& r, const EnergyStep& energy, double dt) {
  book_.add(energy);
  energyNow_ = energy.end;
  contactNow_ = r.contactEnergy;
  if (obstacles_) obstacles_->commitStep();
  previousPinForce_ = pinForce_;
  state_.time += dt;
  ++state_.step;
  pinTarget_.swap(stepPinTarget_);
  lastReport_ = r;
}

void Simulator::dropExpiredForces(double dt) {
  const std::size_t before = forces_.size();
  forces_.erase(std::remove_if(forces_.begin(), forces_.end(),
                               [&](const Force& f) { return f.expiresAt <= state_.time + 1e-12 * dt; }),
                forces_.end());
  if (forces_.size() != before) rebuildExternalForce();
}

int Simulator::startingSubsteps() {
  const int minSubsteps = std::max(settings_.minSubsteps, 1);
  if (currentSubsteps_ > minSubsteps && cleanSteps_ >= kRelaxAfter) {
    currentSubsteps_ = std::max(minSubsteps, currentSubsteps_ / 2);
    cleanSteps_ = 0;
  }
  return std::max(minSubsteps, currentSubsteps_);
}

StepReport Simulator::attempt(const StepInput& input, double dt, int substeps, double energyStart,
                              EnergyStep& energy) {
  StepReport r = integrator_->step(input, state_, dt, substeps, pinForce_);
  if (r.ok && !(state_.x.allFinite() && state_.v.allFinite())) {
    r.ok = false;
    r.error = "the state became non-finite";
  } else if (r.ok) {
    if (Status s = accept(r, energyStart, energy); !s) {
      r.ok = false;
      r.error = integrator_->name() + ": " + s.error();
      r.energyRefused = energyRefused_;
    }
  }
  return r;
}

namespace {

// The step's report from its latest attempt: the counts add up over the attempts, the rest is
// the latest attempt's (the dissipation and pin work only of an accepted one: commit books them).
void takeAttempt(StepReport& total, const StepReport& r) {
  total.substeps = r.substeps;
  total.newtonIterations += r.newtonIterations;
  total.quasiNewtonIterations += r.quasiNewtonIterations;
  total.solverFallbacks += r.solverFallbacks;
  total.lineSearchBacktracks += r.lineSearchBacktracks;
  total.newtonTimes += r.newtonTimes;
  total.iterations += r.iterations;
  total.unbalanced = r.unbalanced;
  total.displacement = r.displacement;
  total.residual = r.unbalanced.largest;
  total.dtUsed = r.dtUsed;
  total.contactChecks += r.contactChecks;
  total.contacts = r.contacts;
  total.contactWork = r.contactWork;
  total.contactEnergy = r.contactEnergy;
  total.airWork = r.airWork;
  total.minContactDistance = r.minContactDistance;
  total.boxDepth = r.boxDepth;
  total.boxDepthWhere = r.boxDepthWhere;
  if (r.ok) {
    total.dissipated = r.dissipated;
    total.pinWork = r.pinWork;
    total.ok = true;
    total.error.clear();
  } else {
    total.ok = false;
    total.error = r.error;
  }
}

}  // namespace

StepReport Simulator::failed(StepReport total, int substeps, const std::string& firstError, double energyStart) {
  if (!firstError.empty() && firstError != total.error) {
    // The retries may fail for another reason (a substep limit): the first one says what went wrong.
    total.error += " (first attempt: " + firstError + ")";
  }
  energyNow_ = energyStart;
  std::ostringstream msg;
  msg << "step at t = " << state_.time << " s failed after " << total.rollbacks
      << " rollbacks (last try: " << substeps << " substeps): " << total.error
      << "; the state is unchanged";
  total.error = msg.str();
  pinForce_ = previousPinForce_;
  lastReport_ = total;
  return total;
}

StepReport Simulator::step(double dt) {
  StepReport total;
  if (!(dt > 0.0) || !std::isfinite(dt)) {
    total.ok = false;
    total.error = "time step must be positive and finite, got " + std::to_string(dt);
    lastReport_ = total;
    return total;
  }
  dropExpiredForces(dt);
  StepInput input = stepInput(dt);
  backup_ = state_;
  const double energyStart = energyNow_ ? *energyNow_ : mechanicalEnergy() + contactEnergyNow();
  // What acceptance test (b) allows the step to create at least (its scale can only grow with
  // the step's work and end energy): the implicit steppers converge within a fraction of it.
  input.energyBudget = integrator_->energyTolerance() * std::max(sizeScale_, heldAtStart(energyStart));
  EnergyStep energy;
  int substeps = startingSubsteps();
  std::string firstError;
  for (int k = 0; k <= settings_.maxRetries; ++k) {
    const StepReport r = attempt(input, dt, substeps, energyStart, energy);
    takeAttempt(total, r);
    if (r.ok) {
      if (k > 0) {
        currentSubsteps_ = substeps;
        cleanSteps_ = 0;
      } else {
        ++cleanSteps_;
      }
      flagPinJump(total, energyStart, dt);
      commit(total, energy, dt);
      return total;
    }
    if (firstError.empty()) firstError = r.error;
    state_ = backup_;
    integrator_->invalidate();
    if (!r.retryable) break;
    // A step within test (a) that test (b) refuses: the energy its remaining solver error made
    // (near stiff contact barriers, and in the booking of a moving obstacle's work, more than
    // the estimate test (a) bounds) is removed by solving the same substeps 100x tighter, once,
    // far cheaper than doubling them. If that fails too, the substeps are doubled as usual.
    if (r.energyRefused && r.displacement.measured() && total.tightened == 0 && k < settings_.maxRetries) {
      input.displacement.ratio *= 0.01;
      input.displacement.cap *= 0.01;
      ++total.rollbacks;
      ++total.tightened;
      continue;
    }
    if (k < settings_.maxRetries) {
      ++total.rollbacks;
      substeps = std::max(substeps, r.substeps) * 2;
    }
  }
  return failed(std::move(total), substeps, firstError, energyStart);
}

EnergyReport Simulator::energies() {
  EnergyReport e;
  e.kinetic = kineticEnergy(state_.v);
  const Model::Energies elastic = model_->energies(state_.x);
  e.strain = elastic.membrane + elastic.other;
  e.bending = elastic.bending;
  e.gravity = -gravityForce_.dot(state_.x - initial_.state.x);
  e.externalWork = book_.externalWork;
  e.pinWork = book_.pinWork;
  e.contactWork = book_.contactWork;
  e.contactEnergy = book_.contactEnergy;
  e.airWork = book_.airWork;
  e.dissipated = book_.dissipated;
  e.liveWork = book_.liveWork;
  e.total = e.kinetic + e.strain + e.bending + e.gravity + e.contactEnergy;
  e.initialTotal = initialTotal_;
  e.balanceError = e.total - e.externalWork - e.pinWork - e.contactWork - e.airWork - e.liveWork +
                   e.dissipated - e.initialTotal;
  e.numericalDissipation = book_.numerical;
  e.created = book_.created;
  e.energyScale = runEnergyScale(EnergyStep{});
  e.pinJumps = book_.pinJumps;
  return e;
}

}  // namespace fem_cloth
