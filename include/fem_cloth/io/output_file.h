// Outputs written so that no data is lost: an output is never one of the run's inputs (a replay
// writing over the recording it reads), and it appears under its final name only once it is
// complete (a run that is killed or fails leaves a temporary file, never a truncated output that
// looks whole).
#pragma once

#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "fem_cloth/core/expected.h"

namespace fem_cloth {

/// An error when `output` names the same file as one of `inputs` (same device and inode, so a
/// symbolic or hard link to an input counts); inputs that are empty or do not exist are skipped.
Status checkNotAnInput(const std::string& output, const std::vector<std::string>& inputs);

/// An error when `path` cannot be written as an output file, found before the work that makes
/// it: its folder does not exist (or is not a folder, or cannot be written), or it names
/// something other than a regular file (a folder, a device such as /dev/full).
Status checkOutputPath(const std::string& path);

/// Whether two output paths name the same file, whether or not it exists yet ("x.csv" and
/// "./x.csv"; a link to the other).
bool sameOutputPath(const std::string& a, const std::string& b);

/// Creates an empty file of a new, unique name next to `path` (in its folder, so that renaming
/// it to `path` is atomic): `path.partial-XXXXXX`.
Expected<std::string> createTemporaryNextTo(const std::string& path);

/// Renames `temporary` to `path`, replacing what was there.
Status moveIntoPlace(const std::string& temporary, const std::string& path);

/// A text output written to a temporary file next to its path and renamed into place by
/// commit(); destroyed without commit() (an error, an exception), it removes the temporary.
class OutputFile {
 public:
  static Expected<std::unique_ptr<OutputFile>> open(const std::string& path);
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  std::ostream& stream() { return stream_; }
  const std::string& path() const { return path_; }
  /// Flushes, checks that every write succeeded (a full disk), closes and renames into place.
  Status commit();

 private:
  OutputFile(std::string path, std::string temporary);
  std::string path_, temporary_;
  std::ofstream stream_;
  bool committed_ = false;
};

}  // namespace fem_cloth
