// The material explorer fem_cloth_materials, run as a program: eval answers against hand
// calculations and finite differences of StVK written out here, its error lines, sweep's CSV
// against closed forms along F = diag(1, s), the plot, audit's verdicts, and the command line.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

struct ProgramRun {
  int status = -1;
  std::string out;
  std::string err;
};

std::string readFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

std::string quoted(const std::string& s) { return "'" + s + "'"; }

class MaterialsTool : public ::testing::Test {
 protected:
  void SetUp() override {
    // The process id keeps concurrent runs of the suite (other build folders) apart.
    dir_ = fs::path(::testing::TempDir()) /
           ("fem_cloth_materials_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  /// Runs the tool (or another program) with arguments and standard input; a shell does the
  /// redirections, every argument is quoted.
  ProgramRun run(const std::vector<std::string>& args, const std::string& input = "",
          const std::string& program = FEM_CLOTH_MATERIALS_TOOL) const {
    std::ofstream(dir_ / "stdin") << input;
    std::string command = quoted(program);
    for (const std::string& a : args) command += " " + quoted(a);
    command += " < " + quoted((dir_ / "stdin").string()) + " > " +
               quoted((dir_ / "stdout").string()) + " 2> " + quoted((dir_ / "stderr").string());
    ProgramRun r;
    const int raw = std::system(command.c_str());
    r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
    r.out = readFile(dir_ / "stdout");
    r.err = readFile(dir_ / "stderr");
    return r;
  }

  /// eval on these lines; the parsed replies.
  std::vector<json> eval(const std::string& input) const {
    const ProgramRun r = run({"eval"}, input);
    EXPECT_EQ(r.status, 0) << r.err;
    std::vector<json> replies;
    for (const std::string& line : lines(r.out)) replies.push_back(json::parse(line));
    return replies;
  }

  fs::path dir_;
};

/// StVK written out here: P = F (2 mu E + lambda tr(E) I), E = (F^T F - I)/2, for F d x 2.
template <int D>
Eigen::Matrix<double, D, 2> stvkStress(const Eigen::Matrix<double, D, 2>& F, double mu,
                                       double lambda) {
  const Eigen::Matrix2d E = 0.5 * (F.transpose() * F - Eigen::Matrix2d::Identity());
  return F * (2.0 * mu * E + lambda * E.trace() * Eigen::Matrix2d::Identity());
}

/// Smallest eigenvalue of the StVK stress Hessian by central differences of stvkStress.
template <int D>
double stvkSmallestHessianEigenvalue(const Eigen::Matrix<double, D, 2>& F, double mu,
                                     double lambda) {
  Eigen::Matrix<double, 2 * D, 2 * D> H;
  const double h = 1e-6;
  for (int i = 0; i < 2 * D; ++i) {
    Eigen::Matrix<double, D, 2> Fp = F, Fm = F;
    Fp.data()[i] += h;
    Fm.data()[i] -= h;
    const Eigen::Matrix<double, D, 2> dP =
        (stvkStress<D>(Fp, mu, lambda) - stvkStress<D>(Fm, mu, lambda)) / (2.0 * h);
    H.col(i) = Eigen::Map<const Eigen::Matrix<double, 2 * D, 1>>(dP.data());
  }
  H = (0.5 * (H + H.transpose())).eval();
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 2 * D, 2 * D>>(H)
      .eigenvalues()
      .minCoeff();
}

bool contains(const std::string& text, const std::string& needle) {
  return text.find(needle) != std::string::npos;
}

}  // namespace

TEST_F(MaterialsTool, EvalMatchesHandCalculations) {
  const std::vector<json> r = eval(
      R"({"model": "stvk", "mu": 1.0, "lambda": 2.0, "F": [[1.1, 0.0], [0.0, 0.9]]})"
      "\n"
      R"({"model": "stvk", "mu": 1.0, "lambda": 2.0, "F": [[1.1, 0.0], [0.0, 0.9], [0.0, 0.0]]})"
      "\n"
      R"({"model": "stvk", "mu": 1.0, "lambda": 0.0, "F": [[0.5, 0.0], [0.0, 0.5]]})"
      "\n"
      R"({"model": "linear", "mu": 3.0, "lambda": 1.0, "F": [[1.0, 0.5], [-0.5, 1.0]]})"
      "\n"
      R"({"model": "neo_hookean", "mu": 1.5, "lambda": 0.5, "F": [[2.0, 0.0], [0.0, 1.0]]})"
      "\n");
  ASSERT_EQ(r.size(), 5u);
  // StVK at F = diag(1.1, 0.9), mu = 1, lambda = 2: E = diag(0.105, -0.095), E:E = 0.02005,
  // tr E = 0.01, psi = 0.02005 + (2/2) 0.0001 = 0.02015; S = 2E + 2 (0.01) I = diag(0.23, -0.17),
  // P = F S = diag(0.253, -0.153).
  for (int k = 0; k < 2; ++k) {
    ASSERT_FALSE(r[k].contains("error")) << r[k];
    EXPECT_NEAR(r[k]["psi"].get<double>(), 0.02015, 1e-14);
    ASSERT_EQ(r[k]["P"].size(), k == 0 ? 2u : 3u);
    EXPECT_NEAR(r[k]["P"][0][0].get<double>(), 0.253, 1e-14);
    EXPECT_NEAR(r[k]["P"][0][1].get<double>(), 0.0, 1e-14);
    EXPECT_NEAR(r[k]["P"][1][0].get<double>(), 0.0, 1e-14);
    EXPECT_NEAR(r[k]["P"][1][1].get<double>(), -0.153, 1e-14);
  }
  EXPECT_EQ(r[1]["P"][2], json::array({0.0, 0.0}));
  Eigen::Matrix2d planar;
  planar << 1.1, 0.0, 0.0, 0.9;
  Eigen::Matrix<double, 3, 2> cloth = Eigen::Matrix<double, 3, 2>::Zero();
  cloth.topRows<2>() = planar;
  const double planarMin = stvkSmallestHessianEigenvalue<2>(planar, 1.0, 2.0);
  const double clothMin = stvkSmallestHessianEigenvalue<3>(cloth, 1.0, 2.0);
  EXPECT_NEAR(r[0]["hessian_min_eig"].get<double>(), planarMin, 1e-6);
  EXPECT_NEAR(r[1]["hessian_min_eig"].get<double>(), clothMin, 1e-6);
  // Cloth: moving the compressed direction out of the plane releases it, psi_2 / s_2 =
  // mu (s2^2 - 1) + lambda/2 (I_C - 2) = -0.19 + 0.02 < 0; the projection clamps it to zero.
  EXPECT_NEAR(clothMin, -0.17, 1e-6);
  EXPECT_GT(planarMin, 0.0);
  EXPECT_NEAR(r[0]["projected_hessian_min_eig"].get<double>(), planarMin, 1e-6);
  EXPECT_NEAR(r[1]["projected_hessian_min_eig"].get<double>(), 0.0, 1e-12);
  // StVK under uniform compression has an indefinite Hessian.
  const Eigen::Matrix2d compressed = 0.5 * Eigen::Matrix2d::Identity();
  EXPECT_NEAR(r[2]["hessian_min_eig"].get<double>(),
              stvkSmallestHessianEigenvalue<2>(compressed, 1.0, 0.0), 1e-6);
  EXPECT_LT(r[2]["hessian_min_eig"].get<double>(), -0.1);
  EXPECT_NEAR(r[2]["projected_hessian_min_eig"].get<double>(), 0.0, 1e-12);
  // Linear elasticity sees no strain in this area-changing rotation: sym(F) = I.
  EXPECT_NEAR(r[3]["psi"].get<double>(), 0.0, 1e-15);
  for (const json& row : r[3]["P"]) {
    for (const json& x : row) EXPECT_NEAR(x.get<double>(), 0.0, 1e-15);
  }
  // Neo-Hookean at diag(2, 1): I_C = 5, J = 2: psi = mu/2 (3) - mu log 2 + lambda/2 (log 2)^2.
  const double log2 = std::log(2.0);
  EXPECT_NEAR(r[4]["psi"].get<double>(), 1.5 * 1.5 - 1.5 * log2 + 0.25 * log2 * log2, 1e-14);
  // Keys in the documented order.
  EXPECT_EQ(lines(run({"eval"}, R"({"model":"arap","mu":1,"lambda":0,"F":[[1,0],[0,1]]})").out)[0]
                .rfind(R"({"psi":)", 0),
            0u);
}

TEST_F(MaterialsTool, EvalAnswersBadLinesWithAnErrorAndGoesOn) {
  const std::string good = R"({"model": "arap", "mu": 1, "lambda": 0, "F": [[1, 0], [0, 1]]})";
  struct Case {
    std::string line;
    std::vector<std::string> mentions;
  };
  const std::vector<Case> cases = {
      {"this is not json", {"malformed JSON"}},
      {R"({"model": "stvk", "mu": 1,)", {"malformed JSON"}},
      {"[1, 2, 3]", {"JSON object"}},
      {R"({"model": "stvk", "lambda": 1, "F": [[1, 0], [0, 1]]})", {"missing", "'mu'"}},
      {R"({"model": "stvk", "mu": 1, "lambda": 1})", {"missing", "'F'"}},
      {R"({"model": "stvk", "mu": 1, "lambda": 1, "F": [[1, 0], [0, 1]], "colour": "red"})",
       {"unknown key", "colour"}},
      {R"({"model": "rubber", "mu": 1, "lambda": 1, "F": [[1, 0], [0, 1]]})",
       {"rubber", "linear", "stvk", "corotational", "arap", "neo_hookean", "stable_neo_hookean"}},
      {R"({"model": 7, "mu": 1, "lambda": 1, "F": [[1, 0], [0, 1]]})", {"'model'", "string"}},
      {R"({"model": "stvk", "mu": 1, "lambda": 1, "F": [[1, 0], [0, 1], [0, 0], [0, 0]]})",
       {"'F'", "2 rows", "3 rows"}},
      {R"({"model": "stvk", "mu": 1, "lambda": 1, "F": [[1, 0, 0], [0, 1, 0]]})",
       {"'F' row 0", "2 numbers"}},
      {R"({"model": "stvk", "mu": 1, "lambda": 1, "F": [[1, 0], [0, "one"]]})",
       {"'F'[1][1]", "number"}},
      {R"({"model": "stvk", "mu": 1, "lambda": 1, "F": [[1, 0], [0, 1e999]]})", {"overflow"}},
      {R"({"model": "stvk", "mu": "1", "lambda": 1, "F": [[1, 0], [0, 1]]})", {"'mu'", "number"}},
      {R"({"model": "stvk", "mu": true, "lambda": 1, "F": [[1, 0], [0, 1]]})", {"'mu'", "number"}},
      {R"({"model": "stvk", "mu": -1, "lambda": 1, "F": [[1, 0], [0, 1]]})", {"'mu'", ">= 0"}},
      {R"({"model": "stvk", "mu": 1, "lambda": -5, "F": [[1, 0], [0, 1]]})", {"'lambda'"}},
      {R"({"model": "neo_hookean", "mu": 1, "lambda": 1, "F": [[1, 0], [0, -0.5]]})",
       {"neo_hookean", "J = -0.5"}},
      {R"({"model": "neo_hookean", "mu": 1, "lambda": 1, "F": [[1, 2], [0, 0], [0, 0]]})",
       {"neo_hookean", "J = 0"}},
  };
  std::string input;
  for (const Case& c : cases) input += c.line + "\n" + good + "\n";
  const std::vector<json> r = eval(input);
  ASSERT_EQ(r.size(), 2 * cases.size());
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const json& reply = r[2 * i];
    ASSERT_TRUE(reply.contains("error")) << cases[i].line << " -> " << reply;
    EXPECT_EQ(reply.size(), 1u) << reply;
    const std::string message = reply["error"].get<std::string>();
    EXPECT_EQ(message.rfind("line " + std::to_string(2 * i + 1) + ": ", 0), 0u) << message;
    for (const std::string& m : cases[i].mentions) {
      EXPECT_TRUE(contains(message, m)) << "'" << m << "' not in: " << message;
    }
    // The tool went on: the good line after it was answered.
    EXPECT_FALSE(r[2 * i + 1].contains("error")) << r[2 * i + 1];
    EXPECT_NEAR(r[2 * i + 1]["psi"].get<double>(), 0.0, 1e-15);
  }
}

