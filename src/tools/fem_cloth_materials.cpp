// fem_cloth_materials: the material explorer. Evaluates the membrane material models on given
// deformation gradients (JSON lines), sweeps them along uniaxial stretch, compression and
// inversion (CSV, optional PNG), and prints the material audit. ROS-free: links fem_cloth_core only.
//
// Units: Lame parameters in N/m (membrane moduli: volumetric moduli times thickness), so psi is an
// energy per unit rest area in J/m^2 and P a force per unit rest length in N/m.
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "fem_cloth/core/material_audit.h"
#include "fem_cloth/core/materials/materials.h"
#include "fem_cloth/core/package_paths.h"
#include "fem_cloth/io/command_line.h"

namespace fs = std::filesystem;
using nlohmann::json;
using nlohmann::ordered_json;

namespace fem_cloth {
namespace {

// ---------------------------------------------------------------------------------------------
// Shared checks
// ---------------------------------------------------------------------------------------------

/// Lame parameters a stable isotropic membrane can have: mu >= 0 and a non-negative 2D bulk
/// modulus mu + lambda (every Poisson ratio in (-1, 1/2) gives mu + lambda = E / (2 (1 - nu)) > 0).
/// Returns an empty string when they are fine, else what is wrong.
std::string checkLame(double mu, double lambda) {
  if (!std::isfinite(mu)) return "'mu' must be a finite number";
  if (!std::isfinite(lambda)) return "'lambda' must be a finite number";
  if (mu < 0.0) return "'mu' must be >= 0 N/m (got " + json(mu).dump() + ")";
  if (mu + lambda < 0.0) {
    return "'lambda' must be >= -mu so that mu + lambda >= 0 (got mu = " + json(mu).dump() +
           ", lambda = " + json(lambda).dump() + ")";
  }
  return "";
}

template <int D>
ordered_json rows(const DefGrad<D>& M) {
  ordered_json out = ordered_json::array();
  for (int r = 0; r < D; ++r) out.push_back({M(r, 0), M(r, 1)});
  return out;
}

template <int D>
double smallestEigenvalue(const StressHessian<D>& H) {
  using Solver = Eigen::SelfAdjointEigenSolver<StressHessian<D>>;
  return Solver(0.5 * (H + H.transpose()), Eigen::EigenvaluesOnly).eigenvalues().minCoeff();
}

// ---------------------------------------------------------------------------------------------
// eval
// ---------------------------------------------------------------------------------------------

/// An error in one input line: becomes {"error": message}.
struct LineError {
  std::string message;
};

double numberAt(const json& value, const std::string& what) {
  if (!value.is_number()) throw LineError{what + " must be a number, got " + value.dump()};
  const double x = value.get<double>();
  if (!std::isfinite(x)) throw LineError{what + " must be finite, got " + value.dump()};
  return x;
}

/// F as 2 rows (planar) or 3 rows (cloth) of 2 numbers each.
template <int D>
DefGrad<D> deformationGradientFrom(const json& F) {
  DefGrad<D> out;
  for (int r = 0; r < D; ++r) {
    const json& row = F[r];
    if (!row.is_array() || row.size() != 2) {
      throw LineError{"'F' row " + std::to_string(r) + " must be an array of 2 numbers, got " +
                      row.dump()};
    }
    for (int c = 0; c < 2; ++c) {
      out(r, c) = numberAt(row[c], "'F'[" + std::to_string(r) + "][" + std::to_string(c) + "]");
    }
  }
  return out;
}

template <int D>
ordered_json evaluate(const Material& material, const DefGrad<D>& F) {
  // The rest frame is T = [e1 e2]: the identity for planar elements, the xy-plane for cloth.
  const DefGrad<D> T = DefGrad<D>::Identity();
  return std::visit(
      [&](const auto& model) -> ordered_json {
        if (!model.template inDomain<D>(F)) {
          throw LineError{"F is outside the domain of " + std::string(model.kName) + ": J = " +
                          json(areaRatio(F)).dump() + " <= 0"};
        }
        const double psi = model.template psi<D>(F, T);
        const DefGrad<D> P = model.template pk1<D>(F, T);
        const StressHessian<D> H = model.template hessian<D>(F, T);
        const StressHessian<D> projected = model.template projectedHessian<D>(F, T);
        if (!std::isfinite(psi) || !P.allFinite() || !H.allFinite() || !projected.allFinite()) {
          throw LineError{"the result is not finite (is F too large?)"};
        }
        return {{"psi", psi},
                {"P", rows<D>(P)},
                {"hessian_min_eig", smallestEigenvalue<D>(H)},
                {"projected_hessian_min_eig", smallestEigenvalue<D>(projected)}};
      },
      material);
}

/// The reply to one input line (keys in the documented order), or LineError.
ordered_json evaluateLine(const std::string& line) {
  json in;
  try {
    in = json::parse(line);
  } catch (const json::exception& e) {
    // Also number overflow (1e999), which nlohmann reports as out_of_range. Its messages start
    // with an "[json.exception.<kind>.<id>] " tag that says nothing to a user.
    const std::string what = e.what();
    const std::size_t tagEnd = what.find("] ");
    throw LineError{"malformed JSON: " +
                    (tagEnd == std::string::npos ? what : what.substr(tagEnd + 2))};
  }
  if (!in.is_object()) throw LineError{"expected a JSON object, got " + in.dump()};
  static const std::vector<std::string> keys = {"model", "mu", "lambda", "F"};
  for (const auto& item : in.items()) {
    if (std::find(keys.begin(), keys.end(), item.key()) == keys.end()) {
      throw LineError{"unknown key '" + item.key() + "' (expected model, mu, lambda, F)"};
    }
  }
  for (const std::string& key : keys) {
    if (!in.contains(key)) throw LineError{"missing key '" + key + "'"};
  }
  if (!in["model"].is_string()) {
    throw LineError{"'model' must be a string, got " + in["model"].dump()};
  }
  const double mu = numberAt(in["mu"], "'mu'");
  const double lambda = numberAt(in["lambda"], "'lambda'");
  if (const std::string problem = checkLame(mu, lambda); !problem.empty()) {
    throw LineError{problem};
  }
  const Expected<Material> material = makeMaterial(in["model"].get<std::string>(), {mu, lambda});
  if (!material) throw LineError{material.error()};
  const json& F = in["F"];
  if (!F.is_array() || (F.size() != 2 && F.size() != 3)) {
    throw LineError{"'F' must be an array of 2 rows (planar) or 3 rows (cloth), got " + F.dump()};
  }
  if (F.size() == 2) return evaluate<2>(*material, deformationGradientFrom<2>(F));
  return evaluate<3>(*material, deformationGradientFrom<3>(F));
}

bool isBlank(const std::string& line) {
  return line.find_first_not_of(" \t\r\n") == std::string::npos;
}

int runEval() {
  std::string line;
  for (long number = 1; std::getline(std::cin, line); ++number) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (isBlank(line)) continue;
    ordered_json reply;
    try {
      reply = evaluateLine(line);
    } catch (const LineError& e) {
      reply = {{"error", "line " + std::to_string(number) + ": " + e.message}};
    } catch (const std::exception& e) {
      // Not expected: every check above throws LineError. Still one bad line must not end the run.
      reply = {{"error", "line " + std::to_string(number) + ": " + e.what()}};
    }
    // One line out per line in, flushed, so the tool can sit behind a pipe.
    std::cout << reply.dump() << std::endl;
  }
  if (std::cin.bad()) {
    std::cerr << "fem_cloth_materials eval: cannot read standard input\n";
    return 2;
  }
  return 0;
}

// ---------------------------------------------------------------------------------------------
// sweep
// ---------------------------------------------------------------------------------------------

struct SweepOptions {
  std::string outDir = ".";
  double mu = 1.0;
  double lambda = 1.0;
  double sMin = -1.0;
  double sMax = 2.0;
  int count = 301;
  bool plot = false;
};

// The most values of s a sweep takes: 6 models x 1e5 rows is a CSV of about 40 MB, written in
// about a second; more is no longer a curve to plot but a disk to fill.
constexpr int kMaxSweepCount = 100000;

constexpr const char* kSweepHeader = "model,s,psi_J_per_m2,P11_N_per_m,P22_N_per_m";

/// The plotting script: next to the executable in an install space (catkin_install_python puts
/// it there), else in the devel space's source tree (core/package_paths.h).
Expected<std::string> findPlotScript() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = self.parent_path() / "plot_material_sweep.py";
    if (fs::exists(installed)) return installed.string();
  }
  const Expected<fs::path> source = findPackageFile("scripts/plot_material_sweep.py");
  if (!source) return Error{"plot script not found: " + source.error()};
  return source->string();
}

