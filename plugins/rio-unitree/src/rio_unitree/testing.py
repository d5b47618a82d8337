"""Helpers for tests of G1 code over real DDS: a domain nobody else on this machine uses (two test runs
side by side must never hear each other's robots), and a tap that records what goes over a topic."""

from __future__ import annotations

import contextlib
import itertools
import random
import threading
import time
from collections.abc import Iterator
from typing import Any

from .dds import Participant
from .wire import LowCmd, LowState, cmd_crc_ok

#: Domains this process handed out, with the order it did: a domain is handed out again only when every
#: other one of the range was (the longest ago first), and only if its probe still finds nobody on it.
_handed_out: dict[int, int] = {}
_order = itertools.count()


#: Cyclone DDS binds UDP ports 7400 + 250 * domain + 0..249 (`dds.udp_ports`). Domains up to 100 keep
#: them under Linux's ephemeral range (32768 and up): above it, a port the kernel had handed to any other
#: socket on the machine fails the domain's start ("failed to bind to ANY:42150: address in use", seen for
#: domain 139 in a loaded parallel test run). Domain 0 is the robot's and 1 the simulators' (unitree_mujoco's).
TEST_DOMAINS = (2, 100)


def free_domain_id(interface: str = "lo", lo: int = TEST_DOMAINS[0], hi: int = TEST_DOMAINS[1],
                   listen_s: float = 0.15) -> int:
    """A DDS domain in [lo, hi] with no participant but ours after `listen_s` of discovery, preferring one
    this process has not handed out before; a pytest-xdist worker draws from its own share of the range
    (`rio.machine.parallel`: two workers probing at once would both find the same domain free).

    A test process can ask more often than the range is long (a worker holds half of it): never reusing a
    domain ran a worker out of domains in the middle of the G1 tests ("no free DDS domain"), so the ones
    handed out longest ago are probed again last."""
    from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsParticipant

    from rio.machine.parallel import worker_share

    share = worker_share(lo, hi)
    candidates = list(share)
    random.shuffle(candidates)
    candidates.sort(key=lambda d: _handed_out.get(d, -1))  # never handed out first, in random order
    for domain in candidates[:20]:
        with Participant(domain, interface) as p:
            reader = BuiltinDataReader(p.participant, BuiltinTopicDcpsParticipant)
            p._entities.append(reader)  # deleted with the participant
            time.sleep(listen_s)
            others = [s for s in reader.take(N=64) if s.key != p.participant.guid]
        if not others:
            _handed_out[domain] = next(_order)
            return domain
    raise RuntimeError(f"no free DDS domain in {share.start}..{share.stop - 1} on {interface}: 20 probed, each in use")


@contextlib.contextmanager
def publishing(writer: Any, data: bytes, period_s: float = 0.005) -> Iterator[None]:
    """`writer` publishes the same sample every `period_s` from a thread while the block runs: a peer that
    only talks (a simulator's state, a damaged robot's) without a whole bridge behind it."""
    stop = threading.Event()

    def publish() -> None:
        while not stop.is_set():
            writer.write(data)
            stop.wait(period_s)

    thread = threading.Thread(target=publish, name="rio-test-publish", daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()


class Tap:
    """Records every sample on `topic` (decoded; `bad_crc` counts those whose CRC is wrong; the hands'
    topics `rt/dex3/...` and `rt/inspire/...` too). `with`."""

    def __init__(self, domain_id: int, topic: str, interface: str = "lo"):
        self.topic = topic
        self.dds = Participant(domain_id, interface)
        self.reader = self.dds.reader(topic, depth=256)
        self.samples: list[Any] = []
        self.bad_crc = 0

    def poll(self) -> list[Any]:
        new = []
        for data in self.reader.take():
            if self.topic.startswith("rt/inspire/"):
                from .inspire_wire import MotorCmds, MotorStates

                new.append((MotorStates if self.topic.endswith("/state") else MotorCmds).decode(data))
                continue
            if self.topic.startswith("rt/dex3/"):
                from .hand_wire import HandCmd, HandState

                new.append((HandState if self.topic.endswith("/state") else HandCmd).decode(data))
                continue
            if self.topic == "rt/lowstate":
                new.append(LowState.decode(data))
                continue
            if not cmd_crc_ok(data):
                self.bad_crc += 1
            new.append(LowCmd.decode(data))
        self.samples.extend(new)
        return new

    def wait(self, pred: Any, timeout: float = 5.0) -> Any:
        """The first new sample for which `pred(sample)` holds, within `timeout` s (None if none)."""
        t_end = time.monotonic() + timeout
        while time.monotonic() < t_end:
            for s in self.poll():
                if pred(s):
                    return s
            time.sleep(0.005)
        return None

    def close(self) -> None:
        self.dds.close()

    def __enter__(self) -> Tap:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
