// Fabric presets (config/materials/, `material: {preset: ...}`): every preset builds and cites
// its source, the ARCSim-derived values follow the conversion written out here, scene keys
// override a preset, and errors name the culprit. The textile lab's subcommands of
// fem_cloth_materials (from-bending-length, from-elongation) against B = w c^3 and E h = F/(w e).
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>

#include "../run_program.h"
#include "fem_cloth/io/scene_yaml.h"

using namespace fem_cloth;

namespace {

const std::string kMaterials = std::string(FEM_CLOTH_CONFIG_DIR) + "/materials";

/// A small grid scene with the given material and bending maps (YAML flow text).
Expected<Scene> sceneWith(const std::string& material, const std::string& bending = "{}",
                          const std::string& source = "") {
  const std::string text = "mesh: {type: grid, rows: 4, cols: 4}\nmaterial: " + material +
                           "\nbending: " + bending + "\nintegrator: {name: backward_euler}\n";
  return parseScene(YAML::Load(text), source);
}

}  // namespace

TEST(MaterialPresets, EveryPresetBuildsAndCitesItsSource) {
  int count = 0;
  for (const auto& f : std::filesystem::directory_iterator(kMaterials)) {
    if (f.path().extension() != ".yaml") continue;
    ++count;
    const std::string name = f.path().stem().string();
    EXPECT_NE(test::readTextFile(f.path().string()).find("Source:"), std::string::npos) << name;
    const Expected<Scene> s = sceneWith("{preset: " + name + "}");
    ASSERT_TRUE(s.ok()) << name << ": " << s.error();
    EXPECT_GT(s->bendingStiffness, 0.0) << name;
    const double areal = s->density * s->thickness;
    EXPECT_GT(areal, 0.05) << name;
    EXPECT_LT(areal, 0.5) << name;
    EXPECT_TRUE(buildSimulation(*s).ok()) << name;
  }
  EXPECT_GE(count, 5);
}

TEST(MaterialPresets, DenimFollowsTheArcsimConversion) {
  // ARCSim's 11oz-black-denim: stretching c = (c11, c12, c22, c33) at zero strain, bending ke at
  // zero curvature for 0, 45, 90 deg, areal density (docs/materials.md, "Presets").
  const double c11 = 205.352005, c12 = 10.234077, c22 = 1013.88629;
  const double Eh = 0.5 * (2 * (c11 - c12 * c12 / c22) + 2 * (c22 - c12 * c12 / c11));
  const double D = (64.196457e-6 + 73.384567e-6 + 96.951576e-6) / 3 / 4;
  const Expected<Scene> s = sceneWith("{preset: denim}");
  ASSERT_TRUE(s.ok()) << s.error();
  EXPECT_NEAR(*s->youngsModulus * s->thickness / Eh, 1.0, 1e-3);
  EXPECT_NEAR(*s->poissonRatio, c12 / std::sqrt(c11 * c22), 1e-3);
  EXPECT_NEAR(s->bendingStiffness / D, 1.0, 1e-3);
  EXPECT_NEAR(s->density * s->thickness, 0.324, 1e-9);
}

TEST(MaterialPresets, SceneKeysOverrideThePreset) {
  const Expected<Scene> s =
      sceneWith("{preset: cotton, poisson_ratio: 0.1, model: neo_hookean}", "{stiffness: 3.0e-5, poisson_ratio: 0.2}");
  ASSERT_TRUE(s.ok()) << s.error();
  EXPECT_EQ(*s->poissonRatio, 0.1);
  EXPECT_EQ(*s->youngsModulus, 0.821e6);  // the preset's
  EXPECT_EQ(s->materialModel, "neo_hookean");
  EXPECT_EQ(s->bendingStiffness, 3.0e-5);
  EXPECT_EQ(s->bendingPoissonRatio, 0.2);
  // mu and lambda in the scene: the preset's E and nu stay out (giving both is an error).
  const Expected<Scene> lame = sceneWith("{preset: cotton, mu: 1.0e5, lambda: 2.0e5}");
  ASSERT_TRUE(lame.ok()) << lame.error();
  EXPECT_FALSE(lame->youngsModulus.has_value());
  EXPECT_EQ(lame->thickness, 0.318e-3);
}

