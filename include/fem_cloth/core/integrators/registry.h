// The integrator registry: every time integrator a scene can name (`integrator.name`), with
// what it supports, the scene keys it reads and how it is built.
//
// Scene validation (which integrator accepts which scene), `fem_cloth_sim --help`, the report's
// "n/a" verdict and every refusal message are derived from these entries, so a rule such as
// "projective dynamics takes the ARAP membrane only" is written once, here, as a capability.
//
// The entries are listed explicitly in registry.cpp, each defined next to its integrator (in
// the integrator's own .cpp). Self-registration by static initialisers would need the core to
// be a shared library or every caller to reference each integrator's object file: in a static
// libfem_cloth_core.a the linker drops an object nothing refers to, and its registration with
// it, silently. The explicit list also fixes the order (the report's rows follow it).
#pragma once

#include <any>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "fem_cloth/core/bending_model.h"
#include "fem_cloth/core/expected.h"
#include "fem_cloth/core/integrators/integrator.h"
#include "fem_cloth/core/settings_reader.h"

namespace fem_cloth {

struct Scene;

/// What an integrator can simulate. A scene that asks for more is refused when it is loaded,
/// naming the key and the integrators that would take it.
/// How an integrator handles contact with obstacles: not at all, by projecting vertices out of
/// them after its updates (contact/projection_contact.h), or by the barrier terms of the
/// incremental potential it minimises (contact/contact_model.h). The scene builds only that one.
enum class ContactMethod { None, Projection, Barriers };

struct IntegratorCapabilities {
  /// material.model values it simulates; empty: every material.
  std::vector<std::string> materials;
  /// bending.model values it simulates (when bending.stiffness > 0); empty: every model.
  std::vector<BendingModel> bendingModels;
  bool planar = true;            ///< 2D meshes (mesh.dim 2)
  ContactMethod contact = ContactMethod::None;  ///< contact with obstacles, and how
  bool selfContact = false;      ///< contact.self_collision (the barriers only)
  bool stiffnessDamping = true;  ///< damping.stiffness > 0
  bool needsHessian = false;     ///< assembles the model's Hessian (implicit Newton solves)
};

/// The values of an integrator's own keys, kept in the scene (`Scene::integratorOptions`) under
/// the integrator's name, in a settings struct the integrator defines in its own .cpp: an
/// integrator with keys of its own then adds no field to `Scene`. Copies are deep (std::any).
class IntegratorOptions {
 public:
  /// The settings stored for `integrator`, default-constructed first if there are none.
  template <class T>
  T& edit(const std::string& integrator) {
    std::any& value = values_[integrator];
    if (!value.has_value()) value = T{};
    return std::any_cast<T&>(value);
  }
  /// The settings stored for `integrator`, or T's defaults if there are none (a scene built in
  /// code that never named the keys).
  template <class T>
  T get(const std::string& integrator) const {
    const auto it = values_.find(integrator);
    return it == values_.end() ? T{} : std::any_cast<T>(it->second);
  }

 private:
  std::map<std::string, std::any> values_;
};

struct IntegratorEntry {
  std::string name;     ///< integrator.name
  std::string summary;  ///< one line for --help and the docs
  IntegratorCapabilities supports;
  /// Its own keys under `integrator` (besides name, dt, substeps and max_retries, which every
  /// integrator reads); integrators may share a key (`iterations`).
  std::vector<std::string> keys;
  /// Reads those keys into the scene: into `Scene::integratorOptions` under its name (a new
  /// integrator's way), or into fields of `Scene` that several integrators share.
  std::function<Status(const SettingsReader&, Scene&)> read;
  /// Range checks on those keys, naming them. Run for every entry whatever the scene's
  /// integrator, so that a bad value is refused even while another integrator is chosen.
  std::function<Status(const Scene&)> check;
  /// The integrator for a validated scene.
  std::function<std::unique_ptr<Integrator>(const Scene&)> make;
};

/// The keys of acceptance test (a) in displacement (acceptance.h), which the integrators that
/// measure it (backward_euler, bdf2) list among theirs, read and check.
const std::vector<std::string>& displacementErrorKeys();
Status readDisplacementTolerance(const SettingsReader& reader, Scene& scene);
Status checkDisplacementTolerance(const Scene& scene);

/// Every integrator, in a fixed order (symplectic_euler, backward_euler, bdf2, xpbd,
/// projective_dynamics).
const std::vector<IntegratorEntry>& integratorRegistry();

/// The integrator names accepted in a scene, in registry order.
const std::vector<std::string>& integratorNames();

/// The entry called `name`, or an error listing the known names.
Expected<const IntegratorEntry*> findIntegrator(const std::string& name);

/// The keys under `integrator` that some integrator reads: the common ones, then each entry's
/// own, each once.
std::vector<std::string> integratorKeys();

/// The keys under `integrator` that the integrator called `name` reads: the common ones, then
/// its own. Empty for an unknown name.
std::vector<std::string> integratorKeysOf(const std::string& name);

/// `key` (under `integrator`) given by `source` ("--set", "parameter ~integrator/...") when the
/// integrator is `name`: an error naming the key, the integrator, the keys it reads and the
/// integrators that read this one, if `name` does not read it (a setting that would otherwise
/// be ignored silently); success for a key it reads, or for an unknown integrator or key (those
/// are refused by name when the scene is read).
Status checkIntegratorUsesKey(const std::string& name, const std::string& key, const std::string& source);

/// The note for a key under `integrator` in a scene document that the integrator called `name`
/// does not read (a scene switched to another integrator, e.g. with --integrator): the key,
/// the integrator and the integrators that read it; empty if `name` reads it.
std::string unusedIntegratorKeyNote(const std::string& name, const std::string& key);

/// Why the scene's integrator cannot simulate the scene (material, bending model, planar mesh,
/// obstacles, self-contact, stiffness damping), naming the key, what the integrator supports
/// and which integrators would take the scene; success if it can. The scene's integrator must
/// be a known name.
Status checkIntegratorSupports(const Scene& scene);

/// The capabilities as a short text for --help: "materials: arap; bending: quadratic; 3D only;
/// no contact".
std::string capabilitiesText(const IntegratorCapabilities& supports);

}  // namespace fem_cloth
