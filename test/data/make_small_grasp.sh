#!/usr/bin/env bash
# Re-records test/data/small_grasp.bag, the fixture of the live-replay integration test: the
# small test cloth (test/rostest/config/small_cloth.yaml) grasped and lifted by
# fem_cloth_grasp_demo, with the topics a replay needs (scene, mesh, applied commands, states,
# tf), lz4-compressed. Needs a built package (scripts/test builds it).
#
# With --paused it records test/data/paused_grasp.bag instead (test/data/make_paused_grasp.sh):
# the same grasp, paused for 2 s of ROS time in the middle of the lift.
set -euo pipefail
paused=false
[ "${1:-}" = --paused ] && paused=true
source "$(dirname "${BASH_SOURCE[0]}")/../../scripts/lib/common.sh"
fem_cloth_env
port="$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')"
export ROS_MASTER_URI="http://127.0.0.1:$port"
out="$FEM_CLOTH_ROOT/test/data/small_grasp.bag"
$paused && out="$FEM_CLOTH_ROOT/test/data/paused_grasp.bag"
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
if ! $paused; then
  rosrun fem_cloth fem_cloth_grasp_demo _hold:=1.0
else
  # The demo resumes the node and lifts from 0.05 s to 2.05 s of simulation time: the pause comes
  # at 0.8 s, while the gripper moves, and lasts 2 s of ROS time.
  rosrun fem_cloth fem_cloth_grasp_demo _hold:=1.0 & demo=$!
  /usr/bin/python3 - <<'PY'
import rospy, std_srvs.srv
from fem_cloth.msg import ClothState
rospy.init_node("pause_in_the_lift")
while not rospy.is_shutdown():
    if rospy.wait_for_message("/fem_cloth_node/state", ClothState).step >= 80:
        break
pause = rospy.ServiceProxy("/fem_cloth_node/pause", std_srvs.srv.Trigger)
resume = rospy.ServiceProxy("/fem_cloth_node/resume", std_srvs.srv.Trigger)
print("pause:", pause().message)
rospy.sleep(2.0)
print("resume:", resume().message)
PY
  wait "$demo"
fi
kill -INT "$record"; wait "$record" || true
kill -INT "$launch"; wait "$launch" || true
rosbag info "$out"
