# Shared set-up for fem_cloth's scripts. Source it; it defines:
#   FEM_CLOTH_ROOT   the package (repository) root
#   FEM_CLOTH_BUILD  the standalone catkin build folder (default: $FEM_CLOTH_ROOT/catkin_build)
#   fem_cloth_build  configure and build (devel space in $FEM_CLOTH_BUILD/devel)
#   fem_cloth_env    source the devel space's setup.bash
#
# ROS 1's Python tools (catkin, rostest, roslaunch) live in Debian's /usr/bin/python3. A pyenv or
# virtualenv python3 earlier on PATH lacks them, so /usr/bin goes first and catkin is told
# explicitly which interpreter to use.

FEM_CLOTH_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
# Not "build": rosrun ignores executables below <package>/build/.
FEM_CLOTH_BUILD="${FEM_CLOTH_BUILD:-$FEM_CLOTH_ROOT/catkin_build}"
export PATH="/usr/bin:/bin:/usr/sbin:/sbin:$PATH"
unset PYTHONHOME PYTHONPATH VIRTUAL_ENV
export PYENV_VERSION=system
export ROS_PYTHON_VERSION=3
# OpenMP threads sleep while they wait (see include/fem_cloth/core/threads.h); the programs set
# this themselves, test programs inherit it from here.
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
# Rebuilds of unchanged sources (a second clone, a worktree, a clean build) come from ccache when
# it is installed; CMake reads this when it first configures a build folder.
if [ -z "${CMAKE_CXX_COMPILER_LAUNCHER:-}" ] && command -v ccache >/dev/null 2>&1; then
  export CMAKE_CXX_COMPILER_LAUNCHER=ccache
fi

fem_cloth_jobs() {
  local n
  n="$(nproc 2>/dev/null || echo 2)"
  echo "${FEM_CLOTH_JOBS:-$n}"
}

fem_cloth_build() {
  mkdir -p "$FEM_CLOTH_BUILD"
  if [ ! -f "$FEM_CLOTH_BUILD/Makefile" ]; then
    echo "== configure ($FEM_CLOTH_BUILD)"
    cmake -S "$FEM_CLOTH_ROOT" -B "$FEM_CLOTH_BUILD" \
      -DCMAKE_BUILD_TYPE=Release \
      -DPYTHON_EXECUTABLE=/usr/bin/python3 \
      -DCATKIN_ENABLE_TESTING=ON >"$FEM_CLOTH_BUILD/configure.log" 2>&1 || {
      tail -40 "$FEM_CLOTH_BUILD/configure.log"
      echo "configure failed: see $FEM_CLOTH_BUILD/configure.log" >&2
      return 1
    }
  fi
  local log="$FEM_CLOTH_BUILD/build.log"
  echo "== build ${*:-all} (make -j$(fem_cloth_jobs), log: $log)"
  # Re-runs cmake first when a CMakeLists.txt changed, so new targets are known.
  if ! { make -C "$FEM_CLOTH_BUILD" cmake_check_build_system &&
         make -C "$FEM_CLOTH_BUILD" -j"$(fem_cloth_jobs)" "$@"; } >"$log" 2>&1; then
    grep -E -A4 "error|Error|\*\*\*" "$log" | head -80
    echo "build failed: see $log" >&2
    return 1
  fi
  local warnings
  warnings="$(grep -c "warning:" "$log" || true)"
  if [ "$warnings" != "0" ]; then
    echo "== build: $warnings compiler warnings (see $log)"
  fi
}

fem_cloth_env() {
  # setup.bash is not written for 'set -u'.
  set +u
  # shellcheck disable=SC1091
  source "$FEM_CLOTH_BUILD/devel/setup.bash"
  set -u
}
