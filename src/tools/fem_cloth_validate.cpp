// fem_cloth_validate: the physical validation (docs/validation.md). Runs cases against closed
// forms and published tables (include/fem_cloth/validate/cases.h) at the given resolutions,
// prints a table with the relative error and the observed order of convergence, and writes CSV
// and JSON. Exit status 0 when every row with a tolerance passes and every static solve
// converged, 1 otherwise, 2 for bad arguments.
#include <CLI/CLI.hpp>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "fem_cloth/core/bending.h"
#include "fem_cloth/core/threads.h"
#include "fem_cloth/io/command_line.h"
#include "fem_cloth/io/output_file.h"
#include "fem_cloth/validate/cases.h"

namespace {

using fem_cloth::validate::CaseRow;

// The finest resolution (the clamp study of docs/validation.md went to 512 cells). Such a run
// takes many minutes: on a terminal each case says when it starts.
constexpr int kMaxCells = 512;

/// Observed order against the previous row of the same case, parameter and quantity at a coarser
/// mesh (or a larger time step); NaN when there is none (or either solve did not converge).
std::vector<double> orders(const std::vector<CaseRow>& rows) {
  std::vector<double> out(rows.size(), std::nan(""));
  std::map<std::string, std::size_t> previous;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const CaseRow& r = rows[i];
    // A solve that did not converge has no error to take an order from.
    if (!r.converged) continue;
    const std::string key = r.validation + "|" + r.parameter + "|" + r.quantity;
    const auto it = previous.find(key);
    if (it != previous.end()) {
      const CaseRow& p = rows[it->second];
      // Resolution: cells, or 1 / dt for time-step studies.
      const double n1 = p.cells > 0 ? p.cells : 1.0 / p.step, n2 = r.cells > 0 ? r.cells : 1.0 / r.step;
      if (n2 != n1 && p.error != 0.0 && r.error != 0.0) {
        out[i] = fem_cloth::validate::convergenceOrder(p.error, n1, r.error, n2);
      }
    }
    previous[key] = i;
  }
  return out;
}

std::string status(const CaseRow& r) {
  if (!r.converged) return "NOT CONVERGED";
  if (r.tolerance <= 0.0) return "reported";
  return r.pass() ? "pass" : "FAIL";
}

std::string csvField(const std::string& s) {
  if (s.find_first_of(",\"") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

void writeCsv(std::ostream& out, const std::vector<CaseRow>& rows, const std::vector<double>& order) {
  out << std::setprecision(10);
  out << "validation,parameter,cells,dt,quantity,value,reference,error,order,tolerance,status,residual,source,note\n";
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const CaseRow& r = rows[i];
    out << csvField(r.validation) << ',' << csvField(r.parameter) << ',' << r.cells << ',' << r.step << ','
        << csvField(r.quantity) << ',' << r.value << ',' << r.reference << ',' << r.error << ','
        << (std::isnan(order[i]) ? std::string() : std::to_string(order[i])) << ',' << r.tolerance << ','
        << status(r) << ',' << r.residual << ',' << csvField(r.source) << ',' << csvField(r.note) << '\n';
  }
}

void writeJson(std::ostream& out, const std::vector<CaseRow>& rows, const std::vector<double>& order) {
  nlohmann::ordered_json doc = nlohmann::ordered_json::array();
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const CaseRow& r = rows[i];
    nlohmann::ordered_json j = {{"validation", r.validation}, {"parameter", r.parameter},
                                {"cells", r.cells},           {"dt", r.step},
                                {"quantity", r.quantity},     {"value", r.value},
                                {"reference", r.reference},   {"error", r.error},
                                {"tolerance", r.tolerance},   {"status", status(r)},
                                {"converged", r.converged},   {"residual", r.residual},
                                {"source", r.source},         {"note", r.note}};
    j["order"] = std::isnan(order[i]) ? nlohmann::ordered_json() : nlohmann::ordered_json(order[i]);
    doc.push_back(j);
  }
  out << doc.dump(2) << '\n';
}

/// Writes an output file (complete under its name or absent, io/output_file.h); false, with the
/// error on stderr, when it cannot be written.
template <class Write>
bool writeOutput(const std::string& option, const std::string& path, Write write) {
  fem_cloth::Expected<std::unique_ptr<fem_cloth::OutputFile>> file = fem_cloth::OutputFile::open(path);
  fem_cloth::Status written = file ? fem_cloth::Status::success() : fem_cloth::Status(fem_cloth::Error{file.error()});
  if (file) {
    write((*file)->stream());
    written = (*file)->commit();
  }
  if (!written) std::cerr << "fem_cloth_validate: " << option << ": " << written.error() << "\n";
  return static_cast<bool>(written);
}

/// The output files checked before the work: each can be written, and they are two files.
bool checkOutputs(const std::string& csv, const std::string& json) {
  for (const auto& [option, path] : {std::pair{"--csv", &csv}, std::pair{"--json", &json}}) {
    if (path->empty()) continue;
    if (fem_cloth::Status s = fem_cloth::checkOutputPath(*path); !s) {
      std::cerr << "fem_cloth_validate: " << option << ": " << s.error() << "\n";
      return false;
    }
  }
  if (!csv.empty() && !json.empty() && fem_cloth::sameOutputPath(csv, json)) {
    std::cerr << "fem_cloth_validate: --csv and --json name the same file '" << csv << "': give two files\n";
    return false;
  }
  return true;
}