TEST_F(MaterialsTool, EvalSkipsBlankLinesAndCountsThemInLineNumbers) {
  const std::string good = R"({"model": "linear", "mu": 1, "lambda": 1, "F": [[2, 0], [0, 1]]})";
  const ProgramRun r = run({"eval"}, "\n" + good + "\n\n   \t\n" + "oops\r\n" + good);
  EXPECT_EQ(r.status, 0);
  const std::vector<std::string> out = lines(r.out);
  ASSERT_EQ(out.size(), 3u) << r.out;
  // Linear at diag(2, 1): eps = diag(1, 0): psi = mu + lambda/2 = 1.5.
  EXPECT_NEAR(json::parse(out[0])["psi"].get<double>(), 1.5, 1e-15);
  EXPECT_EQ(json::parse(out[1])["error"].get<std::string>().rfind("line 5: ", 0), 0u) << out[1];
  EXPECT_NEAR(json::parse(out[2])["psi"].get<double>(), 1.5, 1e-15);
  // Empty input: no output, success.
  const ProgramRun empty = run({"eval"}, "");
  EXPECT_EQ(empty.status, 0);
  EXPECT_TRUE(empty.out.empty());
}

TEST_F(MaterialsTool, SweepWritesTheDocumentedCsv) {
  const double mu = 2.0, lambda = 0.5;
  const ProgramRun r = run({"sweep", "--out", (dir_ / "out").string(), "--mu", "2", "--lambda", "0.5",
                     "--s-min", "-1", "--s-max", "2", "--count", "31"});
  ASSERT_EQ(r.status, 0) << r.err;
  const std::vector<std::string> csv = lines(readFile(dir_ / "out" / "material_sweep.csv"));
  ASSERT_EQ(csv.size(), 1u + 6u * 31u);
  EXPECT_EQ(csv[0], "model,s,psi_J_per_m2,P11_N_per_m,P22_N_per_m");
  std::map<std::string, int> rowsPerModel;
  for (std::size_t i = 1; i < csv.size(); ++i) {
    std::vector<std::string> field;
    std::istringstream row(csv[i]);
    for (std::string f; std::getline(row, f, ',');) field.push_back(f);
    ASSERT_EQ(field.size(), 5u) << csv[i];
    const std::string& model = field[0];
    ++rowsPerModel[model];
    const double s = std::stod(field[1]), psi = std::stod(field[2]);
    const double p11 = std::stod(field[3]), p22 = std::stod(field[4]);
    if (model == "stvk") {
      // psi = (mu/4 + lambda/8)(s^2 - 1)^2; S = 2 mu E + lambda tr(E) I with E = diag(0, (s^2-1)/2).
      const double q = s * s - 1.0;
      EXPECT_NEAR(psi, (mu / 4 + lambda / 8) * q * q, 1e-12) << s;
      EXPECT_NEAR(p11, lambda * q / 2, 1e-12) << s;
      EXPECT_NEAR(p22, s * (mu + lambda / 2) * q, 1e-12) << s;
    } else if (model == "stable_neo_hookean") {
      EXPECT_NEAR(psi, (2 * mu + lambda) / 2 * (s - 1) * (s - 1), 1e-12) << s;
      EXPECT_NEAR(p22, (2 * mu + lambda) * (s - 1), 1e-12) << s;
    } else if (model == "neo_hookean" && s <= 0.0) {
      EXPECT_EQ(field[2], "inf") << csv[i];
      EXPECT_EQ(field[3], "nan") << csv[i];
      EXPECT_EQ(field[4], "nan") << csv[i];
    }
  }
  for (const char* model :
       {"linear", "stvk", "corotational", "arap", "neo_hookean", "stable_neo_hookean"}) {
    EXPECT_EQ(rowsPerModel[model], 31) << model;
  }
  EXPECT_TRUE(contains(r.out, "material_sweep.csv"));
}

