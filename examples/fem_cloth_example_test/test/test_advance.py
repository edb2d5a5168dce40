#!/usr/bin/env python3
"""A downstream test of fem_cloth_node (advance.test): the node, paused on config/small_cloth.yaml,
is advanced step by step with ~advance, and the test checks what a lab's test would rely on:

  - ~advance answers with the step and time it stopped at (steps x dt);
  - the state on ~state (latched: it comes to a subscriber after the fact) is that step's, and
    its state_hash is the FNV-1a hash of its positions' and velocities' bits, computed here;
  - ~reset and the same advance again give the same hash (the run is reproducible);
  - no energy was created: the cloth starts flat and at rest (every energy 0), so its energy
    kinetic + strain + bending + gravity, summed here, can have come only from the work done on
    it (external_work + pin_work + contact_work + air_work + live_work: every work term
    ClothEnergy carries); backward Euler only loses energy.
"""
import struct
import sys
import threading
import unittest

import rospy
import rostest
from fem_cloth.msg import ClothEnergy, ClothState
from fem_cloth.srv import Advance
from std_srvs.srv import Trigger

NODE = "/fem_cloth_node"
STEPS = 50


def fnv1a(values, h):
    """FNV-1a (64 bit) of the bytes of `values` as little-endian doubles, continuing from h."""
    for byte in struct.pack("<%dd" % len(values), *values):
        h = ((h ^ byte) * 1099511628211) % 2**64
    return h


def state_hash(msg):
    """ClothState.state_hash recomputed: positions x, y, z vertex by vertex, then velocities."""
    h = fnv1a([c for p in msg.positions for c in (p.x, p.y, p.z)], 14695981039346656037)
    h = fnv1a([c for v in msg.velocities for c in (v.x, v.y, v.z)], h)
    return "%016x" % h


class Advancing(unittest.TestCase):
    def setUp(self):
        self.lock = threading.Lock()
        self.energies = {}
        self.energy_sub = rospy.Subscriber(NODE + "/energy", ClothEnergy, self.on_energy, queue_size=100)
        rospy.wait_for_service(NODE + "/advance", timeout=60.0)
        self.advance = rospy.ServiceProxy(NODE + "/advance", Advance)
        self.reset = rospy.ServiceProxy(NODE + "/reset", Trigger)

    def on_energy(self, msg):
        with self.lock:
            self.energies[msg.step] = msg

    def latest_state(self):
        # A new subscriber: the latched state is the last one published.
        return rospy.wait_for_message(NODE + "/state", ClothState, timeout=30.0)

    def advance_checked(self):
        dt = float(rospy.get_param(NODE + "/integrator/dt"))
        reply = self.advance(steps=STEPS)
        self.assertTrue(reply.success, reply.message)
        self.assertEqual(reply.steps_taken, STEPS)
        self.assertEqual(reply.step, STEPS)
        self.assertAlmostEqual(reply.time, STEPS * dt, delta=1e-9)
        state = self.latest_state()
        self.assertEqual(state.step, STEPS)
        self.assertEqual(len(state.velocities), len(state.positions), "publish_velocities is on")
        self.assertEqual(state_hash(state), state.state_hash)
        self.assertEqual(reply.state_hash, state.state_hash)
        return state

    def test_advance_hash_and_energy(self):
        start = self.latest_state()
        self.assertEqual(start.step, 0)
        self.assertEqual(state_hash(start), start.state_hash)
        first = self.advance_checked()
        self.assertNotEqual(first.state_hash, start.state_hash, "the cloth moved")

        # Reproducible: the same steps from the same start give the same bits.
        self.assertTrue(self.reset().success)
        second = self.advance_checked()
        self.assertEqual(second.state_hash, first.state_hash)

        # The energy of the last step (published with its state to a subscriber).
        deadline = rospy.Time.now() + rospy.Duration(10.0)
        while rospy.Time.now() < deadline:
            with self.lock:
                if STEPS in self.energies:
                    break
            rospy.sleep(0.1)
        with self.lock:
            self.assertIn(STEPS, self.energies, "no ~energy for step %d" % STEPS)
            e = self.energies[STEPS]
        total = e.kinetic + e.strain + e.bending + e.gravity
        self.assertAlmostEqual(total, e.total, delta=1e-12 * max(1.0, abs(e.gravity)))
        self.assertLess(e.gravity, 0.0, "the cloth swung down")
        created = total - e.external_work - e.pin_work - e.contact_work - e.air_work - e.live_work
        self.assertLessEqual(created, 1e-9 * abs(e.gravity), "energy created: %g J" % created)


if __name__ == "__main__":
    rospy.init_node("test_advance", anonymous=True)
    rostest.rosrun("fem_cloth_example_test", "advance", Advancing, sys.argv)
