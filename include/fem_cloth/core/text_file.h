// Reading a text input (a scene, an OBJ mesh) with a bound: a path that names a directory, a
// device or a pipe (/dev/zero never ends), a file larger than the bound or a binary file is one
// clear error naming the file, not an exception, a hang or an exhausted memory.
#pragma once

#include <cstdint>
#include <string>

#include "fem_cloth/core/expected.h"

namespace fem_cloth {

/// The whole content of the regular text file at `path`, at most `maxBytes` bytes. `what` names
/// the kind of file in messages ("scene file", "OBJ file"). Errors: no such file, not a regular
/// file, larger than maxBytes, holding a NUL byte (binary), unreadable.
Expected<std::string> readTextFile(const std::string& path, std::uintmax_t maxBytes,
                                   const std::string& what);

}  // namespace fem_cloth
