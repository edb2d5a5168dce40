// Every tool, given a bad argument, as a user runs it: exit status 2 and one line on stderr that
// names the argument, found before the work (the outputs the run would make are not there
// afterwards). One table for all the tools (issue 31, parts 4 and 5): fem_cloth_validate,
// fem_cloth_render, fem_cloth_report, fem_cloth_materials, fem_cloth_sim, fem_cloth_bagdiff.
#include <gtest/gtest.h>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <std_msgs/String.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "../run_program.h"
#include "../temp_dir.h"

namespace {

using fem_cloth::test::ProgramResult;
using fem_cloth::test::TempDir;

const std::string kSource = FEM_CLOTH_SOURCE_DIR;
const std::string kBag = kSource + "/test/data/small_grasp.bag";
const std::string kTriangle = kSource + "/config/seed_triangle.yaml";

const TempDir& scratch() {
  static const TempDir dir("fem_cloth_test_bad_arguments");
  return dir;
}

// small_grasp.bag with its stored scene replaced by `edit` of it: every other message as recorded.
template <class Edit>
std::string bagWithScene(const std::string& name, Edit edit) {
  const std::string path = scratch().path(name);
  rosbag::Bag in(kBag, rosbag::bagmode::Read);
  rosbag::Bag out(path, rosbag::bagmode::Write);
  for (const rosbag::MessageInstance& m : rosbag::View(in)) {
    if (m.getTopic() == "/fem_cloth_node/scene") {
      std_msgs::String scene;
      scene.data = edit(m.instantiate<std_msgs::String>()->data);
      out.write(m.getTopic(), m.getTime(), scene);
    } else {
      out.write(m.getTopic(), m.getTime(), m);
    }
  }
  return path;
}

struct BadCall {
  std::string tool;                   // the program (a path), or "bagdiff"
  std::vector<std::string> args;      // {OUT}: this call's own scratch path (not made);
                                      // {DOT_OUT}: the same path spelt with a "/./" in it
  std::vector<std::string> mentions;  // what the error line must name
  std::string untouched;              // an output ({OUT}/...) that must not exist afterwards
};

std::string expand(std::string text, const std::string& out) {
  const std::filesystem::path p(out);
  const std::string dotted = (p.parent_path() / "." / p.filename()).string();
  for (const auto& [key, value] : {std::pair{std::string("{DOT_OUT}"), dotted}, std::pair{std::string("{OUT}"), out}}) {
    for (std::size_t at = text.find(key); at != std::string::npos; at = text.find(key)) text.replace(at, key.size(), value);
  }
  return text;
}

std::string name(const std::string& tool) { return std::filesystem::path(tool).filename().string(); }

}  // namespace

