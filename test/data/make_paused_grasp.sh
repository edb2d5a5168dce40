#!/usr/bin/env bash
# Re-records test/data/paused_grasp.bag, the fixture of test/rostest/paused_replay.test:
# make_small_grasp.sh's grasp and lift of the small test cloth, paused for 2 s of ROS time in the
# middle of the lift (~pause, then ~resume), so that the recorded states' stamps start a second
# segment of the node's timeline (docs/node.md, Time). Needs a built package.
exec "$(dirname "${BASH_SOURCE[0]}")/make_small_grasp.sh" --paused
