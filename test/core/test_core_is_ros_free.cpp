// The core, the scene reader and the renderer must stay usable without ROS. On Debian the ROS headers live in
// /usr/include, on the default include path, so the build alone would not notice a ROS include:
// this test reads every core source and header and fails on any.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

namespace fs = std::filesystem;

TEST(CoreIsRosFree, NoRosIncludes) {
  const fs::path root = FEM_CLOTH_SOURCE_DIR;
  const std::vector<fs::path> folders = {root / "include/fem_cloth/core", root / "src/core",
                                         root / "include/fem_cloth/io", root / "src/io",
                                         root / "include/fem_cloth/render", root / "src/render"};
  // ROS client libraries, message packages and our generated messages.
  const std::regex ros(
      R"(#\s*include\s*[<"](ros/|tf2|rosbag|roscpp|std_msgs|std_srvs|geometry_msgs|shape_msgs|)"
      R"(visualization_msgs|diagnostic_msgs|rosgraph_msgs|sensor_msgs|xmlrpcpp|fem_cloth/ros/|)"
      R"(fem_cloth/[A-Z]))");
  int files = 0;
  for (const fs::path& folder : folders) {
    ASSERT_TRUE(fs::is_directory(folder)) << folder;
    for (const auto& entry : fs::recursive_directory_iterator(folder)) {
      if (!entry.is_regular_file()) continue;
      const std::string ext = entry.path().extension().string();
      if (ext != ".h" && ext != ".cpp") continue;
      ++files;
      std::ifstream in(entry.path());
      std::string line;
      int number = 0;
      while (std::getline(in, line)) {
        ++number;
        EXPECT_FALSE(std::regex_search(line, ros))
            << entry.path().string() << ":" << number << ": " << line;
      }
    }
  }
  // The folders really hold the core (a wrong path must not make the test pass vacuously).
  EXPECT_GT(files, 30);
}

TEST(CoreIsRosFree, TheCheckRecognisesRosIncludes) {
  const std::regex ros(R"(#\s*include\s*[<"](ros/|tf2|fem_cloth/[A-Z]))");
  EXPECT_TRUE(std::regex_search("#include <ros/ros.h>", ros));
  EXPECT_TRUE(std::regex_search("#include \"fem_cloth/ClothState.h\"", ros));
  EXPECT_FALSE(std::regex_search("#include \"fem_cloth/core/mesh.h\"", ros));
}
