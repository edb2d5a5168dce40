// fem_cloth_sim as a user runs it: the built executable on every shipped scene with every
// integrator, its output files, and its exit status and error line for bad scenes, bad options
// and failing simulations (0 success, 2 bad scene or command line, 3 the simulation failed).
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "../run_program.h"
#include "../temp_dir.h"

namespace {

const std::string kProgram = FEM_CLOTH_SIM_EXE;
const std::string kConfigDir = FEM_CLOTH_CONFIG_DIR;
const std::vector<std::string> kIntegrators = {"symplectic_euler", "backward_euler", "bdf2",
                                               "xpbd"};

const fem_cloth::test::TempDir& scratch() {
  static const fem_cloth::test::TempDir dir("fem_cloth_test_sim");
  return dir;
}

std::string readFile(const std::string& path) { return fem_cloth::test::readTextFile(path); }

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream s(text);
  for (std::string line; std::getline(s, line);) out.push_back(line);
  return out;
}

using Result = fem_cloth::test::ProgramResult;

/// Runs the program with the arguments (single-quoted for the shell).
Result runSim(const std::vector<std::string>& args) {
  return fem_cloth::test::runProgram(kProgram, args, scratch());
}

/// Exit 2 and a single stderr line "fem_cloth_sim: ..." naming every word in `mentions`.
void expectUsageError(const std::vector<std::string>& args,
                      const std::vector<std::string>& mentions) {
  const Result r = runSim(args);
  std::string call;
  for (const std::string& a : args) call += a + " ";
  EXPECT_EQ(r.status, 2) << call << "\n" << r.err;
  const std::vector<std::string> errLines = lines(r.err);
  ASSERT_EQ(errLines.size(), 1u) << call << "\n" << r.err;
  EXPECT_EQ(errLines[0].rfind("fem_cloth_sim: ", 0), 0u) << errLines[0];
  for (const std::string& m : mentions) {
    EXPECT_NE(errLines[0].find(m), std::string::npos) << errLines[0] << " does not name " << m;
  }
  EXPECT_EQ(r.out, "") << call;
}

}  // namespace

// Every shipped scene with every integrator for a few steps: exit 0, every step taken, and a
// summary naming the integrator; nothing on stderr but warnings.
TEST(FemClothSim, EverySceneWithEveryIntegratorRuns) {
  int scenes = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kConfigDir)) {
    if (entry.path().extension() != ".yaml") continue;
    ++scenes;
    for (const std::string& integrator : kIntegrators) {
      const Result r = runSim({"--scene", entry.path().string(), "--integrator", integrator,
                               "--duration", "0.02", "--no-output", "--quiet"});
      const std::string what = entry.path().filename().string() + " with " + integrator;
      // Self-collision is handled by the implicit steppers' barrier only (docs/contact.md): a
      // scene that turns it on refuses the explicit steppers, naming the key.
      if (r.err.find("contact.self_collision needs an implicit integrator") != std::string::npos) {
        EXPECT_EQ(r.status, 2) << what;
        EXPECT_TRUE(integrator == "symplectic_euler" || integrator == "xpbd") << what << r.err;
        continue;
      }
      EXPECT_EQ(r.status, 0) << what << "\n" << r.err;
      EXPECT_NE(r.out.find("integrator:   " + integrator), std::string::npos) << what << r.out;
      // "steps:        N of N (...)": all steps taken.
      const auto at = r.out.find("steps:");
      ASSERT_NE(at, std::string::npos) << what << r.out;
      std::istringstream steps(r.out.substr(at + 6));
      int taken = -1, planned = -2;
      std::string of;
      steps >> taken >> of >> planned;
      EXPECT_EQ(taken, planned) << what;
      EXPECT_GE(taken, 2) << what;
      for (const std::string& line : lines(r.err)) {
        EXPECT_EQ(line.rfind("fem_cloth_sim: warning: ", 0), 0u) << what << ": " << line;
      }
    }
  }
  EXPECT_GE(scenes, 4);
}

