// The scenes of the accuracy and stability report (docs/accuracy.md), as scene documents: every
// run of the report is a scene YAML document plus `key=value` overrides, so any single run can be
// repeated with fem_cloth_sim (--scene, --set) or, for the recorded grasp, fem_cloth_sim
// --commands.
//
// Two studies:
//  - work precision: a few standard scenes, every integrator over a range of time steps and
//    settings (Newton tolerance, iteration counts, CFL safety), each compared with a much finer
//    BDF2 run of the same scene;
//  - stability: small extreme cases crossed with material x stretch stiffness x integrator x dt.
#pragma once

#include <yaml-cpp/yaml.h>

#include <memory>
#include <string>
#include <vector>

#include "fem_cloth/core/expected.h"
#include "fem_cloth/io/recording.h"

namespace fem_cloth::report {

/// One way of running an integrator: the scene overrides that select it and its settings, and
/// the label tables and plots use ("bdf2 tol 1e-05", "xpbd 16 it").
struct Variant {
  std::string integrator;
  std::string label;
  std::vector<std::string> overrides;  ///< key.path=value, applied after the scene's own
};

/// The settings each integrator is swept over in the work-precision study (besides dt):
///   symplectic_euler: cfl_safety 0.5 (default), 0.25, 0.125 — it substeps itself below the CFL
///                     bound, so this, not dt, sets its step;
///   backward_euler:   newton_tolerance 1e-3 (default) and 1e-2;
///   bdf2:             newton_tolerance 1e-3 (default) and 1e-5;
///   xpbd:             iterations 1, 4, 16, 64;
///   projective_dynamics: iterations 5, 10 (default), 20, and 7 with Chebyshev rho 0.9 (the fast
///                     scene's setting); it runs only on the ARAP scenes (n/a elsewhere);
///   any other name (integrators added later): its defaults and iterations 4, 16, 64 — the key
///                     every iterative solver of the scene format reads.
/// `small` keeps one setting per integrator (the smoke test).
std::vector<Variant> workPrecisionVariants(const std::vector<std::string>& integrators, bool small);

/// A work-precision scene.
struct AccuracyScene {
  std::string name;
  std::string description;   ///< one line for tables and the docs
  YAML::Node document;       ///< the scene; integrator, dt and duration are set per run
  std::string commandsBag;   ///< a recorded run whose commands and frames drive it ("" none)
  std::shared_ptr<const Recording> recording;  ///< that run, read (null: none)
  double duration = 1.0;     ///< s
  double sampleInterval = 1.0 / 30.0;  ///< s: positions compared at every multiple of this
  std::vector<double> dts;   ///< tested steps (s), coarse to fine; each divides sampleInterval
  /// Upper bound of the reference's step (s); the report also keeps it below a quarter of the
  /// scene's CFL bound, so that the reference resolves every mode of the mesh.
  double referenceDt = 0.0;
  /// Its integrator.error_ratio and error_cap (acceptance test (a) in displacement): Newton
  /// converged to this fraction of the step's own truncation error, and of each vertex's motion.
  double referenceErrorRatio = 1e-4;
  /// The step commands are stamped on (s; 0: none): every step of the study, the reference's
  /// included, divides it, so a command takes effect at the same time in every run.
  double commandGrid = 0.0;
  bool defaultSettingsOnly = false;  ///< only the first variant of each integrator
};

/// The work-precision scenes:
///   hanging_cloth: config/hanging_cloth.yaml, 17 x 17 vertices (9 x 9 small), the first 0.3 s
///                  of the fall, before folds form;
///   stiff_cloth:   config/stiff_cloth.yaml (100x stiffer, nu = 0.45, undamped), the first 0.2 s;
///   hanging_arap:  hanging_cloth with the ARAP material, so that integrators that support only
///                  ARAP (projective dynamics) are compared on the same footing;
///   stiff_arap:    stiff_cloth with the ARAP material, likewise;
///   grasp:         the recorded grasp-and-lift `bag` (test/data/small_grasp.bag: a 9 x 9 cloth
///                  grasped by two corners that follow a gripper frame), its commands re-applied
///                  to every integrator and dt as the node applies them, 3.12 s;
///   hanging_long:  hanging_cloth over 1 s at two steps, default settings: positions after the
///                  cloth folds are sensitive to any perturbation (the reference against itself
///                  diverges too), which this scene shows;
///   smooth:        the problem of test/core/test_convergence.cpp — a free planar 4 x 4 sheet
///                  (1 N/m) released from a smooth stretch, 0.25 s — whose every mode the tested
///                  steps resolve: the asymptotic orders show there.
/// dts: 1/30 to 1/480 s (hanging, stiff), 0.04 to 0.0025 s (grasp: its commands are stamped on
/// a 0.01 s grid), 1/80 to 1/640 s (smooth). `small`: 9 x 9, 0.2 s, three dts, no stiff_arap,
/// grasp, long or smooth scene.
/// `recording` (null: none) is the grasp scene's recorded run.
Expected<std::vector<AccuracyScene>> accuracyScenes(const std::string& configDir,
                                                    std::shared_ptr<const Recording> recording, bool small);

/// Stretch stiffness levels of the stability matrix: cotton-like (E h = 1e4 N/m, nu = 0.3, the
/// hanging cloth), 100x (nu = 0.45, the stiff cloth) and 1000x (nu = 0.49).
struct Stiffness {
  std::string name;
  double youngsModulus = 0.0;  ///< Pa (thickness 5e-4 m)
  double poissonRatio = 0.0;
};
const std::vector<Stiffness>& stiffnessLevels();

/// Time steps of the stability matrix: 1e-4, 1e-3, 1e-2 and 1/30 s.
const std::vector<double>& stabilityDts();

/// The extreme cases, each on a small n x n mesh of a 1 m, 1 kg/m^2 sheet with the hanging
/// cloth's air drag (0.1 1/s):
///   pull_corner: cloth held at one corner while the opposite corner is pulled 5 m (five cloth
///                sizes) in 0.1 s (50 m/s) and let go, 0.2 s;
///   squash:      planar sheet whose boundary is driven to its centre in 0.1 s (zero area),
///                then let go, 0.2 s;
///   inverted:    planar sheet whose left half starts folded over onto the right half (every
///                element of that half inverted, J = -1, none strained in size), free, 0.1 s;
///   degenerate:  cloth hanging from two corners whose rest mesh holds three slivers: two
///                vertices moved to within 1e-5 mesh spacings of the edge opposite them in one
///                of their triangles (quality ~1e-5; mesh.min_quality lowered to 1e-8), 0.1 s;
///   whip:        cloth hanging from one corner that is yanked out of plane at 100 m/s, 0.1 s;
///   slam:        cloth thrown flat at a floor (plane obstacle, friction 0.4) at 10 m/s from 5 cm
///                above it, 0.1 s: contact at every dt;
///   strip:       the sudden-load strip of issue 11 (StripCase: its own 6 x 21 grid whatever n,
///                0.4 x 0.1 m, 0.2 kg/m^2, first column pinned, 20 N along it on the last column,
///                mass damping 30/s, no gravity), 0.5 s: settled to 6e-4 of its motion, so its
///                end state is the static one and is checked against the uniaxial closed form
///                (stability.h, "wrong"). It runs at the cotton level only (its E h = 1e4 N/m).
/// Short horizons keep the matrix within its time budget: every case reaches its extreme within
/// the horizon (the pulled and squashed ones are also let go and must recover). Each horizon is
/// a whole number of every step of the matrix.
const std::vector<std::string>& extremeCaseNames();
/// One line per case for tables and the docs.
std::string extremeCaseDescription(const std::string& name);
Expected<YAML::Node> extremeCase(const std::string& name, int n);

/// The geometry and load of the "strip" case.
struct StripCase {
  static constexpr int rows = 6, cols = 21;
  static constexpr double length = 0.4, width = 0.1;  ///< m, along and across the load
  static constexpr double force = 20.0;               ///< N, total on the last column
  static constexpr double thickness = 5e-4;           ///< m, as every case (baseSheet)
};

/// A cell of the stability matrix.
struct Cell {
  std::string caseName, material, stiffness, integrator;
  double dt = 0.0;
};
/// The cell's scene: the case with the material, stiffness, integrator and dt set.
Expected<YAML::Node> cellScene(const Cell& cell, int n);

/// `key=value` with the value written to full precision.
std::string setting(const std::string& key, double value);

/// Applies overrides to a deep copy of `document`.
Expected<YAML::Node> withOverrides(const YAML::Node& document,
                                   const std::vector<std::string>& overrides);

}  // namespace fem_cloth::report
