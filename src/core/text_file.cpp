#include "fem_cloth/core/text_file.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace fem_cloth {

Expected<std::string> readTextFile(const std::string& path, std::uintmax_t maxBytes,
                                   const std::string& what) {
  namespace fs = std::filesystem;
  const std::string name = what + " '" + path + "'";
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec || !fs::exists(status)) return Error{"cannot open " + name + ": no such file"};
  if (fs::is_directory(status)) return Error{"cannot read " + name + ": it is a directory"};
  // Devices and pipes have no size and may never end (/dev/zero, /dev/urandom, a FIFO).
  if (!fs::is_regular_file(status)) {
    return Error{"cannot read " + name + ": not a regular file (a device, a pipe or a socket)"};
  }
  const std::uintmax_t size = fs::file_size(path, ec);
  if (!ec && size > maxBytes) {
    return Error{"cannot read " + name + ": " + std::to_string(size) + " bytes, more than the " +
                 std::to_string(maxBytes) + " bytes allowed"};
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error{"cannot open " + name + ": " + std::strerror(errno)};
  // Read at most one byte more than allowed, so a file that grows while it is read stays bounded.
  std::string text(static_cast<std::size_t>(std::min<std::uintmax_t>(size, maxBytes) + 1), '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  if (in.bad()) return Error{"cannot read " + name + ": read error"};
  text.resize(static_cast<std::size_t>(in.gcount()));
  if (text.size() > maxBytes) {
    return Error{"cannot read " + name + ": more than the " + std::to_string(maxBytes) +
                 " bytes allowed"};
  }
  if (const auto nul = text.find('\0'); nul != std::string::npos) {
    return Error{"cannot read " + name + ": not a text file (a NUL byte at offset " +
                 std::to_string(nul) + ")"};
  }
  return text;
}

}  // namespace fem_cloth
