"""The Inspire hands: their wire format against cyclonedds' serializer of the SDK's IDL (unitree_go
`MotorCmds_` / `MotorStates_`), the joint table and its normalisation; and the unmodified
`unitree.inspire` driver against the bridge's emulated Inspire service (`hands = "inspire"`, the plugin's
own body model) over real DDS on loopback: fingers reach a pose, a left and a right node share the one
command topic, targets beyond the range end at its limit, a stream that stops is stopped on the wire, lost
state is a named fault, no state at open a named error; and the hand conformance kit."""

from __future__ import annotations

import contextlib

import numpy as np
import pytest
from rio_unitree import inspire
from rio_unitree.dds import INSPIRE_CMD
from rio_unitree.inspire_wire import MotorCmds, MotorStates
from rio_unitree.testing import Tap

from rio import clock
from rio.conformance.drivers import HandConformance
from rio.conformance.driving import Loop, build_node, resolve_driver
from rio.errors import InvalidRequest
from rio.interfaces.damping import STALE_COMMANDS, STATE_LOST
from rio.testing import lifecycle

rng = np.random.default_rng(5)


def _f(*shape):
    return rng.normal(size=shape).astype(np.float32)


def _u(hi, *shape, dtype=np.uint32):
    return rng.integers(0, hi, shape, dtype=np.uint64).astype(dtype)


@pytest.mark.parametrize("n", [12, 3, 0])
def test_inspire_messages_are_the_sdks_bytes_both_ways(n):
    from unitree_sdk2py.idl.unitree_go.msg.dds_ import MotorCmds_, MotorStates_

    cmd = MotorCmds(_u(256, n, dtype=np.uint8), _f(n), _f(n), _f(n), _f(n), _f(n), _u(2**32, n, 3))
    data = cmd.encode()
    sdk = MotorCmds_.deserialize(data)
    assert sdk.serialize() == data  # byte for byte what cyclonedds writes for the SDK's type
    assert [x.mode for x in sdk.cmds] == cmd.mode.tolist() and np.allclose([x.q for x in sdk.cmds], cmd.q)
    assert MotorCmds.from_sample(sdk).encode() == data and MotorCmds.decode(data).encode() == data
    state = MotorStates(_u(256, n, dtype=np.uint8), *(_f(n) for _ in range(7)), _u(256, n, dtype=np.uint8),
                        _u(2**32, n), _u(2**32, n, 2))
    data = state.encode()
    sdk = MotorStates_.deserialize(data)
    assert sdk.serialize() == data
    assert [x.lost for x in sdk.states] == state.lost.tolist()
    assert MotorStates.from_sample(sdk).encode() == data and MotorStates.decode(data).encode() == data
    if n:
        with pytest.raises(ValueError, match="cannot hold"):
            MotorStates.decode(data[:-10])


def test_the_joint_table_and_the_normalisation():
    right, left = inspire.joints("right"), inspire.joints("left")
    assert [j.slot for j in right] == list(range(6)) and [j.slot for j in left] == list(range(6, 12))
    assert left[3].name == "L_index_proximal_joint" and right[4].name == "R_thumb_proximal_pitch_joint"
    lower, upper = np.array([j.lower for j in right]), np.array([j.upper for j in right])
    assert np.allclose(inspire.to_wire(lower, lower, upper), 1.0)  # open
    assert np.allclose(inspire.to_wire(upper, lower, upper), 0.0)  # closed
    q = rng.uniform(0, 1, 6)
    assert np.allclose(inspire.to_wire(inspire.from_wire(q, lower, upper), lower, upper), q)
    assert np.allclose(inspire.to_wire(upper + 1.0, lower, upper), 0.0)  # clipped
    with pytest.raises(ValueError, match="unknown Inspire left hand joints"):
        inspire.lookup("left", ["R_pinky_proximal_joint"])


def inspire_node(domain_id: int, side: str = "right", **fields):
    values = {"side": side, "interface": "lo", "domain_id": domain_id, "state_timeout_s": 1.0, **fields}
    return build_node(resolve_driver("unitree.inspire"), values, f"inspire_{side}")


@pytest.fixture
def inspire_bridge(make_bridge):
    return make_bridge(hands="inspire", hand_state_rate_hz=100.0)