TEST(MaterialPresets, ErrorsNameThePresetAndTheKey) {
  const Expected<Scene> unknown = sceneWith("{preset: corduroy}");
  ASSERT_FALSE(unknown.ok());
  for (const char* word : {"material.preset", "corduroy", "denim", "cotton"}) {
    EXPECT_NE(unknown.error().find(word), std::string::npos) << unknown.error();
  }
  const Expected<Scene> notAName = sceneWith("{preset: [denim]}");
  ASSERT_FALSE(notAName.ok());
  EXPECT_NE(notAName.error().find("material.preset"), std::string::npos) << notAName.error();
  // A folder of one's own ($FEM_CLOTH_MATERIALS_DIR), with a preset holding a key it may not set.
  const test::TempDir dir("fem_cloth_presets");
  dir.write("odd.yaml", "material:\n  youngs_modulus: 1.0e6\n  colour: blue\n");
  dir.write("fine.yaml", "material:\n  youngs_modulus: 1.0e6\n  poisson_ratio: 0.2\n");
  ::setenv("FEM_CLOTH_MATERIALS_DIR", dir.path("").c_str(), 1);
  const Expected<Scene> bad = sceneWith("{preset: odd}");
  const Expected<Scene> fine = sceneWith("{preset: fine}");
  ::unsetenv("FEM_CLOTH_MATERIALS_DIR");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("colour"), std::string::npos) << bad.error();
  ASSERT_TRUE(fine.ok()) << fine.error();
  EXPECT_EQ(*fine->youngsModulus, 1.0e6);
}

TEST(MaterialPresets, APresetIsANameNeverAPath) {
  // A file outside the presets folder whose bytes no error may show: a preset naming it (from a
  // scene, a --set, a batch spec or a bag's scene, all read by parseScene) is refused as a name.
  const test::TempDir dir("fem_cloth_preset_paths");
  const std::string secret = "secretuser:x:1000:1000:secret:/home/secret:/bin/sh\n";
  dir.write("passwd", secret);
  dir.write("passwd.yaml", secret);
  const std::string scene = dir.path("scene.yaml");
  const std::filesystem::path up = std::filesystem::relative(dir.path("passwd"), std::filesystem::current_path());
  for (const std::string& value :
       {std::string("../../../../etc/passwd"), dir.path("passwd"), dir.path("passwd.yaml"), up.string(),
        std::string("passwd.yaml"), std::string("./passwd"), std::string(".."), std::string("denim.yaml"),
        std::string("de/nim"), std::string("")}) {
    const Expected<Scene> s = sceneWith("{preset: '" + value + "'}", "{}", scene);
    ASSERT_FALSE(s.ok()) << value;
    EXPECT_NE(s.error().find("material.preset must be the name of a preset"), std::string::npos) << s.error();
    EXPECT_NE(s.error().find("'" + value + "'"), std::string::npos) << s.error();
    EXPECT_NE(s.error().find("denim"), std::string::npos) << s.error();  // the known names
    EXPECT_EQ(s.error().find("secretuser"), std::string::npos) << s.error();
  }
  // The same file named as the scene itself: one long YAML text, refused without its bytes.
  const Expected<Scene> asScene = loadScene(dir.path("passwd"));
  ASSERT_FALSE(asScene.ok());
  EXPECT_NE(asScene.error().find("not a scene"), std::string::npos) << asScene.error();
  EXPECT_EQ(asScene.error().find("secretuser"), std::string::npos) << asScene.error();
}

TEST(MaterialPresets, AFileWithoutMaterialKeysGetsTheUsualMessages) {
  // No material map at all: the preset lookup steps aside and the reader names what is missing
  // (this once came back as "unexpected structure (invalid node ...)").
  const Expected<Scene> none = parseScene(YAML::Load("mesh: {type: grid, rows: 4, cols: 4}\n"), "");
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().find("youngs_modulus"), std::string::npos) << none.error();
  EXPECT_EQ(none.error().find("unexpected structure"), std::string::npos) << none.error();
  const Expected<Scene> typo =
      parseScene(YAML::Load("mesh: {type: grid, rows: 4, cols: 4}\nintegrator: {substepz: 2}\n"), "");
  ASSERT_FALSE(typo.ok());
  EXPECT_NE(typo.error().find("integrator.substepz"), std::string::npos) << typo.error();
}