/// Runs python3 on the plotting script without a shell; returns an error message or "".
std::string plotSweep(const fs::path& csv, const fs::path& png, const SweepOptions& o) {
  const std::string python = FEM_CLOTH_PYTHON;
  if (access(python.c_str(), X_OK) != 0) {
    return "python3 not found at " + python + " (install it with scripts/install-deps)";
  }
  const Expected<std::string> found = findPlotScript();
  if (!found) return found.error();
  const std::string& script = *found;
  std::ostringstream title;
  title << "mu = " << o.mu << " N/m, lambda = " << o.lambda << " N/m";
  std::vector<std::string> args = {python,       script,           "--csv", csv.string(),
                                   "--png",      png.string(),     "--title", title.str()};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::cout.flush();
  const pid_t pid = fork();
  if (pid < 0) return "cannot start python3";
  if (pid == 0) {
    execv(argv[0], argv.data());
    _exit(127);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    return "plotting failed (" + script + " exited with status " +
           std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) +
           "; is python3-matplotlib installed? scripts/install-deps installs it)";
  }
  return "";
}

std::string csvNumber(double x) {
  if (std::isnan(x)) return "nan";
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  return json(x).dump();  // shortest representation that reads back exactly
}

int runSweep(const SweepOptions& o) {
  if (const std::string problem = checkLame(o.mu, o.lambda); !problem.empty()) {
    std::cerr << "fem_cloth_materials sweep: " << problem << "\n";
    return 2;
  }
  if (!(o.sMin < o.sMax) || !std::isfinite(o.sMin) || !std::isfinite(o.sMax) || o.count < 2 ||
      o.count > kMaxSweepCount) {
    std::cerr << "fem_cloth_materials sweep: need finite --s-min < --s-max and --count from 2 to "
              << kMaxSweepCount << ", got --count " << o.count << "\n";
    return 2;
  }
  std::error_code ec;
  fs::create_directories(o.outDir, ec);
  const fs::path csvPath = fs::path(o.outDir) / "material_sweep.csv";
  std::ofstream csv(csvPath);
  if (!csv) {
    std::cerr << "fem_cloth_materials sweep: cannot write " << csvPath << "\n";
    return 2;
  }
  csv << kSweepHeader << "\n";
  const DefGrad<2> T = DefGrad<2>::Identity();
  for (const std::string& name : materialNames()) {
    const Material material = *makeMaterial(name, Lame{o.mu, o.lambda});
    std::visit(
        [&](const auto& model) {
          for (int i = 0; i < o.count; ++i) {
            const double s = o.sMin + (o.sMax - o.sMin) * i / (o.count - 1);
            const DefGrad<2> F = Eigen::Vector2d(1.0, s).asDiagonal();
            const double psi = model.template psi<2>(F, T);
            DefGrad<2> P = DefGrad<2>::Constant(std::numeric_limits<double>::quiet_NaN());
            if (model.template inDomain<2>(F)) P = model.template pk1<2>(F, T);
            csv << name << "," << csvNumber(s) << "," << csvNumber(psi) << ","
                << csvNumber(P(0, 0)) << "," << csvNumber(P(1, 1)) << "\n";
          }
        },
        material);
  }
  csv.close();
  if (!csv) {
    std::cerr << "fem_cloth_materials sweep: error writing " << csvPath << "\n";
    return 2;
  }
  std::cout << "wrote " << csvPath.string() << " (" << materialNames().size() << " models x "
            << o.count << " values of s)\n";
  if (o.plot) {
    const fs::path pngPath = fs::path(o.outDir) / "material_sweep.png";
    if (const std::string problem = plotSweep(csvPath, pngPath, o); !problem.empty()) {
      std::cerr << "fem_cloth_materials sweep --plot: " << problem << "\n";
      return 2;
    }
    std::cout << "wrote " << pngPath.string() << "\n";
  }
  return 0;
}