def _pose(side: str) -> np.ndarray:
    """Fingers half closed (0.85 rad), the thumb bent 0.3 rad and turned 0.6 rad (each within its range)."""
    return np.array([0.85, 0.85, 0.85, 0.85, 0.3, 0.6])


def _wire_slots(side: str) -> slice:
    first = inspire.FIRST_SLOT[side]
    return slice(first, first + 6)


def test_fingers_reach_a_commanded_pose(inspire_bridge, domain_id):
    node = inspire_node(domain_id, "left")
    target = _pose("left")
    with Tap(domain_id, INSPIRE_CMD) as tap, lifecycle(node):
        loop = Loop(node)
        s = loop.run(cycles=3)
        assert np.allclose(s["joint_pos"], node.default_home(), atol=0.01)  # the emulated hands start open
        node.handle_request({"joint_pos": target, "t_cmd_target": clock.now() + 0.5})
        s = loop.run(until=lambda s: np.abs(s["joint_pos"] - target).max() < 0.02, timeout=5.0)
        assert np.abs(s["joint_pos"] - target).max() < 0.02, s["joint_pos"]
        lower, upper = np.array(node.hardware_limits())
        truth = inspire_bridge.inspire_pos()
        assert np.abs(inspire.from_wire(truth[6:], lower, upper) - target).max() < 0.03  # ground truth
        assert np.allclose(truth[:6], 1.0, atol=0.002)  # the right hand held open
        msg = tap.wait(lambda m: m.q[8] < 0.9)
        assert msg is not None and msg.mode.tolist() == [0] * 6 + [1] * 6  # authored: the left hand's motors
        assert not (msg.kp.any() or msg.kd.any() or msg.tau.any())
    assert inspire_bridge.counts.hand_cmd > 10 and inspire_bridge.counts.malformed == 0


def test_a_left_and_a_right_node_share_the_command_topic(inspire_bridge, domain_id):
    """Each node's messages carry the other hand's goals exactly as its node wrote them (not where that
    hand is), so neither undoes the other; both hands reach their targets and stay there."""
    left, right = inspire_node(domain_id, "left"), inspire_node(domain_id, "right")
    t_left, t_right = _pose("left"), np.array([1.5, 1.5, 0.2, 0.2, 0.45, 1.0])
    with Tap(domain_id, INSPIRE_CMD) as tap, lifecycle(left), lifecycle(right):
        loops = Loop(left), Loop(right)
        for lp in loops:
            lp.run(cycles=3)
        left.handle_request({"joint_pos": t_left, "t_cmd_target": clock.now() + 1.0})
        right.handle_request({"joint_pos": t_right, "t_cmd_target": clock.now() + 1.0})

        def both_there() -> bool:
            sl, sr = (lp.tick() for lp in loops)
            tap.poll()  # all along: the tap's reader keeps only the newest 256
            return bool(sl is not None and sr is not None and np.abs(sl["joint_pos"] - t_left).max() < 0.02
                        and np.abs(sr["joint_pos"] - t_right).max() < 0.02)

        t_end = clock.now() + 8.0
        while clock.now() < t_end and not both_there():
            pass
        for lp in loops:  # and they stay there
            lp.run(cycles=20)
            tap.poll()
        assert np.abs(loops[0].last["joint_pos"] - t_left).max() < 0.02, loops[0].last["joint_pos"]
        assert np.abs(loops[1].last["joint_pos"] - t_right).max() < 0.02, loops[1].last["joint_pos"]
        tap.poll()
    sent = tap.samples
    by_left = {m.q[6:].tobytes() for m in sent if m.mode[6:].all() and not m.mode[:6].any()}
    by_right = {m.q[:6].tobytes() for m in sent if m.mode[:6].all() and not m.mode[6:].any()}
    moving = [m for m in sent if m.mode[:6].all() and (m.q[6:] < 0.99).any()]  # right's, carrying the left's move
    assert len(moving) > 20 and all(m.q[6:].tobytes() in by_left for m in moving)
    moving = [m for m in sent if m.mode[6:].all() and (m.q[:6] < 0.99).any()]
    assert len(moving) > 20 and all(m.q[:6].tobytes() in by_right for m in moving)