TEST(BadArguments, EveryToolRefusesWithStatus2NamingTheArgumentBeforeTheWork) {
  const std::string validate = FEM_CLOTH_VALIDATE_EXE, render = FEM_CLOTH_RENDER_EXE,
                    report = FEM_CLOTH_REPORT_EXE, materials = FEM_CLOTH_MATERIALS_EXE, sim = FEM_CLOTH_SIM_EXE,
                    bagdiff = FEM_CLOTH_BAGDIFF;
  // The scene of another mesh (the 2D triangle) stored with small_grasp's states; a scene that
  // is not YAML.
  const std::string otherMesh =
      bagWithScene("other_mesh.bag", [](const std::string&) { return fem_cloth::test::readTextFile(kTriangle); });
  const std::string badScene = bagWithScene("bad_scene.bag", [](const std::string&) { return "integrator: {dt: [1, 2\n"; });
  // The recorded scene with 17 MiB of comment after it (a scene file may have 16 MiB), or with
  // a second YAML document.
  const std::string hugeScene =
      bagWithScene("huge_scene.bag", [](const std::string& scene) { return scene + "\n# " + std::string(17u << 20, 'x') + "\n"; });
  const std::string twoScenes = bagWithScene("two_scenes.bag", [](const std::string& scene) { return scene + "\n---\nduration: 1\n"; });
  const std::vector<BadCall> calls = {
      // fem_cloth_validate: a gamma of 0 used to fail the peirce case (exit 1); outputs that
      // cannot be written used to be dropped silently after the run (exit 0).
      {validate, {"--case", "peirce", "--gammas", "0"}, {"--gammas"}, ""},
      {validate, {"--case", "tension", "--csv", "/nonexistent/dir/x.csv"}, {"--csv", "/nonexistent/dir"}, ""},
      {validate, {"--case", "tension", "--json", "/dev/full"}, {"--json", "/dev/full"}, ""},
      {validate, {"--case", "tension", "--json", scratch().path("")}, {"--json", "folder"}, ""},
      {validate,
       {"--case", "tension", "--csv", "{OUT}.csv", "--json", "{DOT_OUT}.csv"},
       {"--csv", "--json", "same file"},
       "{OUT}.csv"},
      // fem_cloth_render: --fps 0 used to exit 105 (CLI11's code); /etc/passwd as a view was a
      // raw yaml-cpp error after the bag was read; a scene that is not the mesh of the states
      // was "std::get: wrong index for variant".
      {render, {kBag, "--out", "{OUT}", "--fps", "0"}, {"--fps"}, "{OUT}"},
      {render, {kBag, "--out", "{OUT}", "--view", "/etc/passwd", "--quiet"}, {"--view", "/etc/passwd"}, "{OUT}"},
      {render, {otherMesh, "--out", "{OUT}", "--quiet"}, {"other_mesh.bag", "mesh"}, "{OUT}/frame_00000.png"},
      // fem_cloth_report: refused only after the work-precision study (--grid,
      // --from-cell-results), in it (--reference-resolution 0: exit 3), or not at all (a
      // negative step, cell budget or duration).
      {report, {"--out", "{OUT}", "--quiet", "--reference-resolution", "0"}, {"--reference-resolution"}, "{OUT}"},
      {report, {"--out", "{OUT}", "--quiet", "--grid", "4"}, {"--grid", "4"}, "{OUT}"},
      {report, {"--out", "{OUT}", "--quiet", "--from-cell-results", "/nonexistent"}, {"--from-cell-results", "/nonexistent"}, "{OUT}"},
      {report, {"--out", "{OUT}", "--quiet", "--dts", "-1"}, {"--dts", "-1"}, "{OUT}"},
      {report, {"--out", "{OUT}", "--quiet", "--cell-budget", "-1"}, {"--cell-budget", "-1"}, "{OUT}"},
      {report, {"--out", "{OUT}", "--quiet", "--duration", "-1"}, {"--duration", "-1"}, "{OUT}"},
      // A runner's task: its results file was found unwritable only after its cells ran.
      {report,
       {"--study", "stability", "--quiet", "--cells", "0:1", "--cell-results", "/nonexistent/dir/c.json"},
       {"--cell-results", "/nonexistent/dir"},
       ""},
      // fem_cloth_materials: 1e8 values of s ran for minutes; products that overflow printed
      // "stiffness: inf"; a negative length was answered "give --length".
      {materials, {"sweep", "--out", "{OUT}", "--count", "100000000"}, {"--count", "100000000"}, "{OUT}/material_sweep.csv"},
      {materials, {"from-bending-length", "--length", "1e308", "--density", "0.2"}, {"--length", "not a finite"}, ""},
      {materials, {"from-bending-length", "--length", "-1", "--density", "0.2"}, {"--length must be positive"}, ""},
      {materials, {"from-elongation", "--force", "1e308", "--width", "1e-300", "--strain", "0.01"}, {"--force", "--width"}, ""},
      // fem_cloth_sim: a summary naming the bag it writes was refused after the run, blaming
      // an input; a negative --duration of a replay or --every was taken.
      {sim, {"--scene", kTriangle, "-q", "--out", "{OUT}.bag", "--summary-json", "{OUT}.bag"}, {"--summary-json", "--out"}, "{OUT}.bag"},
      {sim, {"--scene", kTriangle, "-q", "--no-output", "--summary-json", "/nonexistent/dir/s.json"}, {"--summary-json", "/nonexistent/dir"}, ""},
      {sim, {"--commands", kBag, "-q", "--duration", "-1", "--out", "{OUT}.bag"}, {"--duration", "-1"}, "{OUT}.bag"},
      {sim, {"--scene", kTriangle, "-q", "--every", "-3", "--out", "{OUT}"}, {"--every"}, "{OUT}"},
      // A scene stored in a bag was read without the bounds of a scene file.
      {sim, {"--commands", hugeScene, "-q", "--out", "{OUT}.bag"}, {"huge_scene.bag", "16777216 bytes"}, "{OUT}.bag"},
      {sim, {"--commands", twoScenes, "-q", "--out", "{OUT}.bag"}, {"two_scenes.bag", "2 YAML documents"}, "{OUT}.bag"},
      // fem_cloth_bagdiff: a stored scene it cannot read made the states unpairable: "a
      // difference", exit 1.
      {bagdiff, {badScene, kBag}, {"bad_scene.bag", "scene"}, ""},
  };
  int index = 0;
  for (const BadCall& c : calls) {
    const std::string out = scratch().path("call" + std::to_string(index++));
    std::vector<std::string> args;
    for (const std::string& a : c.args) args.push_back(expand(a, out));
    std::string call = name(c.tool);
    for (const std::string& a : args) call += " " + a;
    // Killed after 60 s: a refusal takes well under a second, the work it should not start
    // takes minutes (the bound keeps an old binary from hanging the test; it is no assertion).
    const bool python = c.tool == bagdiff;
    std::vector<std::string> all = args;
    if (python) all.insert(all.begin(), c.tool);
    const ProgramResult r =
        fem_cloth::test::runProgramWithin(60, python ? "/usr/bin/python3" : c.tool, all, scratch());
    EXPECT_EQ(r.status, 2) << call << "\n" << r.err;
    if (r.err.empty()) {
      ADD_FAILURE() << call << " printed no error";
      continue;  // the next call: each row is its own case
    }
    // One line (a warning line before it aside), the program's name first.
    std::string line = r.err.substr(0, r.err.find('\n'));
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << call << "\n" << r.err;
    EXPECT_EQ(line.rfind(name(c.tool), 0), 0u) << call << "\n" << line;
    for (const std::string& m : c.mentions) {
      EXPECT_NE(line.find(m), std::string::npos) << call << "\n" << line << "\ndoes not name " << m;
    }
    if (!c.untouched.empty()) {
      EXPECT_FALSE(std::filesystem::exists(expand(c.untouched, out))) << call << " wrote " << expand(c.untouched, out);
    }
  }
}
