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