def test_targets_beyond_the_range_end_at_its_limit(inspire_bridge, domain_id):
    node = inspire_node(domain_id, "right")
    with Tap(domain_id, INSPIRE_CMD) as tap, lifecycle(node):
        loop = Loop(node)
        loop.run(cycles=3)
        lower, upper = (np.array(x) for x in node.hardware_limits())
        node.handle_request({"joint_pos": upper + 0.5, "t_cmd_target": clock.now() + 0.3})
        s = loop.run(until=lambda s: np.abs(s["joint_pos"] - upper).max() < 0.01, timeout=5.0)
        assert np.abs(s["joint_pos"] - upper).max() < 0.01, s["joint_pos"]
        sent = tap.poll()
        assert sent and min(m.q[:6].min() for m in sent) >= 0.0  # never past fully closed on the wire
        assert np.allclose(inspire_bridge.inspire_pos()[:6], 0.0, atol=0.01)  # ground truth: closed


def test_a_stream_that_stops_stops_the_hand_where_it_is(inspire_bridge, domain_id):
    node = inspire_node(domain_id, "right", watchdog_s=0.3)
    with Tap(domain_id, INSPIRE_CMD) as tap, lifecycle(node):
        loop = Loop(node)
        loop.run(cycles=3)
        target = np.array([1.7, 1.7, 1.7, 1.7, 0.5, 1.3])  # closed ... due in 20 s, then the stream stops
        for _ in range(5):
            node.handle_request({"joint_pos": target, "t_cmd_target": clock.now() + 20.0})
            loop.tick()
        s = loop.run(until=lambda s: s["fault_code"] != 0, timeout=3.0)
        assert s["fault_code"] == STALE_COMMANDS and not s["enabled"]
        loop.run(cycles=10)
        held = loop.last["joint_pos"]
        assert np.abs(held - target).max() > 1.0  # stopped, far from the target
        tap.poll()
        loop.run(cycles=10)
        later = loop.last["joint_pos"]
        assert np.abs(later - held).max() < 0.01  # and stays there
        stops = tap.poll()
        assert stops and all(m.mode[:6].all() for m in stops)
        lower, upper = (np.array(x) for x in node.hardware_limits())
        assert np.abs(inspire.from_wire(stops[-1].q[:6], lower, upper) - later).max() < 0.01  # where it is
        with pytest.raises(InvalidRequest, match="stale_commands"):
            node.handle_request({"joint_pos": target, "t_cmd_target": clock.now() + 1.0})


def test_lost_state_is_a_named_fault(inspire_bridge, domain_id):
    node = inspire_node(domain_id, "left", state_timeout_s=0.3)
    with lifecycle(node):
        loop = Loop(node)
        assert loop.run(cycles=3)["fault_code"] == 0
        inspire_bridge.stop()  # the service goes silent
        s = loop.run(until=lambda s: s["fault_code"] != 0, timeout=3.0)
        assert s["fault_code"] == STATE_LOST and not s["enabled"]
        assert node.faults.fault.name == "handstate_timeout" and "rt/inspire/state" in node.faults.fault.meaning
        with pytest.raises(InvalidRequest, match="handstate_timeout"):
            node.handle_request({"joint_pos": _pose("left"), "t_cmd_target": clock.now() + 1.0})


def test_no_inspire_state_is_a_named_error(domain_id):
    node = inspire_node(domain_id, "left", connect_timeout_s=0.3)
    with pytest.raises(TimeoutError, match=rf"no rt/inspire/state on interface 'lo' \(DDS domain {domain_id}\)"):
        node.open()
    assert node.topics.dds is None


class TestInspireOnBridge(HandConformance):
    """The kit's watchdog case sees the damping stop (`on_stale = "damp"`, the default): disabled with its
    stale_commands fault, the hand stopped where it is."""

    driver = "unitree.inspire"
    config = {"side": "right", "rate_hz": 100.0, "state_timeout_s": 1.0}
    bad_config = {"interface": "nope0"}

    @contextlib.contextmanager
    def emulator(self):
        pytest.importorskip("mujoco")
        from rio_unitree.bridge import Bridge
        from rio_unitree.testing import free_domain_id

        domain = free_domain_id()
        with Bridge(domain_id=domain, interface="lo", model="fallback", state_rate_hz=100.0, hands="inspire"):
            yield {"interface": "lo", "domain_id": domain}