// ---------------------------------------------------------------------------------------------
// audit
// ---------------------------------------------------------------------------------------------

/// Display width of a UTF-8 string: its code points (every character used here is one column).
std::size_t displayWidth(const std::string& s) {
  std::size_t width = 0;
  for (unsigned char c : s) width += (c & 0xC0) != 0x80;
  return width;
}

std::string padded(const std::string& s, std::size_t width) {
  return s + std::string(width > displayWidth(s) ? width - displayWidth(s) : 0, ' ');
}

std::string formatMeasured(const AuditCriterion& c) {
  if (std::isnan(c.measured)) return "n/a";
  if (std::isinf(c.measured)) {
    if (c.name == audit_criterion::kLinearOrder) return "exact";
    return c.measured > 0 ? "+inf" : "-inf";
  }
  char buffer[32];
  if (c.name == audit_criterion::kLinearOrder) {
    std::snprintf(buffer, sizeof buffer, "%.2f", c.measured);
  } else {
    std::snprintf(buffer, sizeof buffer, "%.3g", c.measured);
  }
  return buffer;
}

std::string formatCell(const AuditCriterion& c) {
  std::string cell = formatMeasured(c) + (c.pass ? " ✓" : " ✗");
  if (!c.decides && c.note.rfind("exempt", 0) == 0) cell += " exempt";
  return cell;
}

