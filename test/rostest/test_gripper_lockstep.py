#!/usr/bin/env python3
"""Lock-step with a robot stack from a cold start (issue 32, part 3; gripper_lockstep.test).

launch/gripper_lockstep.launch: the node in time_mode fast on simulation time, started paused;
robot_state_publisher and fem_cloth_gripper_controller on the node's /clock. Nobody publishes
/clock by hand. After ~resume the gantry gripper pinches the cloth of config/gripper_pinch.yaml,
lifts it 20 cm and carries it 10 cm along +x (the controller's motion), and the cloth hangs from
the fingers, held by friction alone (the scene pins nothing). Checked against what the scene's
numbers and the commanded motion imply, computed here (as test/core/test_pinch_lift.cpp does for
the scripted fingers of pinch_lift.yaml):
  - the run reaches the scene's duration, and no step was taken with a stand-in transform (the
    node never gave up waiting for the fingers' frames at a step's time: that is lock-step);
  - the vertices between the pads when the lift starts moved with the fingers: along the pads by
    less than the creep of IPC's smoothed friction, friction_velocity x the time held, across
    them by less than the gap between the pads;
  - hanging still (the last 0.5 s), the fingers' wrenches sum to the cloth's weight, density x
    thickness x width x height x g, within 3 % (the last swings and mass damping's drag), and the
    table carries nothing: the cloth was lifted off it.
"""
import math
import sys
import threading
import unittest

import rospy
import rostest
from fem_cloth.msg import ClothState
from geometry_msgs.msg import WrenchStamped
from rosgraph_msgs.msg import Log
from std_srvs.srv import Trigger

NODE = "/fem_cloth_node"
# The commanded motion (scripts/fem_cloth_gripper_controller): the pinch is closed from 0.3 s,
# the lift starts at 0.5 s, and from 2.1 s the fingers rest (0.1, 0, 0.2) m from where they were
# when the lift started.
LIFT_START = 0.5
FINGER_MOVE = (0.1, 0.0, 0.2)
# The fingers' boxes at the lift's start (urdf/gantry_gripper.urdf with the pinch closed by
# 18 mm; the boxes' size from the scene): centre x, half width along x, the lower pad's top and
# the upper pad's bottom (m).
FINGER_X, FINGER_HALF_X = 0.555, 0.045
LOWER_TOP, UPPER_BOTTOM = 0.735 + 0.015, 0.785 - 0.018 - 0.015
HOLD = 0.5  # s at the end over which the wrenches are averaged
TIMEOUT = 900.0  # s of wall time for the whole run (a loaded machine)