// The output files: a trajectory row (time, step, d coordinates per vertex) and an energy row
// per written step, after a header.
TEST(FemClothSim, WritesTrajectoryAndEnergy) {
  const std::string out = scratch().path("run");
  const Result r = runSim({"--scene", kConfigDir + "/seed_triangle.yaml", "--duration", "0.05",
                           "--every", "1", "--out", out, "--quiet"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find(out + "/trajectory.csv"), std::string::npos) << r.out;
  const std::vector<std::string> trajectory = lines(readFile(out + "/trajectory.csv"));
  const std::vector<std::string> energy = lines(readFile(out + "/energy.csv"));
  // dt = 0.01 s: 5 steps plus the initial state, after the header.
  ASSERT_EQ(trajectory.size(), 7u);
  ASSERT_EQ(energy.size(), 7u);
  EXPECT_EQ(trajectory[0], "time,step,x0,y0,x1,y1,x2,y2");
  EXPECT_EQ(energy[0].rfind("time,step,kinetic,strain,", 0), 0u) << energy[0];
  // The initial row holds the scene's initial positions: vertex 1 pushed to (0.5, 0).
  EXPECT_EQ(trajectory[1], "0,0,0,0,0.5,0,0,1");
  std::istringstream last(trajectory.back());
  double time = 0.0;
  last >> time;
  EXPECT_NEAR(time, 0.05, 1e-12);
}

TEST(FemClothSim, BadScenesAndOptionsExit2WithOneLine) {
  const std::string seed = kConfigDir + "/seed_triangle.yaml";
  expectUsageError({"--scene", scratch().path("missing.yaml")}, {"cannot open", "missing.yaml"});
  {
    std::ofstream(scratch().path("broken.yaml")) << "name: broken\nmesh: {type: grid\n";
  }
  expectUsageError({"--scene", scratch().path("broken.yaml")}, {"broken.yaml", "malformed YAML"});
  expectUsageError({"--scene", seed, "--set", "material.colour=red"}, {"material.colour"});
  expectUsageError({"--scene", seed, "--set", "integrator.dt=fast"}, {"integrator.dt", "fast"});
  expectUsageError({"--scene", kConfigDir + "/hanging_cloth.yaml", "--set",
                    "material.poisson_ratio=0.5"},
                   {"hanging_cloth.yaml", "material.poisson_ratio", "0.5"});
  expectUsageError({"--scene", seed, "--set", "nonsense"}, {"nonsense", "key.path=value"});
  expectUsageError({"--scene", seed, "--integrator", "leapfrog"}, {"leapfrog"});
  expectUsageError({"--scene", seed, "--dt", "-0.01"}, {"integrator.dt"});
  expectUsageError({"--scene", seed, "--dt", "abc"}, {"--dt", "abc"});
  expectUsageError({"--scene", seed, "--bogus"}, {"--bogus"});
  expectUsageError({}, {"--scene"});
  // --help is not an error.
  const Result help = runSim({"--help"});
  EXPECT_EQ(help.status, 0);
  EXPECT_NE(help.out.find("--scene"), std::string::npos);
}

// A simulation that fails exits 3 after the summary, with one error line that says why.
TEST(FemClothSim, FailingSimulationsExit3) {
  struct Case {
    std::vector<std::string> args;
    std::string why;
  };
  const std::vector<Case> cases = {
      // Symplectic Euler told not to substep, at 10x its stability bound.
      {{"--scene", kConfigDir + "/seed_triangle.yaml", "--integrator", "symplectic_euler",
        "--set", "integrator.auto_substep=false", "--dt", "1"},
       "CFL bound"},
      // Neo-Hookean cannot follow the planar sheet's pins through each other (t = 1/3 s).
      {{"--scene", kConfigDir + "/planar_sheet.yaml", "--set", "material.model=neo_hookean",
        "--duration", "0.4"},
       "J <= 0"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> args = c.args;
    args.insert(args.end(), {"--no-output", "--quiet"});
    const Result r = runSim(args);
    EXPECT_EQ(r.status, 3) << r.err;
    const std::vector<std::string> errLines = lines(r.err);
    ASSERT_EQ(errLines.size(), 1u) << r.err;
    EXPECT_EQ(errLines[0].rfind("fem_cloth_sim: simulation failed at t = ", 0), 0u) << r.err;
    EXPECT_NE(errLines[0].find(c.why), std::string::npos) << r.err;
    EXPECT_NE(r.out.find("steps:"), std::string::npos) << "the summary is still printed";
    EXPECT_NE(r.out.find("1 failures"), std::string::npos) << r.out;
  }
}
