// The physical validation of fem_cloth (docs/validation.md): every case against a closed form or
// a published table that nobody here wrote, with its error against the mesh size (or the time
// step) so that the order of convergence shows.
//
//   peirce         cantilever strip under its own weight (Peirce 1930, ASTM D1388) against the
//                  heavy inextensible elastica (elastica.h), gamma = w l^3 / B from 0.5 to 20;
//                  Peirce's 41.5 deg at c = l/2 and the bending rigidity a lab would read back
//   plate_clamped  square plate, clamped, uniform load: w0 = 0.00126532 q a^4 / D
//   plate_simply   square plate, simply supported, uniform load: w0 = 0.00406235 q a^4 / D
//                  (Timoshenko & Woinowsky-Krieger 1959, tables 8 and 35: 0.00406, 0.00126; more
//                  digits from Navier's series, summed here, and Taylor & Govindjee 2004)
//   beam_clamped   a strip clamped at both ends, free long edges, uniform load (reported): the
//                  clamped-clamped beam q a^4 / (384 D), the clamp's closure on its own
//   tension        uniaxial tension of a strip, every material model, nu = 0 (finite strain)
//                  and nu = 0.3 (small strain): stretch and contraction against uniaxial.h
//   hanging_sheet  a sheet hanging from its whole top edge: strain rho g (L - y) / (E h)
//   free_fall      centre of mass against -g t^2 / 2, per time step, backward Euler and BDF2
//   pendulum       a square plate swinging in its plane about a corner: the compound pendulum's
//                  period 2 pi sqrt(I / (m g d)) with the finite-amplitude correction
//   incline        a cloth on a plane with friction mu: sticks below atan(mu), slides above it
//                  with acceleration g (sin a - mu cos a)
//
// Static cases are solved by statics.h and report its residual; a row that did not converge is
// not a pass.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "fem_cloth/core/bending_model.h"
#include "fem_cloth/core/expected.h"

namespace fem_cloth::validate {

struct CaseRow {
  std::string validation;  ///< the case
  std::string parameter;   ///< what varies within it ("gamma=8", "stvk nu=0", "dt=0.01")
  int cells = 0;           ///< mesh resolution (cells along the governing length; 0: n/a)
  double step = 0.0;       ///< time step (s; 0: static)
  std::string quantity;    ///< what value and reference are
  double value = 0.0;
  double reference = 0.0;
  std::string source;      ///< where the reference comes from
  double error = 0.0;      ///< relative error (value - reference) / reference, unless noted
  double tolerance = 0.0;  ///< |error| allowed for a pass at this resolution (0: reported only)
  bool converged = true;   ///< static solve converged (always true for dynamic cases)
  double residual = 0.0;   ///< static solve's final relative residual
  std::string note;
  bool pass() const { return converged && (tolerance <= 0.0 || std::abs(error) <= tolerance); }
};

struct CaseOptions {
  std::vector<int> cells = {16};
  BendingModel bendingModel = BendingModel::Midedge;
  /// peirce: the gammas to run (empty: 0.5, 1, 2, 4, 8, 12, 20).
  std::vector<double> gammas;
  /// Multiplies the simulated moduli (Young's modulus, bending stiffness) but not the
  /// references: a wrong stiffness the validation must catch (its tests use 1.05).
  double modulusScale = 1.0;
  /// The plates' (plate_clamped, plate_simply, beam_clamped) triangulation: "alternating"
  /// (makeGrid's checkerboard of diagonals, the mesh a scene's grid gets), "uniform" (every
  /// diagonal from (i, j) to (i + 1, j + 1)) or "crossed" (both diagonals: a vertex at each
  /// cell's centre, four triangles). Other cases always use makeGrid's mesh.
  std::string diagonals = "alternating";
};

/// The triangulations CaseOptions::diagonals names.
const std::vector<std::string>& diagonalPatterns();

/// The case names, in the order above.
const std::vector<std::string>& caseNames();

/// Runs one case at every resolution in options.cells (dynamic cases at their own time steps).
/// Errors: an unknown case (listing the known ones), a scene that does not build.
Expected<std::vector<CaseRow>> runCase(const std::string& name, const CaseOptions& options);

/// The observed order of convergence log(e1 / e2) / log(n2 / n1) between two resolutions.
double convergenceOrder(double error1, double n1, double error2, double n2);

}  // namespace fem_cloth::validate
