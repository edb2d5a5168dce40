#include "fem_cloth/core/package_paths.h"

#include <fstream>
#include <regex>
#include <sstream>
#include <system_error>
#include <vector>

namespace fem_cloth {
namespace {

namespace fs = std::filesystem;

constexpr const char* kPackage = "fem_cloth";
// How deep below a workspace's source folder a package may sit (src/<group>/<repo>/<package>).
constexpr int kMaxDepth = 4;

bool namesThisPackage(const fs::path& manifest) {
  std::ifstream in(manifest);
  if (!in) return false;
  std::stringstream text;
  text << in.rdbuf();
  static const std::regex name(R"(<name>\s*fem_cloth\s*</name>)");
  return std::regex_search(text.str(), name);
}

/// The package root below a devel space's source folder: the folder itself (standalone build) or
/// the folder of the package.xml naming fem_cloth below it (workspace). Packages do not nest,
/// so the search does not descend into another package; like catkin it skips CATKIN_IGNORE and
/// hidden folders.
fs::path packageRootBelow(const fs::path& source) {
  std::error_code ec;
  if (namesThisPackage(source / "package.xml")) return source;
  if (!fs::is_directory(source, ec) || fs::exists(source / "package.xml", ec)) return {};
  fs::recursive_directory_iterator it(source, fs::directory_options::skip_permission_denied, ec);
  for (; !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (!it->is_directory(ec)) continue;
    const fs::path& dir = it->path();
    if (dir.filename().string().rfind('.', 0) == 0 || fs::exists(dir / "CATKIN_IGNORE", ec)) {
      it.disable_recursion_pending();
      continue;
    }
    if (namesThisPackage(dir / "package.xml")) return dir;
    if (it.depth() + 1 >= kMaxDepth || fs::exists(dir / "package.xml", ec)) {
      it.disable_recursion_pending();
    }
  }
  return {};
}

/// The source folders a devel space's .catkin marker lists (none for an install space).
std::vector<fs::path> sourceFolders(const fs::path& prefix) {
  std::ifstream in(prefix / ".catkin");
  std::vector<fs::path> folders;
  std::string item;
  while (std::getline(in, item, ';')) {
    while (!item.empty() && (item.back() == '\n' || item.back() == '\r')) item.pop_back();
    if (!item.empty()) folders.emplace_back(item);
  }
  return folders;
}

}  // namespace

Expected<fs::path> findPackageFile(const std::string& relative, const fs::path& program) {
  // <prefix>/lib/fem_cloth/<program>
  const fs::path prefix = program.parent_path().parent_path().parent_path();
  std::error_code ec;
  std::vector<fs::path> looked;
  const fs::path installed = prefix / "share" / kPackage / relative;
  if (fs::exists(installed, ec)) return installed;
  looked.push_back(installed);
  for (const fs::path& source : sourceFolders(prefix)) {
    const fs::path root = packageRootBelow(source);
    if (root.empty()) {
      looked.push_back(source / "**/package.xml naming fem_cloth");
      continue;
    }
    if (fs::exists(root / relative, ec)) return root / relative;
    looked.push_back(root / relative);
  }
  std::string message = "cannot find " + relative + " of the " + kPackage + " package for " +
                        program.string() + "; looked at";
  for (const fs::path& p : looked) message += " " + p.string();
  if (!fs::exists(prefix / ".catkin", ec)) {
    message += " (" + prefix.string() + "/.catkin, the devel space's list of source folders, is missing)";
  }
  return Error{message};
}

Expected<fs::path> findPackageFile(const std::string& relative) {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) return Error{"cannot find " + relative + ": /proc/self/exe is unreadable (" + ec.message() + ")"};
  return findPackageFile(relative, self);
}

}  // namespace fem_cloth