class GripperLockstep(unittest.TestCase):
    def setUp(self):
        self.lock = threading.Lock()
        self.states = {}  # step -> (stamp in s, positions)
        self.wrenches = {"table": {}, "lower_finger": {}, "upper_finger": {}}  # stamp ns -> force
        self.stand_ins = []
        self.subs = [rospy.Subscriber(NODE + "/state", ClothState, self.on_state, queue_size=1000)]
        for name in self.wrenches:
            self.subs.append(rospy.Subscriber(NODE + "/obstacles/%s/wrench" % name, WrenchStamped,
                                              self.on_wrench, callback_args=name, queue_size=1000))
        self.subs.append(rospy.Subscriber("/rosout", Log, self.on_log, queue_size=1000))

    def on_state(self, msg):
        with self.lock:
            self.states[msg.step] = (msg.header.stamp.to_sec(), [(p.x, p.y, p.z) for p in msg.positions])

    def on_wrench(self, msg, name):
        with self.lock:
            f = msg.wrench.force
            self.wrenches[name][msg.header.stamp.to_nsec()] = (f.x, f.y, f.z)

    def on_log(self, msg):
        # TransformWait's give-up (cloth_node.cpp, transformsReady): a step with another time's
        # transforms, which lock-step must never need.
        if "stepping without the transforms" in msg.msg:
            with self.lock:
                self.stand_ins.append(msg.msg)

    def param(self, key):
        return rospy.get_param(NODE + "/" + key)

    def test_pinch_lift_carry_by_friction(self):
        start = float(self.param("start_time"))
        duration = float(self.param("duration"))
        dt = float(self.param("integrator/dt"))
        mesh = self.param("mesh")
        rows, cols = int(mesh["rows"]), int(mesh["cols"])
        width, height, origin = float(mesh["width"]), float(mesh["height"]), mesh["origin"]
        gravity = self.param("gravity")
        weight = (float(self.param("material/density")) * float(self.param("material/thickness")) * width * height *
                  math.sqrt(sum(g * g for g in gravity)))
        obstacles = self.param("obstacles")
        self.assertFalse(rospy.has_param(NODE + "/pins"), "the cloth must be held by friction alone")
        self.assertEqual(sorted(o["name"] for o in obstacles), ["lower_finger", "table", "upper_finger"])
        creep_bound = float(self.param("contact/friction_velocity")) * (duration - LIFT_START)
        lift_step = int(round(LIFT_START / dt))
        last_step = int(round(duration / dt))

        rospy.wait_for_service(NODE + "/resume", timeout=60.0)
        resume = rospy.ServiceProxy(NODE + "/resume", Trigger)
        self.assertTrue(resume().success)

        waited = 0.0  # s of wall time (simulation time is the node's)
        while not rospy.is_shutdown() and waited < TIMEOUT:
            with self.lock:
                if last_step in self.states:
                    break
            rospy.rostime.wallsleep(0.5)
            waited += 0.5
        pause = rospy.ServiceProxy(NODE + "/pause", Trigger)
        pause()
        rospy.rostime.wallsleep(1.0)  # the wrenches of the last states
        with self.lock:
            states = dict(self.states)
            wrenches = {k: dict(v) for k, v in self.wrenches.items()}
            stand_ins = list(self.stand_ins)
        self.assertIn(last_step, states, "the run did not reach step %d (t = %g s) in %g s of wall time; last "
                      "state: step %s" % (last_step, duration, TIMEOUT, max(states) if states else None))
        self.assertEqual(stand_ins, [], "a step was taken without the fingers' transforms at its time")
        # Every state is stamped start_time + its simulation time (one timeline in fast mode).
        for step in (lift_step, last_step):
            self.assertIn(step, states)
            self.assertAlmostEqual(states[step][0], start + step * dt, delta=1e-6)

        # The pinched vertices: the grid columns between the pads' inner and outer edges, every
        # row; between the pads at the lift's start.
        x0 = float(origin[0])
        columns = [c for c in range(cols) if abs(x0 + c * width / (cols - 1) - FINGER_X) < FINGER_HALF_X]
        self.assertEqual(len(columns), 3)
        pinched = [r * cols + c for r in range(rows) for c in columns]
        at_lift = states[lift_step][1]
        at_end = states[last_step][1]
        for i in pinched:
            self.assertTrue(LOWER_TOP < at_lift[i][2] < UPPER_BOTTOM,
                            "vertex %d is not between the pads at the lift's start: z = %.6f" % (i, at_lift[i][2]))
        slip = [tuple(at_end[i][k] - at_lift[i][k] - FINGER_MOVE[k] for k in range(3)) for i in pinched]
        worst_along = max(math.hypot(s[0], s[1]) for s in slip)
        worst_across = max(abs(s[2]) for s in slip)
        gap = UPPER_BOTTOM - LOWER_TOP
        print("%d vertices pinched; they slipped %.3f mm along the pads (bound %.3f mm), %.3f mm across "
              "(gap %.1f mm)" % (len(pinched), worst_along * 1e3, creep_bound * 1e3, worst_across * 1e3, gap * 1e3))
        self.assertLess(worst_along, creep_bound)
        self.assertLess(worst_across, gap)

        # Hanging still: the fingers carry the weight (the cloth pulls them down), the table nothing.
        # The node runs on until the test pauses it: the states of [duration - HOLD, duration].
        hold_from, hold_to = int(round((start + duration - HOLD) * 1e9)), int(round((start + duration) * 1e9))
        held = [0.0, 0.0, 0.0]
        samples = 0
        table_load = 0.0
        for stamp, f in wrenches["lower_finger"].items():
            if not hold_from <= stamp <= hold_to or stamp not in wrenches["upper_finger"] or stamp not in wrenches["table"]:
                continue
            g = wrenches["upper_finger"][stamp]
            held = [held[k] + f[k] + g[k] for k in range(3)]
            table_load = max(table_load, math.sqrt(sum(t * t for t in wrenches["table"][stamp])))
            samples += 1
        self.assertGreater(samples, 10, "too few finger wrenches in the last %g s" % HOLD)
        held = [h / samples for h in held]
        print("fingers carry %.6f N (mean of %d), the cloth weighs %.6f N; table load %g N"
              % (-held[2], samples, weight, table_load))
        self.assertLess(table_load, 1e-9)
        self.assertAlmostEqual(-held[2], weight, delta=0.03 * weight)
        self.assertLess(math.hypot(held[0], held[1]), 0.03 * weight)


if __name__ == "__main__":
    rospy.init_node("test_gripper_lockstep", anonymous=True)
    rostest.rosrun("fem_cloth", "gripper_lockstep", GripperLockstep, sys.argv)