TEST_F(MaterialsTool, SweepPlotsAPng) {
  const ProgramRun r = run({"sweep", "--out", dir_.string(), "--plot"});
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string png = readFile(dir_ / "material_sweep.png");
  ASSERT_GT(png.size(), 10000u);
  EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
}

TEST_F(MaterialsTool, PlotScriptSaysWhenMatplotlibIsMissing) {
  // python3 -S leaves out site-packages, where matplotlib lives.
  const ProgramRun r = run({"-S", FEM_CLOTH_PLOT_SWEEP_SCRIPT, "--csv", "x.csv", "--png", "x.png"}, "",
                    "/usr/bin/python3");
  EXPECT_EQ(r.status, 3);
  EXPECT_TRUE(contains(r.err, "python3-matplotlib")) << r.err;
}

TEST_F(MaterialsTool, SweepRejectsBadOptions) {
  for (const std::vector<std::string>& args :
       std::vector<std::vector<std::string>>{{"sweep", "--out", dir_.string(), "--count", "1"},
                                             {"sweep", "--out", dir_.string(), "--mu", "-1"},
                                             {"sweep", "--out", dir_.string(), "--s-min", "2"}}) {
    const ProgramRun r = run(args);
    EXPECT_NE(r.status, 0) << args.back();
    EXPECT_FALSE(r.err.empty());
  }
}

