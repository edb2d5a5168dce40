// The bag tools as a user runs them: fem_cloth_sim writing and re-simulating bags (exit
// statuses, --verify) and fem_cloth_bagdiff on bags whose difference is known by construction.
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <std_msgs/String.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>

#include "../run_program.h"
#include "fem_cloth/ClothState.h"
#include "fem_cloth/ForceCommand.h"
#include "fem_cloth/PinCommand.h"
#include <rosbag/view.h>
#include <tf2_msgs/TFMessage.h>

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

// Both killed after 120 s: a read that never ends fails the test instead of hanging it.
ProgramResult sim(const std::vector<std::string>& args) {
  return fem_cloth::test::runProgramWithin(120, kSim, args, scratch());
}

ProgramResult bagdiff(const std::vector<std::string>& args) {
  std::vector<std::string> all = {kBagdiff};
  all.insert(all.end(), args.begin(), args.end());
  return fem_cloth::test::runProgramWithin(120, "/usr/bin/python3", all, scratch());
}

// Writes states of `n` vertices on a line moving up at 0.5 m/s, at the steps 0, every, 2 every,
// ... up to `last` (dt = 0.01 s), shifted up by `offset` (m); with `resetAt` > 0, the node is
// reset after that step and the states start again from step 0 (bag time going on); with
// `pauseAt` > 0, the node is paused there for `pause` s: the state of that step is published
// again with its new stamp, and every later stamp is `pause` s later (docs/node.md, Time).
void writeLinearMotion(const std::string& path, int n, int every, int last, double offset,
                       int resetAt = 0, int pauseAt = 0, double pause = 0.0) {
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  std_msgs::String scene;
  scene.data = "integrator: {dt: 0.01}\n";
  const ros::Time epoch(50.0);
  bag.write("/fem_cloth_node/scene", epoch, scene);
  std::vector<int> steps;
  for (int step = 0; step <= last; step += every) steps.push_back(step);
  if (resetAt > 0) {
    steps.erase(std::upper_bound(steps.begin(), steps.end(), resetAt), steps.end());
    for (int step = 0; step <= last; step += every) steps.push_back(step);
  }
  if (pauseAt > 0) steps.insert(std::upper_bound(steps.begin(), steps.end(), pauseAt), pauseAt);
  ros::Time received = epoch;
  bool paused = false;
  for (int step : steps) {
    fem_cloth::ClothState s;
    s.header.stamp = epoch + ros::Duration(0.01 * step + (paused ? pause : 0.0));
    paused = paused || (pauseAt > 0 && step == pauseAt);
    s.step = static_cast<std::uint64_t>(step);
    s.positions.resize(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
      s.positions[i].x = 0.1 * i;
      s.positions[i].z = 0.5 * 0.01 * step + offset;
    }
    received += ros::Duration(0.01);
    bag.write("/fem_cloth_node/state", received, s);
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

// The line of a summary that starts with `label`.
std::string lineOf(const std::string& out, const std::string& label) {
  const std::size_t at = out.find(label);
  return at == std::string::npos ? std::string() : out.substr(at, out.find('\n', at) - at);
}

// A replay judges its energy balance as a scene run does (one judgement, judgeBalance): the
// re-simulation is the recorded run bit for bit, so its balance line is the scene run's to the
// digit, and the JSON summary carries the judgement and an "ok" status.
TEST(FemClothSimBags, AReplayJudgesItsBalanceAsTheSceneRunDoes) {
  const std::string run = scratch().path("balance.bag"), json = scratch().path("balance.json");
  ASSERT_EQ(sim({"--scene", kScene, "--duration", "0.3", "--out", run, "-q"}).status, 0);
  const ProgramResult scene = sim({"--scene", kScene, "--duration", "0.3", "--no-output", "-q"});
  ASSERT_EQ(scene.status, 0) << scene.err;
  const ProgramResult replay = sim({"--commands", run, "--verify", "-q", "--summary-json", json});
  ASSERT_EQ(replay.status, 0) << replay.err;
  const std::string line = lineOf(scene.out, "balance:      energy created (net) ");
  ASSERT_FALSE(line.empty()) << scene.out;
  EXPECT_NE(line.find("(at most 5 % accepted)"), std::string::npos) << line;
  EXPECT_EQ(lineOf(replay.out, "balance:      "), line) << replay.out;
  EXPECT_EQ(replay.err.find("energy balance out of tolerance"), std::string::npos) << replay.err;
  std::ifstream in(json);
  const std::string summary((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(summary.find("\"status\": \"ok\""), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"balance\": {"), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"tolerance\": 0.05"), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"ok\": true"), std::string::npos) << summary;
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

// States are paired by step x dt, not by stamp: a run paused for 3 s in the middle (its stamps
// 3 s later from there on) is the same run as one never paused.
TEST(Bagdiff, PairsStatesByStepNotByStampAcrossAPause) {
  const std::string paused = scratch().path("paused.bag"), straight = scratch().path("straight.bag");
  writeLinearMotion(paused, 4, 1, 20, 0.0, 0, 10, 3.0);
  writeLinearMotion(straight, 4, 1, 20, 0.0);
  const ProgramResult r = bagdiff({paused, straight});
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const std::string s = summaryOf(r);
  // Steps 0 to 20 (step 10 twice in the paused bag counts once), none interpolated.
  EXPECT_NE(s.find("21 states compared (0 interpolated)"), std::string::npos) << s;
  EXPECT_NE(s.find(": identical"), std::string::npos) << s;
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

namespace {

// A bag holding the test scene and one extra message, written at bag time 10 s.
template <class M>
std::string bagWith(const std::string& name, const std::string& topic, const M& message) {
  const std::string path = scratch().path(name);
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  std_msgs::String scene;
  scene.data = fem_cloth::test::readTextFile(kScene);
  bag.write("/fem_cloth_node/scene", ros::Time(10.0), scene);
  bag.write(topic, ros::Time(10.5), message);
  return path;
}

/// Exit 2 and one stderr line naming every word in `mentions`.
void expectBadBag(const ProgramResult& r, const std::vector<std::string>& mentions) {
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  for (const std::string& m : mentions) EXPECT_NE(r.err.find(m), std::string::npos) << r.err << " does not name " << m;
}

}  // namespace

// Bags that used to abort fem_cloth_sim ("Duration is out of dual 32-bit range", uncaught): one
// line naming the problem, status 2.
TEST(FemClothSimBags, BagsThatUsedToCrashAreOneLineAndStatus2) {
  const std::string out = scratch().path("never.bag");
  { rosbag::Bag empty(scratch().path("empty.bag"), rosbag::bagmode::Write); }
  expectBadBag(sim({"--commands", scratch().path("empty.bag"), "--out", out, "-q"}), {"empty.bag", "holds no messages"});
  // A command stamped 4294967295 s, 4.3e9 s after the recording started.
  fem_cloth::PinCommand far;
  far.header.stamp = ros::Time(4294967295u, 0);
  far.header.frame_id = "world";
  far.vertices = {0};
  far.targets.resize(1);
  // The node refuses such a command (and records it as sent): the replay leaves it out with a
  // warning naming it, and runs (ACommandTheNodeRefusedForItsStampIsLeftOutOfTheReplay).
  const ProgramResult farRun = sim({"--commands", bagWith("far_command.bag", "/fem_cloth_node/pin", far), "-q"});
  EXPECT_EQ(farRun.status, 0) << farRun.err;
  for (const char* word : {"/fem_cloth_node/pin", "4.29497e+09 s", "1e+09 s", "left out"}) {
    EXPECT_NE(farRun.err.find(word), std::string::npos) << farRun.err;
  }
  tf2_msgs::TFMessage tf;
  tf.transforms.resize(1);
  tf.transforms[0].header.stamp = ros::Time(4e9);
  tf.transforms[0].header.frame_id = "world";
  tf.transforms[0].child_frame_id = "gripper";
  tf.transforms[0].transform.rotation.w = 1.0;
  expectBadBag(sim({"--commands", bagWith("far_tf.bag", "/tf", tf), "--out", out, "-q"}), {"far_tf.bag", "'gripper'"});
  // A state whose step does not fit its stamp (step x dt = 1e16 s before a stamp of 10.5 s).
  fem_cloth::ClothState state;
  state.header.stamp = ros::Time(10.5);
  state.step = 1000000000000000000ull;
  expectBadBag(sim({"--commands", bagWith("far_step.bag", "/fem_cloth_node/state", state), "--out", out, "-q"}),
               {"far_step.bag", "step 1000000000000000000", "does not fit"});
  // Not a bag file at all.
  std::filesystem::create_directories(scratch().path("folder.bag"));
  expectBadBag(sim({"--commands", scratch().path("folder.bag"), "--out", out, "-q"}), {"folder.bag", "not a regular file"});
  // A folder as the output: refused before the run, not when the bag cannot be renamed onto it.
  expectBadBag(sim({"--scene", kScene, "--duration", "0.05", "--out", scratch().path("folder.bag"), "-q"}),
               {"folder.bag", "it is a directory"});
  EXPECT_FALSE(std::filesystem::exists(out));
}

// ROS time runs to 2^32 s (2106); a recording made after 2038 (stamps beyond 2^31 s, where
// ros::Duration ends) replays bit for bit like any other: the same run, shifted by 3e9 s.
TEST(FemClothSimBags, RecordingsAfter2038ReplayBitForBit) {
  const std::string run = scratch().path("early.bag");
  ASSERT_EQ(sim({"--scene", kScene, "--duration", "0.3", "--out", run, "-q"}).status, 0);
  const std::string late = scratch().path("late.bag");
  {
    rosbag::Bag in(run), out(late, rosbag::bagmode::Write);
    for (const rosbag::MessageInstance& m : rosbag::View(in)) {
      if (auto s = m.instantiate<fem_cloth::ClothState>()) {
        s->header.stamp = ros::Time(s->header.stamp.toSec() + 3e9);
        out.write(m.getTopic(), ros::Time(m.getTime().toSec() + 3e9), *s);
      } else if (auto scene = m.instantiate<std_msgs::String>()) {
        out.write(m.getTopic(), ros::Time(m.getTime().toSec() + 3e9), *scene);
      }
    }
  }
  const ProgramResult early = sim({"--commands", run, "--out", scratch().path("early_again.bag"), "--verify", "-q"});
  const ProgramResult again = sim({"--commands", late, "--out", scratch().path("late_again.bag"), "--verify", "-q"});
  ASSERT_EQ(early.status, 0) << early.err;
  ASSERT_EQ(again.status, 0) << again.err;
  EXPECT_NE(again.out.find("reproduced:   11 of 11 recorded states bit for bit"), std::string::npos) << again.out;
  std::smatch a, b;
  static const std::regex digest("digest: +([0-9a-f]{16})");
  ASSERT_TRUE(std::regex_search(early.out, a, digest));
  ASSERT_TRUE(std::regex_search(again.out, b, digest));
  EXPECT_EQ(a[1], b[1]);
}

// Commands of a recording made after 2038 (stamps beyond 2^31 s): the replay takes their times
// from the run's origin in 64-bit nanoseconds (secondsBetween), so the same force, stamped 0.105 s
// into the run, gives the same final state whether the recording started at 10 s or at 3e9 + 10 s;
// and it is applied (the state differs from the replay without it).
TEST(FemClothSimBags, CommandsOfARecordingAfter2038Replay) {
  const std::string run = scratch().path("commands_early.bag");
  ASSERT_EQ(sim({"--scene", kScene, "--duration", "0.3", "--out", run, "-q"}).status, 0);
  auto shifted = [&](const std::string& name, double shift, bool withForce) {
    const std::string path = scratch().path(name);
    rosbag::Bag in(run), out(path, rosbag::bagmode::Write);
    ros::Time epoch;
    for (const rosbag::MessageInstance& m : rosbag::View(in)) {
      if (auto s = m.instantiate<fem_cloth::ClothState>()) {
        if (s->step == 0) epoch = s->header.stamp;
        s->header.stamp = ros::Time(s->header.stamp.toSec() + shift);
        out.write(m.getTopic(), ros::Time(m.getTime().toSec() + shift), *s);
      } else if (auto scene = m.instantiate<std_msgs::String>()) {
        out.write(m.getTopic(), ros::Time(m.getTime().toSec() + shift), *scene);
      }
    }
    if (withForce) {
      fem_cloth::ForceCommand force;
      force.header.stamp = ros::Time(epoch.toSec() + shift + 0.105);
      force.header.frame_id = "world";
      force.action = fem_cloth::ForceCommand::APPLY;
      force.vertices = {40};
      force.forces.resize(1);
      force.forces[0].x = 2.0;
      out.write("/fem_cloth_node/force", force.header.stamp, force);
    }
    return path;
  };
  static const std::regex digest("digest: +([0-9a-f]{16})");
  auto replayDigest = [&](const std::string& bag) {
    const ProgramResult r = sim({"--commands", bag, "--out", bag + ".replay.bag", "-q"});
    EXPECT_EQ(r.status, 0) << bag << ": " << r.err;
    std::smatch d;
    return std::regex_search(r.out, d, digest) ? d[1].str() : "no digest in: " + r.out;
  };
  const std::string late = shifted("commands_late.bag", 3e9, true);
  const ProgramResult lateRun = sim({"--commands", late, "--out", scratch().path("commands_late_again.bag"), "-q"});
  ASSERT_EQ(lateRun.status, 0) << lateRun.err;
  EXPECT_NE(lateRun.out.find("0 pin, 1 force"), std::string::npos) << lateRun.out;
  EXPECT_NE(lateRun.out.find("0 rejected"), std::string::npos) << lateRun.out;
  const std::string early = replayDigest(shifted("commands_early_force.bag", 0.0, true));
  EXPECT_EQ(replayDigest(late), early);
  EXPECT_NE(replayDigest(shifted("commands_late_none.bag", 3e9, false)), early);
}

// A recording that spans a reset of the node (~reset: the state's step goes back) cannot be
// reproduced, since nothing in it says which commands came before the reset: refused, by the
// replay and by bagdiff, naming where the reset is.
// The node refuses a command stamped 2^32 s and records it as sent; a replay of that recording
// leaves it out the same way (with a warning) instead of refusing the whole recording.
TEST(FemClothSimBags, ACommandTheNodeRefusedForItsStampIsLeftOutOfTheReplay) {
  const std::string run = scratch().path("far_stamp_run.bag");
  ASSERT_EQ(sim({"--scene", kScene, "--duration", "0.3", "--out", run, "-q"}).status, 0);
  auto withForces = [&](const std::string& name, bool farOne) {
    const std::string path = scratch().path(name);
    rosbag::Bag in(run), out(path, rosbag::bagmode::Write);
    ros::Time epoch;
    for (const rosbag::MessageInstance& m : rosbag::View(in)) {
      if (auto s = m.instantiate<fem_cloth::ClothState>()) {
        if (s->step == 0) epoch = s->header.stamp;
        out.write(m.getTopic(), m.getTime(), *s);
      } else if (auto scene = m.instantiate<std_msgs::String>()) {
        out.write(m.getTopic(), m.getTime(), *scene);
      }
    }
    fem_cloth::ForceCommand force;
    force.header.stamp = ros::Time(epoch.toSec() + 0.105);
    force.header.frame_id = "world";
    force.action = fem_cloth::ForceCommand::APPLY;
    force.vertices = {40};
    force.forces.resize(1);
    force.forces[0].x = 2.0;
    out.write("/fem_cloth_node/force", force.header.stamp, force);
    if (farOne) {
      force.header.stamp = ros::Time(4294967295u, 0u);
      force.forces[0].x = 50.0;
      out.write("/fem_cloth_node/force", ros::Time(epoch.toSec() + 0.2), force);
    }
    return path;
  };
  static const std::regex digest("digest: +([0-9a-f]{16})");
  // Not --verify: the recorded states are those of the run without forces.
  const ProgramResult good = sim({"--commands", withForces("far_stamp_good.bag", false), "--duration", "0.3"});
  const ProgramResult far = sim({"--commands", withForces("far_stamp_far.bag", true), "--duration", "0.3"});
  ASSERT_EQ(far.status, 0) << far.err;
  EXPECT_NE(far.err.find("left out"), std::string::npos) << far.err;
  EXPECT_NE(far.err.find("4.29497e+09"), std::string::npos) << far.err;
  EXPECT_NE(far.out.find("1 force"), std::string::npos) << far.out;
  std::smatch a, b;
  ASSERT_TRUE(std::regex_search(good.out, a, digest)) << good.out;
  ASSERT_TRUE(std::regex_search(far.out, b, digest)) << far.out;
  EXPECT_EQ(a[1].str(), b[1].str());  // the refused force had no effect
}

TEST(FemClothSimBags, ARecordingThatSpansAResetIsRefused) {
  const std::string reset = scratch().path("reset.bag"), plain = scratch().path("plain.bag");
  writeLinearMotion(reset, 4, 2, 10, 0.0, 6);
  writeLinearMotion(plain, 4, 2, 10, 0.0);
  const ProgramResult r = sim({"--commands", reset, "--scene", kScene, "--out", scratch().path("r.bag"), "-q"});
  expectBadBag(r, {"reset.bag", "spans a reset", "from 6 to 0"});
  expectBadBag(bagdiff({reset, plain}), {"reset.bag", "spans a reset", "from 6 to 0"});
  expectBadBag(bagdiff({plain, reset}), {"reset.bag", "spans a reset"});
}

// States of one bag outside the time span of the other cannot be compared: a difference (status
// 1, their number and range), never "identical" (a 435-state recording against a 55-state
// replay used to be "identical").
TEST(Bagdiff, StatesThatCannotBePairedAreADifference) {
  const std::string full = scratch().path("full.bag"), part = scratch().path("part.bag");
  writeLinearMotion(full, 3, 1, 10, 0.0);
  writeLinearMotion(part, 3, 1, 4, 0.0);
  ProgramResult r = bagdiff({full, part});
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(summaryOf(r).find("5 states compared"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("identical"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("unpaired: 6 states of A (t = 0.050 to 0.100 s)"), std::string::npos) << r.out;
  r = bagdiff({part, full});
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("unpaired: 6 states of B (t = 0.050 to 0.100 s)"), std::string::npos) << r.out;
  // The same span, B sparser: every state paired (B interpolated), no unpaired ones.
  const std::string sparse = scratch().path("sparse.bag");
  writeLinearMotion(sparse, 3, 2, 10, 0.0);
  r = bagdiff({full, sparse});
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(summaryOf(r).find("11 states compared (5 interpolated)"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("unpaired"), std::string::npos) << r.out;
}

// --plot naming one of the bags would overwrite it: refused, the bag untouched.
TEST(Bagdiff, APlotIsNeverABag) {
  const std::string a = scratch().path("plotted.bag");
  writeLinearMotion(a, 3, 1, 4, 0.0);
  const std::string before = fem_cloth::test::readTextFile(a);
  expectBadBag(bagdiff({a, a, "--plot", a}), {"--plot", "plotted.bag", "destroy"});
  EXPECT_EQ(fem_cloth::test::readTextFile(a), before);
}

// `rosrun fem_cloth TOOL` finds exactly one executable for each Python tool, in the layout the
// scripts build (catkin_build/ inside the source tree, which rosrun searches too): with several
// it stops at a numbered prompt, which with stdin closed runs nothing. So each is run with stdin
// closed and must print its own usage (argparse names the program) and exit 0.
TEST(Rosrun, FindsOneCopyOfEachPythonTool) {
  for (const std::string tool : {"fem_cloth_bagdiff", "fem_cloth_batch", "bag_report.py",
                                 "plot_report.py", "plot_material_sweep.py"}) {
    const ProgramResult r = fem_cloth::test::runProgramWithin(
        60, "/bin/sh", {"-c", "exec rosrun fem_cloth \"$0\" --help <&-", tool}, scratch());
    EXPECT_EQ(r.out.find("non-unique"), std::string::npos) << tool << ":\n" << r.out;
    EXPECT_EQ(r.out.rfind("usage: " + tool + " ", 0), 0u) << tool << ":\n" << r.out << r.err;
    EXPECT_EQ(r.status, 0) << tool << ":\n" << r.out << r.err;
  }
}
