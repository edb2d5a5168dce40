#!/usr/bin/env bash
# Re-records test/data/small_grasp.bag, the fixture of the live-replay integration test: the
# small test cloth (test/rostest/config/small_cloth.yaml) grasped and lifted by
# fem_cloth_grasp_demo, with the topics a replay needs (scene, mesh, applied commands, states,
# tf), lz4-compressed. Needs a built package (scripts/test builds it).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/../../scripts/lib/common.sh"
fem_cloth_env
port="$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')"
export ROS_MASTER_URI="http://127.0.0.1:$port"
out="$FEM_CLOTH_ROOT/test/data/small_grasp.bag"
roscore -p "$port" >/dev/null 2>&1 & core=$!
trap 'kill -INT $core 2>/dev/null; wait' EXIT
sleep 3
roslaunch fem_cloth cloth.launch scene:="$FEM_CLOTH_ROOT/test/rostest/config/small_cloth.yaml" \
  start_paused:=true output:=log >/dev/null 2>&1 & launch=$!
sleep 3
rosbag record --lz4 -O "$out" /fem_cloth_node/scene /fem_cloth_node/mesh \
  /fem_cloth_node/applied_pin /fem_cloth_node/applied_force /fem_cloth_node/state \
  /tf /tf_static >/dev/null 2>&1 & record=$!
sleep 2
rosrun fem_cloth fem_cloth_grasp_demo _hold:=1.0
kill -INT "$record"; wait "$record" || true
kill -INT "$launch"; wait "$launch" || true
rosbag info "$out"