/// Column headings, shorter than the criterion names, in the audit's criterion order.
const std::vector<std::string> kAuditHeadings = {
    "ψ(rest)",    "P(rest)",     "min ψ",         "rot. change", "linear order",   "P vs FD",
    "min eig",    "ψ(collapse)", "-P22 collapse", "ψ(inverted)", "-P22 inverted"};

const char* kAuditLegend = R"(Columns (samples: planar F with T = I, cloth F with several rest frames T; k = mu + |lambda|):
  ψ(rest), P(rest)  largest |psi(T)| (J/m^2) and largest |P(T)| entry (N/m) at rest; pass <= 1e-12 k
  min ψ             smallest psi over stretched, compressed, sheared and inverted samples; pass >= -1e-10 k
  rot. change       largest |psi(Q F) - psi(F)| over rotations Q; pass <= 1e-10 k (linear: exempt, reported)
  linear order      p in |psi - psi_linear| ~ eps^p at F = T (I + eps H); 3 = agrees to second order; pass >= 2.5
  P vs FD           largest |P - central differences of psi| / max(|P|, k); pass <= 1e-6
  min eig           smallest eigenvalue of the projected stress Hessian / max(|H|, k); pass >= -1e-10
  ψ, -P22 at F = diag(1, 0) (collapse) and diag(1, -0.5) (planar inversion): -P22 > 0 pushes the element
                    back towards rest; reported only (they choose scenes and integrators, not validity)
A model is accepted when it passes every criterion left of ψ(collapse), exemptions aside.)";

