#include "fem_cloth/io/output_file.h"

#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

namespace fem_cloth {

Status checkNotAnInput(const std::string& output, const std::vector<std::string>& inputs) {
  for (const std::string& input : inputs) {
    if (input.empty()) continue;
    std::error_code ec;
    // equivalent() compares device and inode; it fails (ec) when either does not exist.
    if (std::filesystem::equivalent(output, input, ec) && !ec) {
      return Error{"the output '" + output + "' is the input '" + input +
                   "': writing it would destroy the input; choose another output"};
    }
  }
  return Status::success();
}

Status checkOutputPath(const std::string& path) {
  namespace fs = std::filesystem;
  if (path.empty()) return Error{"an empty file name"};
  if (fs::path(path).filename().empty()) return Error{"'" + path + "' names a folder, not a file"};
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (fs::is_directory(status)) return Error{"'" + path + "' is a folder, not a file"};
  if (fs::exists(status) && !fs::is_regular_file(status)) {
    return Error{"'" + path + "' is not a regular file (a device or pipe): write to a file"};
  }
  const fs::path parent = fs::path(path).parent_path();
  const fs::path folder = parent.empty() ? fs::path(".") : parent;
  if (!fs::is_directory(folder, ec)) {
    return Error{"cannot write '" + path + "': there is no folder '" + folder.string() + "'"};
  }
  if (::access(folder.c_str(), W_OK) != 0) {
    return Error{"cannot write '" + path + "': the folder '" + folder.string() + "' is not writable"};
  }
  return Status::success();
}

bool sameOutputPath(const std::string& a, const std::string& b) {
  std::error_code same, ea, eb;  // one each: a failed call's code is not cleared by the next
  if (std::filesystem::equivalent(a, b, same) && !same) return true;
  // Absolute first: weakly_canonical leaves a relative path to a file not yet there relative.
  const std::filesystem::path ca = std::filesystem::weakly_canonical(std::filesystem::absolute(a), ea);
  const std::filesystem::path cb = std::filesystem::weakly_canonical(std::filesystem::absolute(b), eb);
  if (ea || eb) return a == b;
  return ca == cb;
}

Expected<std::string> createTemporaryNextTo(const std::string& path) {
  std::string name = path + ".partial-XXXXXX";
  const int fd = ::mkstemp(name.data());
  if (fd < 0) return Error{"cannot write '" + path + "': " + std::strerror(errno)};
  // mkstemp makes the file private (0600); the output gets the permissions of any new file.
  const mode_t mask = ::umask(0);
  ::umask(mask);
  ::fchmod(fd, 0666 & ~mask);
  ::close(fd);
  return name;
}

Status moveIntoPlace(const std::string& temporary, const std::string& path) {
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec) {
    std::filesystem::remove(temporary, ec);
    return Error{"cannot move the finished output into place as '" + path + "': " + ec.message()};
  }
  return Status::success();
}

OutputFile::OutputFile(std::string path, std::string temporary)
    : path_(std::move(path)), temporary_(std::move(temporary)), stream_(temporary_) {}

Expected<std::unique_ptr<OutputFile>> OutputFile::open(const std::string& path) {
  Expected<std::string> temporary = createTemporaryNextTo(path);
  if (!temporary) return Error{temporary.error()};
  std::unique_ptr<OutputFile> file(new OutputFile(path, *temporary));
  if (!file->stream_) return Error{"cannot write '" + path + "'"};
  return file;
}

OutputFile::~OutputFile() {
  if (committed_) return;
  stream_.close();
  std::error_code ignored;
  std::filesystem::remove(temporary_, ignored);
}

Status OutputFile::commit() {
  stream_.flush();
  const bool written = static_cast<bool>(stream_);
  stream_.close();
  if (!written || stream_.fail()) return Error{"cannot write '" + path_ + "' (disk full?)"};
  if (Status s = moveIntoPlace(temporary_, path_); !s) return s;
  committed_ = true;
  return Status::success();
}

}  // namespace fem_cloth