TEST_F(MaterialsTool, AuditPrintsTheVerdicts) {
  const fs::path csvPath = dir_ / "audit.csv";
  const ProgramRun r = run({"audit", "--csv", csvPath.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  std::map<std::string, std::string> rowOf;
  for (const std::string& line : lines(r.out)) rowOf[line.substr(0, line.find(' '))] = line;
  for (const char* model :
       {"linear", "stvk", "corotational", "arap", "neo_hookean", "stable_neo_hookean"}) {
    ASSERT_TRUE(rowOf.count(model)) << model << "\n" << r.out;
    EXPECT_EQ(rowOf[model].substr(rowOf[model].size() - 8), "accepted") << rowOf[model];
  }
  EXPECT_TRUE(contains(rowOf["norm_squared"], "rejected: rest energy, rest stress, linear order"));
  EXPECT_TRUE(
      contains(rowOf["norm_squared_minus_2"], "rejected: rest stress, non-negative, linear order"));
  EXPECT_TRUE(contains(rowOf["linear"], "exempt"));

  const std::vector<std::string> csv = lines(readFile(csvPath));
  ASSERT_EQ(csv.size(), 9u);
  EXPECT_EQ(csv[0].rfind("model,counterexample,accepted,verdict,rest_energy,rest_energy_pass,", 0),
            0u);
  for (std::size_t i = 1; i <= 6; ++i) {
    EXPECT_NE(csv[i].find(",false,true,accepted,"), std::string::npos) << csv[i];
  }
  EXPECT_EQ(csv[7].rfind("norm_squared,true,false,\"rejected: rest energy, rest stress, linear "
                         "order\",",
                         0),
            0u)
      << csv[7];
  EXPECT_EQ(csv[8].rfind("norm_squared_minus_2,true,false,\"rejected: rest stress, "
                         "non-negative, linear order\",",
                         0),
            0u)
      << csv[8];
}

TEST_F(MaterialsTool, CommandLineHelpAndErrors) {
  const ProgramRun help = run({"--help"});
  EXPECT_EQ(help.status, 0);
  for (const char* sub : {"eval", "sweep", "audit"}) EXPECT_TRUE(contains(help.out, sub)) << sub;
  const ProgramRun evalHelp = run({"eval", "--help"});
  EXPECT_EQ(evalHelp.status, 0);
  EXPECT_TRUE(contains(evalHelp.out, "Blank lines")) << evalHelp.out;
  const ProgramRun sweepHelp = run({"sweep", "--help"});
  EXPECT_EQ(sweepHelp.status, 0);
  EXPECT_TRUE(contains(sweepHelp.out, "--plot") && contains(sweepHelp.out, "P22_N_per_m"));
  const ProgramRun auditHelp = run({"audit", "--help"});
  EXPECT_EQ(auditHelp.status, 0);
  EXPECT_TRUE(contains(auditHelp.out, "--csv") && contains(auditHelp.out, "linear order"));

  const ProgramRun unknownOption = run({"sweep", "--bogus"});
  EXPECT_NE(unknownOption.status, 0);
  EXPECT_TRUE(contains(unknownOption.err + unknownOption.out, "--bogus"));
  const ProgramRun unknownSubcommand = run({"frobnicate"});
  EXPECT_NE(unknownSubcommand.status, 0);
  EXPECT_TRUE(contains(unknownSubcommand.err + unknownSubcommand.out, "frobnicate"));
  const ProgramRun none = run({});
  EXPECT_NE(none.status, 0);
}