std::string csvField(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string quoted = "\"";
  for (char c : s) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

std::string snakeCase(std::string s) {
  for (char& c : s) c = c == ' ' || c == '-' ? '_' : static_cast<char>(std::tolower(c));
  return s;
}

int runAudit(double mu, double lambda, const std::string& csvPath) {
  if (const std::string problem = checkLame(mu, lambda); !problem.empty()) {
    std::cerr << "fem_cloth_materials audit: " << problem << "\n";
    return 2;
  }
  const std::vector<MaterialAudit> audits = auditMaterials(Lame{mu, lambda});
  // Table: one row per model, one column per criterion, widths fitted to the contents.
  std::vector<std::vector<std::string>> table;
  std::vector<std::string> heading = {"model"};
  heading.insert(heading.end(), kAuditHeadings.begin(), kAuditHeadings.end());
  heading.push_back("verdict");
  table.push_back(heading);
  for (const MaterialAudit& a : audits) {
    std::vector<std::string> row = {a.model};
    for (const AuditCriterion& c : a.criteria) row.push_back(formatCell(c));
    row.push_back(a.verdict);
    table.push_back(row);
  }
  std::vector<std::size_t> widths(heading.size(), 0);
  for (const auto& row : table) {
    for (std::size_t j = 0; j < row.size(); ++j) {
      widths[j] = std::max(widths[j], displayWidth(row[j]));
    }
  }
  std::cout << "Material audit, mu = " << mu << " N/m, lambda = " << lambda << " N/m\n";
  for (std::size_t i = 0; i < table.size(); ++i) {
    std::string line;
    for (std::size_t j = 0; j < table[i].size(); ++j) {
      line += j + 1 < table[i].size() ? padded(table[i][j], widths[j] + 2) : table[i][j];
    }
    std::cout << line << "\n";
    if (i == 0) std::cout << std::string(displayWidth(line), '-') << "\n";
  }
  std::cout << "\n" << kAuditLegend << "\n";

  if (!csvPath.empty()) {
    std::ofstream csv(csvPath);
    csv << std::boolalpha << "model,counterexample,accepted,verdict";
    for (const AuditCriterion& c : audits.front().criteria) {
      csv << "," << snakeCase(c.name) << "," << snakeCase(c.name) << "_pass";
    }
    csv << "\n";
    for (const MaterialAudit& a : audits) {
      csv << a.model << "," << a.counterexample << "," << a.accepted << "," << csvField(a.verdict);
      for (const AuditCriterion& c : a.criteria) {
        csv << "," << csvNumber(c.measured) << "," << c.pass;
      }
      csv << "\n";
    }
    csv.close();
    if (!csv) {
      std::cerr << "fem_cloth_materials audit: cannot write " << csvPath << "\n";
      return 2;
    }
    std::cout << "\nwrote " << csvPath << "\n";
  }
  return 0;
}

// ---------------------------------------------------------------------------------------------
// from-bending-length, from-elongation: scene keys from a textile lab's measurements
// ---------------------------------------------------------------------------------------------

struct LabOptions {
  // from-bending-length
  double length = 0.0, overhang = 0.0, density = 0.0, gravity = 9.81;
  // from-elongation
  double force = 0.0, width = 0.0, strain = 0.0, extension = 0.0, gaugeLength = 0.0;
  double thickness = 5e-4, poisson = 0.3;
};

/// An error for a value that must be positive and finite, or "".
std::string positive(double value, const std::string& option) {
  if (value > 0.0 && std::isfinite(value)) return "";
  return option + " must be positive and finite, got " + json(value).dump();
}

int labError(const std::string& subcommand, const std::string& message) {
  std::cerr << "fem_cloth_materials " << subcommand << ": " << message << "\n";
  return 2;
}

/// Peirce 1930 / ASTM D1388: the strip's bending length c (the overhang at which its tip chord
/// reaches 41.5 deg, halved) gives the rigidity per unit width B = w c^3, w = rho_A g.
int runFromBendingLength(const LabOptions& o, const CLI::App& command) {
  const std::string name = "from-bending-length";
  const bool byLength = command.count("--length") != 0;
  if (byLength == (command.count("--overhang") != 0)) return labError(name, "give --length or --overhang (one of them)");
  const double c = byLength ? o.length : 0.5 * o.overhang;
  for (const std::string& e : {positive(byLength ? o.length : o.overhang, byLength ? "--length" : "--overhang"),
                               positive(o.density, "--density"), positive(o.gravity, "--gravity"),
                               positive(o.thickness, "--thickness")}) {
    if (!e.empty()) return labError(name, e);
  }
  const double w = o.density * o.gravity;
  // Each input finite, their products need not be: no "stiffness: inf" for a scene.
  if (!std::isfinite(w * c * c * c) || !std::isfinite(o.density / o.thickness)) {
    return labError(name, "the bending stiffness w c^3 = " + csvNumber(w * c * c * c) + " N m or the density " +
                              csvNumber(o.density / o.thickness) +
                              " kg/m^3 is not a finite number: check --length, --overhang, --density, "
                              "--gravity and --thickness");
  }
  std::cout << "# bending length c = " << c << " m, areal density " << o.density << " kg/m^2 (w = rho_A g = " << w
            << " N/m^2)\n"
            << "# B = w c^3 (Peirce 1930, ASTM D1388): the rigidity per unit width\n"
            << "bending:\n"
            << "  model: midedge\n"
            << "  stiffness: " << w * c * c * c << "   # N m\n"
            << "  poisson_ratio: 0.0   # woven cloth (docs/bending.md)\n"
            << "material:\n"
            << "  thickness: " << o.thickness << "   # m\n"
            << "  density: " << o.density / o.thickness << "   # kg/m^3: areal density " << o.density << " kg/m^2\n";
  return 0;
}

/// A strip test (e.g. ASTM D5035): force F on a strip of width w at strain e gives the membrane
/// stiffness E h = F / (w e).
int runFromElongation(const LabOptions& o, const CLI::App& command) {
  const std::string name = "from-elongation";
  const bool byExtension = command.count("--extension") != 0 || command.count("--gauge-length") != 0;
  if ((command.count("--strain") != 0) == byExtension) {
    return labError(name, "give --strain, or --extension with --gauge-length");
  }
  const double strain = byExtension ? o.extension / o.gaugeLength : o.strain;
  for (const std::string& e : {positive(o.force, "--force"), positive(o.width, "--width"),
                               positive(byExtension ? o.extension : o.strain, byExtension ? "--extension" : "--strain"),
                               byExtension ? positive(o.gaugeLength, "--gauge-length") : std::string(),
                               positive(o.thickness, "--thickness")}) {
    if (!e.empty()) return labError(name, e);
  }
  if (!(o.poisson >= 0.0 && o.poisson < 0.5)) return labError(name, "--poisson must be in [0, 0.5), got " + json(o.poisson).dump());
  const double Eh = o.force / (o.width * strain);
  if (!std::isfinite(Eh) || !std::isfinite(Eh / o.thickness)) {
    return labError(name, "the membrane stiffness E h = F / (w strain) = " + csvNumber(Eh) + " N/m at --thickness " +
                              csvNumber(o.thickness) +
                              " m gives no finite Young's modulus: check --force, --width, --strain (or "
                              "--extension, --gauge-length) and --thickness");
  }
  std::cout << "# strip test: " << o.force << " N on a " << o.width << " m wide strip at strain " << strain << "\n"
            << "# E h = F / (w strain) = " << Eh << " N/m\n"
            << "material:\n"
            << "  youngs_modulus: " << Eh / o.thickness << "   # Pa at the thickness below\n"
            << "  poisson_ratio: " << o.poisson << "\n"
            << "  thickness: " << o.thickness << "   # m\n";
  return 0;
}

/// The two lab subcommands, with their options bound to `o`.
std::pair<CLI::App*, CLI::App*> addLabSubcommands(CLI::App& app, LabOptions& o) {
  CLI::App* bending = app.add_subcommand(
      "from-bending-length", "bending.stiffness from a cantilever test (Peirce 1930, ASTM D1388): B = w c^3");
  bending->add_option("--length", o.length, "bending length c (m)");
  bending->add_option("--overhang", o.overhang, "or the overhang (m) at which the tip reaches 41.5 deg (c = overhang / 2)");
  bending->add_option("--density", o.density, "areal density (kg/m^2)")->required();
  bending->add_option("--gravity", o.gravity, "m/s^2")->capture_default_str();
  bending->add_option("--thickness", o.thickness, "thickness for the printed density (m)")->capture_default_str();
  CLI::App* elongation = app.add_subcommand(
      "from-elongation", "material keys from a strip tensile test: E h = F / (w strain)");
  elongation->add_option("--force", o.force, "tensile force (N)")->required();
  elongation->add_option("--width", o.width, "strip width (m)")->required();
  elongation->add_option("--strain", o.strain, "strain at that force (dimensionless)");
  elongation->add_option("--extension", o.extension, "or the extension (m) ...");
  elongation->add_option("--gauge-length", o.gaugeLength, "... over this gauge length (m)");
  elongation->add_option("--thickness", o.thickness, "thickness (m): E = E h / thickness")->capture_default_str();
  elongation->add_option("--poisson", o.poisson, "Poisson ratio to print")->capture_default_str();
  return {bending, elongation};
}

}  // namespace
}  // namespace fem_cloth

