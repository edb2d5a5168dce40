// Runs a program from a test, as a user would from a shell, and captures what it printed.
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "temp_dir.h"

namespace fem_cloth::test {

struct ProgramResult {
  int status = -1;  ///< exit status (-1: did not exit normally)
  std::string out, err;
};

inline std::string readTextFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Runs `program` with `args` (each single-quoted for the shell); stdout and stderr go through
/// files in `scratch`.
inline ProgramResult runProgram(const std::string& program, const std::vector<std::string>& args,
                                const TempDir& scratch) {
  std::string command = "'" + program + "'";
  for (const std::string& a : args) command += " '" + a + "'";
  const std::string out = scratch.path("stdout"), err = scratch.path("stderr");
  const int raw = std::system((command + " >'" + out + "' 2>'" + err + "'").c_str());
  ProgramResult r;
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  r.out = readTextFile(out);
  r.err = readTextFile(err);
  return r;
}

/// runProgram with a time bound: the program is killed (SIGKILL) after `seconds`. A program
/// that is killed, by the bound or by a signal of its own (an abort), has status 128 + the
/// signal's number (timeout(1)'s convention), never 0, 2 or 3.
inline ProgramResult runProgramWithin(int seconds, const std::string& program,
                                      const std::vector<std::string>& args, const TempDir& scratch) {
  std::vector<std::string> all = {"-s", "KILL", std::to_string(seconds), program};
  all.insert(all.end(), args.begin(), args.end());
  return runProgram("/usr/bin/timeout", all, scratch);
}

}  // namespace fem_cloth::test
