// The bag tools as a user runs them: fem_cloth_sim writing and re-simulating bags (exit
// statuses, --verify) and fem_cloth_bagdiff on bags whose difference is known by construction.
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <std_msgs/String.h>

#include <filesystem>
#include <regex>

#include "../run_program.h"
#include "fem_cloth/ClothState.h"

using fem_cloth::test::ProgramResult;
using fem_cloth::test::TempDir;

namespace {

const std::string kSim = FEM_CLOTH_SIM_EXE;
const std::string kBagdiff = FEM_CLOTH_BAGDIFF;
const std::string kScene = std::string(FEM_CLOTH_SOURCE_DIR) + "/test/rostest/config/small_cloth.yaml";

const TempDir& scratch() {
  static const TempDir dir("fem_cloth_test_bag_tools");
  return dir;
}

ProgramResult sim(const std::vector<std::string>& args) {
  return fem_cloth::test::runProgram(kSim, args, scratch());
}

ProgramResult bagdiff(const std::vector<std::string>& args) {
  std::vector<std::string> all = {kBagdiff};
  all.insert(all.end(), args.begin(), args.end());
  return fem_cloth::test::runProgram("/usr/bin/python3", all, scratch());
}

// Writes states of `n` vertices on a line moving up at 0.5 m/s, at the steps 0, every, 2 every,
// ... up to `last` (dt = 0.01 s), shifted up by `offset` (m).
void writeLinearMotion(const std::string& path, int n, int every, int last, double offset) {
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  std_msgs::String scene;
  scene.data = "integrator: {dt: 0.01}\n";
  const ros::Time epoch(50.0);
  bag.write("/fem_cloth_node/scene", epoch, scene);
  for (int step = 0; step <= last; step += every) {
    fem_cloth::ClothState s;
    s.header.stamp = epoch + ros::Duration(0.01 * step);
    s.step = static_cast<std::uint64_t>(step);
    s.positions.resize(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
      s.positions[i].x = 0.1 * i;
      s.positions[i].z = 0.5 * 0.01 * step + offset;
    }
    bag.write("/fem_cloth_node/state", s.header.stamp, s);
  }
}

std::string summaryOf(const ProgramResult& r) {
  std::smatch m;
  static const std::regex line("summary: [^\n]*");
  return std::regex_search(r.out, m, line) ? m.str() : std::string();
}

}  // namespace

TEST(FemClothSimBags, WritesAndVerifiesARun) {
  const std::string run = scratch().path("run.bag");
  ProgramResult r = sim({"--scene", kScene, "--duration", "0.6", "--out", run, "-q"});
  ASSERT_EQ(r.status, 0) << r.err;
  ASSERT_TRUE(std::filesystem::exists(run));
  // Re-simulating the recorded scene reproduces every state: 0.6 s at dt 0.01, a state every
  // 3 steps -> steps 0, 3, ..., 60: 21 states.
  r = sim({"--commands", run, "--out", scratch().path("again.bag"), "--verify", "-q"});
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("reproduced:   21 of 21 recorded states bit for bit"), std::string::npos)
      << r.out;
  // Another integrator does not reproduce it: --verify fails with status 4.
  r = sim({"--commands", run, "--out", scratch().path("other.bag"), "--integrator",
           "symplectic_euler", "--verify", "-q"});
  EXPECT_EQ(r.status, 4) << r.out << r.err;
  EXPECT_NE(r.err.find("recorded states were not reproduced"), std::string::npos) << r.err;
}

// --verify needs no --out (issue 15, item 6): it compares and writes nothing.
TEST(FemClothSimBags, VerifiesWithoutWritingABag) {
  const std::string run = scratch().path("verify_only.bag");
  ProgramResult r = sim({"--scene", kScene, "--duration", "0.3", "--out", run, "-q"});
  ASSERT_EQ(r.status, 0) << r.err;
  const auto before = std::distance(std::filesystem::directory_iterator(scratch().path("")),
                                    std::filesystem::directory_iterator());
  r = sim({"--commands", run, "--verify", "-q"});
  EXPECT_EQ(r.status, 0) << r.err;
  // 0.3 s at dt 0.01, a state every 3 steps: steps 0, 3, ..., 30.
  EXPECT_NE(r.out.find("reproduced:   11 of 11 recorded states bit for bit"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("output:       none"), std::string::npos) << r.out;
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(scratch().path("")), std::filesystem::directory_iterator()),
            before) << "a file was written";
  r = sim({"--commands", run, "--integrator", "symplectic_euler", "--verify", "-q"});
  EXPECT_EQ(r.status, 4) << r.out << r.err;
}

TEST(FemClothSimBags, BadBagsAreOneErrorAndStatus2) {
  ProgramResult r = sim({"--commands", scratch().path("missing.bag"), "--out", scratch().path("o.bag")});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("no bag at"), std::string::npos) << r.err;
  r = sim({"--commands", scratch().path("missing.bag"), "--out", scratch().path("o")});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("give --out FILE.bag"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(scratch().path("o.bag")));
}

TEST(Bagdiff, KnownOffsetWithInterpolation) {
  // A at every step, B at every other step and 1 mm higher. Both move linearly, so B
  // interpolated at A's odd steps is exact: every vertex differs by exactly 1 mm.
  const std::string a = scratch().path("a.bag"), b = scratch().path("b.bag");
  writeLinearMotion(a, 5, 1, 10, 0.0);
  writeLinearMotion(b, 5, 2, 10, 0.001);
  const ProgramResult r = bagdiff({a, b});
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string s = summaryOf(r);
  EXPECT_NE(s.find("11 states compared (5 interpolated)"), std::string::npos) << s;
  EXPECT_NE(s.find("RMS at the end 1.000e-03 m"), std::string::npos) << s;
  EXPECT_NE(s.find("largest difference 1.000e-03 m"), std::string::npos) << s;
  // --tolerance decides the exit status.
  EXPECT_EQ(bagdiff({a, b, "--tolerance", "5e-4"}).status, 1);
  EXPECT_EQ(bagdiff({a, b, "--tolerance", "2e-3"}).status, 0);
}

TEST(Bagdiff, IdenticalBagsAndPlot) {
  const std::string a = scratch().path("same.bag");
  writeLinearMotion(a, 4, 1, 6, 0.0);
  const std::string png = scratch().path("diff.png");
  const ProgramResult r = bagdiff({a, a, "--plot", png});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(summaryOf(r).find(": identical"), std::string::npos) << r.out;
  EXPECT_GT(std::filesystem::file_size(png), 1000u);
}

TEST(Bagdiff, BadInputIsStatus2WithAReason) {
  const std::string a = scratch().path("five.bag"), b = scratch().path("six.bag");
  writeLinearMotion(a, 5, 1, 4, 0.0);
  writeLinearMotion(b, 6, 1, 4, 0.0);
  ProgramResult r = bagdiff({a, b});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("different meshes: 5 and 6 vertices"), std::string::npos) << r.err;
  r = bagdiff({a, scratch().path("nowhere.bag")});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("no bag at"), std::string::npos) << r.err;
  // Truncated.
  std::filesystem::copy_file(a, scratch().path("cut.bag"),
                             std::filesystem::copy_options::overwrite_existing);
  std::filesystem::resize_file(scratch().path("cut.bag"), std::filesystem::file_size(a) / 2);
  r = bagdiff({scratch().path("cut.bag"), a});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("cut.bag"), std::string::npos) << r.err;
}