namespace {

int run(int argc, char** argv) {
  using namespace fem_cloth;
  CLI::App app{"fem_cloth_materials: explore fem_cloth's membrane material models (linear, stvk, "
               "corotational, arap, neo_hookean, stable_neo_hookean). Lame parameters are "
               "membrane moduli in N/m; psi is in J/m^2 per unit rest area, P in N/m."};
  app.require_subcommand(1);

  CLI::App* eval = app.add_subcommand("eval", "Evaluate models on deformation gradients given as "
                                              "JSON lines on standard input");
  eval->footer(R"(Input: one JSON object per line with exactly the keys
  model   one of linear, stvk, corotational, arap, neo_hookean, stable_neo_hookean
  mu      Lame mu in N/m, >= 0
  lambda  Lame lambda in N/m, >= -mu (ARAP ignores it)
  F       the deformation gradient as rows: 2 rows of 2 numbers (planar, rest frame T = I) or
          3 rows of 2 numbers (cloth, rest frame T = [e1 e2])
  e.g. {"model": "stvk", "mu": 1.0, "lambda": 2.0, "F": [[1.1, 0.0], [0.0, 0.9]]}
Output: one JSON line per non-blank input line, in order:
  {"psi": J/m^2, "P": rows of the first Piola-Kirchhoff stress (N/m),
   "hessian_min_eig": .., "projected_hessian_min_eig": ..}  (smallest eigenvalues of the
   (2d)x(2d) stress Hessian d2psi/dF2 and of its PSD projection, column-major vec(F))
  or {"error": "line N: what is wrong"} for a bad line (malformed JSON, a missing or unknown key,
  an unknown model, F of the wrong shape, a non-number or non-finite entry, a negative mu,
  Neo-Hookean with J <= 0, ...); the tool then goes on with the next line.
Blank lines (empty or white space only) are skipped: they get no output line, so a reply matches
the N-th non-blank input line; error messages give the input line number.
Exit status: 0, also when lines had errors; 2 if standard input cannot be read.)");

  SweepOptions sweepOptions;
  CLI::App* sweep = app.add_subcommand(
      "sweep", "psi and the stress along uniaxial stretch, compression and inversion "
               "F = diag(1, s), every model, as CSV (and a PNG with --plot)");
  sweep->add_option("--out", sweepOptions.outDir, "output folder (created if missing)")
      ->capture_default_str();
  sweep->add_option("--mu", sweepOptions.mu, "Lame mu (N/m)")->capture_default_str();
  sweep->add_option("--lambda", sweepOptions.lambda, "Lame lambda (N/m)")->capture_default_str();
  sweep->add_option("--s-min", sweepOptions.sMin, "smallest s (s < 0: inverted)")
      ->capture_default_str();
  sweep->add_option("--s-max", sweepOptions.sMax, "largest s")->capture_default_str();
  sweep->add_option("--count", sweepOptions.count, "number of values of s, evenly spaced (2 to 100000)")
      ->capture_default_str();
  sweep->add_flag("--plot", sweepOptions.plot,
                  "also draw OUT/material_sweep.png (needs python3 and python3-matplotlib)");
  sweep->footer(R"(Writes OUT/material_sweep.csv in long format, one row per model and value of s:
  model,s,psi_J_per_m2,P11_N_per_m,P22_N_per_m
with F = diag(1, s) in the planar rest frame (T = I). P22 = d psi / ds, so -P22 is the force on s:
P22 < 0 pushes s up (restoring under compression). Where a model is undefined (neo_hookean at
s <= 0) psi is inf and P11, P22 are nan.)");

  double auditMu = 1.0, auditLambda = 1.0;
  std::string auditCsv;
  CLI::App* audit = app.add_subcommand(
      "audit", "Print the material audit: every model and two rejected counterexamples against "
               "the criteria a membrane energy must meet, with measured numbers and verdicts");
  audit->add_option("--mu", auditMu, "Lame mu (N/m)")->capture_default_str();
  audit->add_option("--lambda", auditLambda, "Lame lambda (N/m)")->capture_default_str();
  audit->add_option("--csv", auditCsv,
                    "also write the table as CSV: model,counterexample,accepted,verdict, then "
                    "<criterion>,<criterion>_pass for each criterion (true/false; measured "
                    "numbers as in the table, nan where not measured)");
  audit->footer(kAuditLegend);

  LabOptions lab;
  const auto [fromBendingLength, fromElongation] = addLabSubcommands(app, lab);

  // CLI11 reports a misspelt subcommand only as "A subcommand is required"; name it instead.
  const std::vector<std::string> subcommands = {"eval", "sweep", "audit", "from-bending-length", "from-elongation"};
  if (argc > 1 && argv[1][0] != '-' &&
      std::find(subcommands.begin(), subcommands.end(), argv[1]) == subcommands.end()) {
    std::cerr << "fem_cloth_materials: unknown subcommand '" << argv[1]
              << "' (expected eval, sweep, audit, from-bending-length or from-elongation; see --help)\n";
    return 2;
  }
  if (const std::optional<int> status = fem_cloth::parseToolCommandLine(app, argc, argv, "fem_cloth_materials")) {
    return *status;
  }
  if (eval->parsed()) return runEval();
  if (sweep->parsed()) return runSweep(sweepOptions);
  if (fromBendingLength->parsed()) return runFromBendingLength(lab, *fromBendingLength);
  if (fromElongation->parsed()) return runFromElongation(lab, *fromElongation);
  return runAudit(auditMu, auditLambda, auditCsv);
}

}  // namespace

// Exit status: 0, 2 bad input (options, an output that cannot be written, unreadable standard
// input), 3 an unexpected error; each with one line on stderr.
int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "fem_cloth_materials: " << e.what() << '\n';
    return 3;
  }
}
