#include "fem_cloth/core/integrators/registry.h"

#include <algorithm>

#include "fem_cloth/core/contact/pinch.h"
#include "fem_cloth/core/contact/surface_reach.h"
#include "fem_cloth/core/scene.h"

namespace fem_cloth {

// Each entry is defined in its integrator's .cpp (implicit_registration.cpp for the implicit
// pair); this list is the only other place that names them (see registry.h for why a list).
IntegratorEntry symplecticEulerEntry();
IntegratorEntry backwardEulerEntry();
IntegratorEntry bdf2Entry();
IntegratorEntry xpbdEntry();
IntegratorEntry projectiveDynamicsEntry();

const std::vector<IntegratorEntry>& integratorRegistry() {
  static const std::vector<IntegratorEntry> entries = {
      symplecticEulerEntry(), backwardEulerEntry(), bdf2Entry(), xpbdEntry(),
      projectiveDynamicsEntry()};
  return entries;
}

const std::vector<std::string>& integratorNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const IntegratorEntry& e : integratorRegistry()) out.push_back(e.name);
    return out;
  }();
  return names;
}

namespace {

template <typename T>
bool listed(const std::vector<T>& allowed, const T& value) {
  return allowed.empty() || std::find(allowed.begin(), allowed.end(), value) != allowed.end();
}

/// One thing a scene may ask of its integrator: the key that asks, whether the scene asks, and
/// whether an integrator with these capabilities gives it.
struct Requirement {
  std::string key;
  std::function<bool(const Scene&)> asked;
  std::function<bool(const IntegratorCapabilities&, const Scene&)> given;
  std::string what;  ///< "material 'stvk'", filled in for the scene
  std::string supported;  ///< "; supported: arap" (empty for yes/no capabilities)
  std::string hint;       ///< how to satisfy the integrator instead
};

std::vector<Requirement> requirements(const Scene& s, const IntegratorCapabilities& c) {
  const std::string bendingDefault = s.bendingModel == BendingModel::Midedge ? " (the default)" : "";
  const std::vector<std::string> bendingModels = enumNames(bendingModelNames(), c.bendingModels);
  const auto firstOf = [](const std::vector<std::string>& v) { return v.empty() ? "" : v.front(); };
  const bool projection = c.contact == ContactMethod::Projection;
  const std::optional<ObstaclePinch> pinch = projection ? findScenePinch(s) : std::nullopt;
  const std::optional<SurfaceReach> reach = projection ? findSurfaceReach(s) : std::nullopt;
  return {
      {"material.model", [](const Scene&) { return true; },
       [](const IntegratorCapabilities& k, const Scene& x) { return listed(k.materials, x.materialModel); },
       "material '" + s.materialModel + "'", "; supported: " + commaList(c.materials),
       "set material.model: " + firstOf(c.materials)},
      {"mesh.dim", [](const Scene& x) { return meshDim(x) == 2; },
       [](const IntegratorCapabilities& k, const Scene&) { return k.planar; },
       "planar meshes (mesh.dim 2); it simulates cloth (dim 3) only", "", "set mesh.dim: 3"},
      {"bending.model", [](const Scene& x) { return x.bendingStiffness > 0.0; },
       [](const IntegratorCapabilities& k, const Scene& x) { return listed(k.bendingModels, x.bendingModel); },
       "bending model '" + bendingModelName(s.bendingModel) + "'" + bendingDefault,
       "; supported: " + commaList(bendingModels), "set bending.model: " + firstOf(bendingModels)},
      {"damping.stiffness", [](const Scene& x) { return x.damping.stiffnessProportional > 0.0; },
       [](const IntegratorCapabilities& k, const Scene&) { return k.stiffnessDamping; },
       "stiffness damping", "", "set it to 0 and use damping.mass"},
      {"contact.self_collision", [](const Scene& x) { return x.contact.selfCollision; },
       [](const IntegratorCapabilities& k, const Scene&) { return k.selfContact; }, "self-contact",
       "", "turn it off"},
      {"obstacles", [](const Scene& x) { return !x.obstacles.empty(); },
       [](const IntegratorCapabilities& k, const Scene&) { return k.contact != ContactMethod::None; },
       "contact with obstacles", "", "remove the obstacles"},
      // Issue 30: the projection cannot keep a vertex out of two pads closer than 2 dHat
      // (contact/pinch.h).
      {"obstacles", [pinch](const Scene&) { return pinch.has_value(); },
       [](const IntegratorCapabilities& k, const Scene&) { return k.contact == ContactMethod::Barriers; },
       "a pinch between obstacles: " + (pinch ? pinchText(*pinch, s.contact.distance) : std::string()) +
           ", where its projection cannot keep a vertex contact.distance from both",
       "", pinch && !pinch->frame.empty() ? "script their motion (velocity, trajectory) instead of a tf frame"
                                           : "keep the obstacles 2 contact.distance apart"},
      // Issue 30: the projection keeps vertices out, not the surface between them
      // (contact/surface_reach.h).
      {"obstacles", [reach](const Scene&) { return reach.has_value(); },
       [](const IntegratorCapabilities& k, const Scene&) { return k.contact == ContactMethod::Barriers; },
       "keeping the cloth's surface out of " + (reach ? surfaceReachText(*reach, s) : std::string()), "",
       reach ? surfaceReachHint(*reach, s) : std::string()},
  };
}

}  // namespace