TEST(MaterialsLab, FromBendingLengthIsPeircesFormula) {
  const test::TempDir dir("fem_cloth_lab");
  const test::ProgramResult r =
      test::runProgram(FEM_CLOTH_MATERIALS_EXE, {"from-bending-length", "--length", "0.02", "--density", "0.2"}, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const YAML::Node keys = YAML::Load(r.out);
  EXPECT_NEAR(keys["bending"]["stiffness"].as<double>(), 0.2 * 9.81 * 0.02 * 0.02 * 0.02, 1e-11);
  EXPECT_NEAR(keys["material"]["density"].as<double>() * keys["material"]["thickness"].as<double>(), 0.2, 1e-9);
  // ASTM D1388's fixed angle: the overhang reaching 41.5 deg is twice the bending length.
  const test::ProgramResult o =
      test::runProgram(FEM_CLOTH_MATERIALS_EXE, {"from-bending-length", "--overhang", "0.04", "--density", "0.2"}, dir);
  ASSERT_EQ(o.status, 0) << o.err;
  EXPECT_NEAR(YAML::Load(o.out)["bending"]["stiffness"].as<double>(), keys["bending"]["stiffness"].as<double>(), 1e-15);
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"from-bending-length", "--density", "0.2"},
        std::vector<std::string>{"from-bending-length", "--length", "0.02", "--overhang", "0.04", "--density", "0.2"},
        std::vector<std::string>{"from-bending-length", "--length", "-1", "--density", "0.2"}}) {
    const test::ProgramResult bad = test::runProgram(FEM_CLOTH_MATERIALS_EXE, args, dir);
    EXPECT_EQ(bad.status, 2) << bad.out;
    EXPECT_FALSE(bad.err.empty());
  }
}

TEST(MaterialsLab, FromElongationIsForcePerWidthOverStrain) {
  const test::TempDir dir("fem_cloth_lab");
  const test::ProgramResult r = test::runProgram(
      FEM_CLOTH_MATERIALS_EXE, {"from-elongation", "--force", "5", "--width", "0.05", "--strain", "0.01"}, dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const YAML::Node keys = YAML::Load(r.out);
  // E h = 5 N / (0.05 m * 0.01) = 10^4 N/m.
  EXPECT_NEAR(keys["material"]["youngs_modulus"].as<double>() * keys["material"]["thickness"].as<double>(), 1e4, 1e-6);
  const test::ProgramResult e = test::runProgram(
      FEM_CLOTH_MATERIALS_EXE,
      {"from-elongation", "--force", "5", "--width", "0.05", "--extension", "0.002", "--gauge-length", "0.2"}, dir);
  ASSERT_EQ(e.status, 0) << e.err;
  EXPECT_NEAR(YAML::Load(e.out)["material"]["youngs_modulus"].as<double>(), keys["material"]["youngs_modulus"].as<double>(), 1e-3);
  const test::ProgramResult bad = test::runProgram(FEM_CLOTH_MATERIALS_EXE, {"from-elongation", "--force", "5", "--width", "0.05"}, dir);
  EXPECT_EQ(bad.status, 2);
}

// The node's default scene (config/default_cloth.yaml; the node, cloth.launch and
// cloth_rviz.launch take it when no scene is given) is a fabric: cotton's stretch, density and
// bending, as config/materials/cotton.yaml gives them (read here on its own), not the stiff
// sheet without bending of hanging_cloth.yaml (which stays as it is for benchmarks and tests).
TEST(MaterialPresets, TheDefaultSceneIsCottonWithItsBending) {
  const Expected<Scene> s = loadScene(std::string(FEM_CLOTH_CONFIG_DIR) + "/default_cloth.yaml");
  ASSERT_TRUE(s.ok()) << s.error();
  const YAML::Node cotton = YAML::LoadFile(kMaterials + "/cotton.yaml");
  EXPECT_EQ(*s->youngsModulus, cotton["material"]["youngs_modulus"].as<double>());
  EXPECT_EQ(*s->poissonRatio, cotton["material"]["poisson_ratio"].as<double>());
  EXPECT_EQ(s->thickness, cotton["material"]["thickness"].as<double>());
  EXPECT_EQ(s->density, cotton["material"]["density"].as<double>());
  EXPECT_EQ(s->bendingStiffness, cotton["bending"]["stiffness"].as<double>());
  EXPECT_GT(s->bendingStiffness, 0.0);
  const Expected<Scene> sheet = loadScene(std::string(FEM_CLOTH_CONFIG_DIR) + "/hanging_cloth.yaml");
  ASSERT_TRUE(sheet.ok()) << sheet.error();
  EXPECT_EQ(sheet->bendingStiffness, 0.0);
  EXPECT_TRUE(buildSimulation(*s).ok());
}
