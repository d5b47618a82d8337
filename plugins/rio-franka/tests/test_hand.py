"""The Franka Hand node on the fake franky gripper: grasp with a force when closing, move otherwise,
`object_detected` from is_grasped, a dropped link held and reconnected."""

from __future__ import annotations

from rio_franka import fake
from rio_franka.hand import FrankaHand

from rio import clock
from rio.conformance.driving import Loop
from rio.testing import lifecycle


def test_closing_on_an_object_grasps_it_and_opening_releases(fake_ip):
    ctl = fake.controller(fake_ip)
    ctl.object_width = 0.03
    with lifecycle(FrankaHand(ip=fake_ip, backend="fake", speed=0.2)) as hand:
        assert abs(hand.cycle()["width"] - 0.08) < 1e-6
        hand.command("width", [0.0], clock.now() + 0.1)
        s = Loop(hand).run(until=lambda s: s["object_detected"], timeout=5)
        assert s["object_detected"] and abs(s["width"] - 0.03) < 1e-3
        assert ctl.grasping is not None  # a grasp, with the force
        hand.command("width", [0.08], clock.now() + 0.1)
        s = Loop(hand).run(until=lambda s: s["width"] > 0.079, timeout=5)
        assert not s["object_detected"] and ctl.grasping is None  # a move


def test_fingers_that_reach_the_goal_with_nothing_between_them_detect_no_object(fake_ip):
    """libfranka calls a grasp whose fingers reach its goal grasped (the goal is within the epsilons):
    the kind's step-limited goals are such grasps, and none of them holds an object."""
    ctl = fake.controller(fake_ip)
    ctl.object_width = None
    with lifecycle(FrankaHand(ip=fake_ip, backend="fake", speed=0.2)) as hand:
        hand.command("width", [0.05], clock.now() + 0.1)
        s = Loop(hand).run(until=lambda s: abs(s["width"] - 0.05) < 1e-4, timeout=5)
        assert abs(s["width"] - 0.05) < 1e-4
        assert ctl.grasping is not None and hand.conn.handle.is_grasped  # what libfranka says
        assert not Loop(hand).run(cycles=3)["object_detected"]


def test_a_dropped_gripper_link_reconnects(fake_ip):
    ctl = fake.controller(fake_ip)
    with lifecycle(FrankaHand(ip=fake_ip, backend="fake")) as hand:
        hand.cycle()
        ctl.inject("link_lost")
        Loop(hand).run(until=lambda s: not s["connected"], timeout=3)
        ctl.restore_link()
        s = Loop(hand).run(until=lambda s: s["connected"] and s["enabled"], timeout=5)
        assert s["connected"] and s["enabled"]