const std::vector<std::string>& displacementErrorKeys() {
  static const std::vector<std::string> keys = {"error_ratio", "error_cap", "error_floor"};
  return keys;
}

Status readDisplacementTolerance(const SettingsReader& r, Scene& s) {
  FEM_CLOTH_CHECK(r.number("error_ratio", s.displacement.ratio));
  FEM_CLOTH_CHECK(r.number("error_cap", s.displacement.cap));
  return r.number("error_floor", s.displacement.floor);
}

Status checkDisplacementTolerance(const Scene& s) {
  FEM_CLOTH_CHECK(inRange(s.displacement.ratio, 1e-6, 1.0, "integrator.error_ratio", ""));
  FEM_CLOTH_CHECK(inRange(s.displacement.cap, 1e-6, 0.5, "integrator.error_cap", ""));
  return inRange(s.displacement.floor, 1e-12, 1e-2, "integrator.error_floor", "cloth sizes");
}

Expected<const IntegratorEntry*> findIntegrator(const std::string& name) {
  for (const IntegratorEntry& e : integratorRegistry()) {
    if (e.name == name) return &e;
  }
  return Error{"unknown integrator '" + printableText(name, 100) + "' (known: " +
               commaList(integratorNames()) + ")"};
}

std::vector<std::string> integratorKeys() {
  std::vector<std::string> keys = {"name", "dt", "substeps", "max_retries"};
  for (const IntegratorEntry& e : integratorRegistry()) {
    for (const std::string& k : e.keys) {
      if (std::find(keys.begin(), keys.end(), k) == keys.end()) keys.push_back(k);
    }
  }
  return keys;
}

std::vector<std::string> integratorKeysOf(const std::string& name) {
  Expected<const IntegratorEntry*> found = findIntegrator(name);
  if (!found) return {};
  std::vector<std::string> keys = {"name", "dt", "substeps", "max_retries"};
  keys.insert(keys.end(), (*found)->keys.begin(), (*found)->keys.end());
  return keys;
}

namespace {

/// The integrators that read `key` (their own keys; the common ones are read by all).
std::vector<std::string> integratorsReading(const std::string& key) {
  std::vector<std::string> out;
  for (const IntegratorEntry& e : integratorRegistry()) {
    if (std::find(e.keys.begin(), e.keys.end(), key) != e.keys.end()) out.push_back(e.name);
  }
  return out;
}

bool readsKey(const std::string& name, const std::string& key) {
  const std::vector<std::string> keys = integratorKeysOf(name);
  return keys.empty() || std::find(keys.begin(), keys.end(), key) != keys.end();
}

}  // namespace

Status checkIntegratorUsesKey(const std::string& name, const std::string& key, const std::string& source) {
  const std::vector<std::string> readers = integratorsReading(key);
  if (readers.empty() || readsKey(name, key)) return Status::success();
  return Error{source + ": integrator " + name + " does not use integrator." + key + " (read by " +
               commaList(readers) + "); " + name + " reads: " + commaList(integratorKeysOf(name))};
}

std::string unusedIntegratorKeyNote(const std::string& name, const std::string& key) {
  const std::vector<std::string> readers = integratorsReading(key);
  if (readers.empty() || readsKey(name, key)) return "";
  return "integrator." + key + " is ignored: integrator " + name + " does not use it (read by " +
         commaList(readers) + ")";
}

Status checkIntegratorSupports(const Scene& s) {
  Expected<const IntegratorEntry*> found = findIntegrator(s.integrator);
  if (!found) return Error{"integrator.name: " + found.error()};
  const IntegratorEntry& entry = **found;
  for (const Requirement& r : requirements(s, entry.supports)) {
    if (!r.asked(s) || r.given(entry.supports, s)) continue;
    std::vector<std::string> others;
    for (const IntegratorEntry& e : integratorRegistry()) {
      if (r.given(e.supports, s)) others.push_back(e.name);
    }
    const std::string choose = others.empty() ? "" : ", or choose an integrator that does: " + commaList(others);
    return Error{r.key + ": integrator " + entry.name + " does not support " + r.what + r.supported +
                 " (" + r.hint + choose + ")"};
  }
  return Status::success();
}

std::string capabilitiesText(const IntegratorCapabilities& c) {
  std::vector<std::string> parts;
  parts.push_back("materials: " + (c.materials.empty() ? std::string("all") : commaList(c.materials)));
  const std::vector<std::string> bendingModels = enumNames(bendingModelNames(), c.bendingModels);
  parts.push_back("bending: " + (bendingModels.empty() ? std::string("all") : commaList(bendingModels)));
  parts.push_back(c.planar ? "2D and 3D" : "3D only");
  parts.push_back(std::string(c.contact == ContactMethod::Barriers     ? "obstacles (barriers)"
                              : c.contact == ContactMethod::Projection ? "obstacles (projection)"
                                                                       : "no obstacles") +
                  (c.selfContact ? ", self-contact" : ""));
  if (!c.stiffnessDamping) parts.push_back("mass damping only");
  if (c.needsHessian) parts.push_back("assembles Hessians");
  std::string out;
  for (const std::string& p : parts) out += (out.empty() ? "" : "; ") + p;
  return out;
}

}  // namespace fem_cloth