void printTable(const std::vector<CaseRow>& rows, const std::vector<double>& order) {
  std::cout << std::left << std::setw(14) << "case" << std::setw(24) << "parameter" << std::right
            << std::setw(6) << "cells" << std::setw(8) << "dt" << "  " << std::left << std::setw(38)
            << "quantity" << std::right << std::setw(13) << "value" << std::setw(13) << "reference"
            << std::setw(10) << "error %" << std::setw(7) << "order" << std::setw(10) << "residual"
            << "  status\n";
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const CaseRow& r = rows[i];
    std::ostringstream ord;
    if (!std::isnan(order[i])) ord << std::fixed << std::setprecision(2) << order[i];
    // A static row's force residual / largest nodal load: a comparison counts only once the
    // solve is converged, so every static row shows how far it got.
    std::ostringstream residual;
    if (r.residual > 0.0) residual << std::setprecision(2) << r.residual;
    std::cout << std::left << std::setw(14) << r.validation << std::setw(24) << r.parameter << std::right
              << std::setw(6) << (r.cells > 0 ? std::to_string(r.cells) : "-") << std::setw(8)
              << (r.step > 0 ? fem_cloth::numberText(r.step) : "-") << "  " << std::left << std::setw(38)
              << r.quantity << std::right << std::setw(13) << std::setprecision(6) << r.value << std::setw(13)
              << r.reference << std::setw(10) << std::setprecision(3) << 100.0 * r.error << std::setw(7)
              << ord.str() << std::setw(10) << (r.residual > 0.0 ? residual.str() : "-") << "  " << status(r) << (r.note.empty() ? "" : "  (" + r.note + ")") << "\n";
  }
}

}  // namespace

int main(int argc, char** argv) {
  fem_cloth::preferPassiveThreadWaiting(argv);
  CLI::App app{
      "fem_cloth_validate: fem_cloth against closed forms and published tables (docs/validation.md).\n"
      "Cases: peirce, plate_clamped, plate_simply, beam_clamped, tension, hanging_sheet, free_fall, pendulum, incline.\n"
      "Prints case, parameter, resolution, value, reference, relative error, observed order, status."};
  std::vector<std::string> cases;
  std::vector<int> cells = {16};
  std::vector<double> gammas;
  std::string model = "midedge", diagonals = "alternating", csv, jsonPath;
  app.add_option("--case", cases, "cases to run (repeatable or comma-separated; default all)")
      ->delimiter(',')
      ->check(CLI::IsMember(fem_cloth::validate::caseNames()));
  app.add_option("--cells", cells,
                 "mesh resolutions, cells along the governing length (default 16; at most " +
                     std::to_string(kMaxCells) + ")")
      ->delimiter(',')
      ->check(CLI::Range(2, kMaxCells));
  app.add_option("--model", model, "bending model of the bending cases (default midedge)")
      ->check(CLI::IsMember(fem_cloth::bendingModelNames()));
  app.add_option("--gammas", gammas, "peirce: the gammas w l^3 / B, each in (0, 100] (default 0.5,1,2,4,8,12,20)")
      ->delimiter(',');
  app.add_option("--diagonals", diagonals,
                 "plate_clamped, plate_simply, beam_clamped: the triangulation (default alternating, "
                 "makeGrid's checkerboard; uniform; crossed)")
      ->check(CLI::IsMember(fem_cloth::validate::diagonalPatterns()));
  app.add_option("--csv", csv, "write the rows as CSV to this file");
  app.add_option("--json", jsonPath, "write the rows as JSON to this file");
  if (const std::optional<int> status = fem_cloth::parseToolCommandLine(app, argc, argv, "fem_cloth_validate")) {
    return *status;
  }
  for (double gamma : gammas) {
    // gamma = w l^3 / B: a strip of no weight (0) has nothing to bend it.
    if (!(gamma > 0.0 && gamma <= 100.0)) {
      std::cerr << "fem_cloth_validate: --gammas: each must be in (0, 100], got " << gamma << "\n";
      return 2;
    }
  }
  if (!checkOutputs(csv, jsonPath)) return 2;
  if (cases.empty()) cases = fem_cloth::validate::caseNames();
  fem_cloth::validate::CaseOptions options;
  options.cells = cells;
  options.bendingModel = *fem_cloth::bendingModelFromName(model);  // checked by --model
  options.gammas = gammas;
  options.diagonals = diagonals;
  std::vector<CaseRow> rows;
  // A case at fine resolutions takes minutes: on a terminal, say which one is running.
  const bool progress = isatty(STDERR_FILENO) != 0;
  for (const std::string& name : cases) {
    if (progress) std::cerr << "fem_cloth_validate: running " << name << " ...\n";
    fem_cloth::Expected<std::vector<CaseRow>> result = fem_cloth::validate::runCase(name, options);
    if (!result) {
      std::cerr << "fem_cloth_validate: " << result.error() << "\n";
      return 1;
    }
    rows.insert(rows.end(), result->begin(), result->end());
  }
  const std::vector<double> order = orders(rows);
  printTable(rows, order);
  if (!csv.empty() && !writeOutput("--csv", csv, [&](std::ostream& out) { writeCsv(out, rows, order); })) return 2;
  if (!jsonPath.empty() &&
      !writeOutput("--json", jsonPath, [&](std::ostream& out) { writeJson(out, rows, order); })) {
    return 2;
  }
  int failed = 0;
  for (const CaseRow& r : rows) failed += r.pass() ? 0 : 1;
  std::cout << rows.size() - static_cast<std::size_t>(failed) << " rows pass or are reported, " << failed
            << " fail\n";
  return failed == 0 ? 0 : 1;
}
