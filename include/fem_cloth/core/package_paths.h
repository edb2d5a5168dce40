// Where the package's data (config/, scripts, recorded bags) is at run time, without ROS tools
// (no rospack) and without a path of the source tree compiled into the program, so that an
// install space works with the source tree gone (issue 13, item 5).
//
// catkin puts the programs at <prefix>/lib/fem_cloth/ in both spaces (CATKIN_PACKAGE_BIN_
// DESTINATION) and marks each space's prefix with a file ".catkin": empty in an install space,
// listing the source folders (';'-separated) in a devel space. The plain-CMake core build
// (CMakeLists.txt) lays out its build folder the same way. So from the program's own location:
//   install space: <prefix>/share/fem_cloth/<relative>           (CATKIN_PACKAGE_SHARE_DESTINATION)
//   devel space:   <source>/<relative>, for the folder below a .catkin source folder whose
//                  package.xml names fem_cloth (the package root itself, or below a workspace's src/)
// This is the search catkin's own find_in_workspaces() does (catkin/find_in_workspaces.py).
#pragma once

#include <filesystem>
#include <string>

#include "fem_cloth/core/expected.h"

namespace fem_cloth {

/// The file or folder <relative> of the fem_cloth package for a program at <program>: the
/// install space's share folder first, then the devel space's source folders. The error names
/// every place looked at.
Expected<std::filesystem::path> findPackageFile(const std::string& relative,
                                                const std::filesystem::path& program);

/// The same for the running program (/proc/self/exe).
Expected<std::filesystem::path> findPackageFile(const std::string& relative);

}  // namespace fem_cloth
