// findPackageFile on hand-made install spaces, devel spaces and workspaces in a temporary folder
// (the layouts catkin writes: programs in <prefix>/lib/fem_cloth, data in share/fem_cloth, a
// .catkin marker listing the source folders), and for this very test program in its build.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "fem_cloth/core/package_paths.h"

namespace fs = std::filesystem;
using fem_cloth::findPackageFile;

namespace {

void write(const fs::path& file, const std::string& text) {
  fs::create_directories(file.parent_path());
  std::ofstream(file) << text;
}

/// A package folder: package.xml naming <name>, and the empty file <relative>.
void makePackage(const fs::path& dir, const std::string& name, const std::string& relative = "") {
  write(dir / "package.xml", "<?xml version=\"1.0\"?>\n<package format=\"2\">\n  <name>" + name +
                                 "</name>\n  <version>0.1.0</version>\n</package>\n");
  if (!relative.empty()) write(dir / relative, "");
}

class PackagePaths : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("fem_cloth_package_paths_" + std::to_string(getpid()));
    fs::remove_all(root_);
    prefix_ = root_ / "space";
    program_ = prefix_ / "lib/fem_cloth/fem_cloth_tool";
    write(program_, "");
  }
  void TearDown() override { fs::remove_all(root_); }

  fs::path root_, prefix_, program_;
};

TEST_F(PackagePaths, InstallSpaceShareFolder) {
  write(prefix_ / ".catkin", "");
  write(prefix_ / "share/fem_cloth/config/a.yaml", "x: 1\n");
  const auto found = findPackageFile("config/a.yaml", program_);
  ASSERT_TRUE(found.ok()) << found.error();
  EXPECT_EQ(*found, prefix_ / "share/fem_cloth/config/a.yaml");
}

TEST_F(PackagePaths, InstallSpaceComesBeforeTheSourceFolders) {
  const fs::path source = root_ / "source";
  makePackage(source, "fem_cloth", "config/a.yaml");
  write(prefix_ / "share/fem_cloth/config/a.yaml", "");
  write(prefix_ / ".catkin", source.string());
  const auto found = findPackageFile("config/a.yaml", program_);
  ASSERT_TRUE(found.ok()) << found.error();
  EXPECT_EQ(*found, prefix_ / "share/fem_cloth/config/a.yaml");
}

TEST_F(PackagePaths, StandaloneDevelSpaceListsThePackageRoot) {
  const fs::path source = root_ / "checkout";
  makePackage(source, "fem_cloth", "scripts/plot.py");
  write(prefix_ / ".catkin", source.string() + "\n");  // a trailing newline is tolerated
  const auto found = findPackageFile("scripts/plot.py", program_);
  ASSERT_TRUE(found.ok()) << found.error();
  EXPECT_EQ(*found, source / "scripts/plot.py");
}

TEST_F(PackagePaths, WorkspaceDevelSpaceSearchesBelowTheSourceFolders) {
  const fs::path first = root_ / "ws/src";
  const fs::path second = root_ / "overlay/src";
  makePackage(first / "other", "other", "config/a.yaml");  // another package's file of that name
  makePackage(second / "group/repo/fem_cloth", "fem_cloth", "config/a.yaml");
  makePackage(second / ".hidden/fem_cloth", "fem_cloth", "config/a.yaml");  // hidden: skipped
  write(prefix_ / ".catkin", first.string() + ";" + second.string());
  const auto found = findPackageFile("config/a.yaml", program_);
  ASSERT_TRUE(found.ok()) << found.error();
  EXPECT_EQ(*found, second / "group/repo/fem_cloth/config/a.yaml");
}

TEST_F(PackagePaths, APackageOfAnotherNameIsNotTaken) {
  const fs::path source = root_ / "checkout";
  makePackage(source, "fem_cloth_extras", "config/a.yaml");
  write(prefix_ / ".catkin", source.string());
  const auto found = findPackageFile("config/a.yaml", program_);
  ASSERT_FALSE(found.ok());
  EXPECT_NE(found.error().find("cannot find config/a.yaml"), std::string::npos) << found.error();
  EXPECT_NE(found.error().find((prefix_ / "share/fem_cloth/config/a.yaml").string()),
            std::string::npos)
      << found.error();
  EXPECT_NE(found.error().find(source.string()), std::string::npos) << found.error();
}

TEST_F(PackagePaths, NoMarkerIsNamedInTheError) {
  const auto found = findPackageFile("config", program_);
  ASSERT_FALSE(found.ok());
  EXPECT_NE(found.error().find((prefix_ / ".catkin").string() + ", the devel space's list"),
            std::string::npos)
      << found.error();
}

TEST(PackagePathsOfThisBuild, TheTestProgramFindsTheSourceTreesConfig) {
  // This program runs from the devel space (or the plain-CMake build folder laid out like one).
  const auto found = findPackageFile("config");
  ASSERT_TRUE(found.ok()) << found.error();
  EXPECT_TRUE(fs::equivalent(*found, fs::path(FEM_CLOTH_SOURCE_DIR) / "config")) << *found;
}

}  // namespace
