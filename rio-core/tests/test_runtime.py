"""The node runtime's loop shapes, worker threads, client-side vs remote methods and error paths.
Run on the thread middleware: these are properties of the runtime, not of a transport."""

import threading
import time

import numpy as np
import pytest

import rio
from rio import Node, ServerManager, client_side, connect, remote, serve
from rio.fakes.arms import FakeArm
from rio.testing import Counter, wait_until


class ReqOnly(Node):
    def setup(self):
        self.example_request = {"v": 0.0}
        self.values = []
        self.threads = set()

    def handle_request(self, r):
        self.values.append(float(r["v"]))
        self.threads.add(threading.current_thread().name)

    @remote
    def seen(self):
        return self.values

    @remote
    def loop_thread(self):
        return sorted(self.threads)


class Both(ReqOnly):
    worker = "req"

    def setup(self):
        super().setup()
        self.example_data = {"v": 0.0}

    def read_state(self):
        return {"v": self.values[-1] if self.values else 0.0}

    @client_side
    def move(self, v):
        """Client-side convenience wrapper: validates and enqueues, never blocks."""
        self.send_request(v=v)


class Crashes(Counter):
    def read_state(self):
        if self.i >= 5:
            raise RuntimeError("encoder read failed")
        return super().read_state()



class SlowToConnect(Counter):
    """A device that answers after `delay_s`, as a controller still booting does."""

    class Config(Node.Config):
        delay_s: float = 1.0
        connect_timeout_s: float = 0.0

    def open(self):
        time.sleep(self.config.delay_s)


def test_a_node_gets_its_own_connect_timeout_to_be_ready():
    """CI saw a station's gripper (connect_timeout_s = 90) abandoned at the manager's 60 s."""
    with ServerManager("thread", [serve(SlowToConnect, name="s", connect_timeout_s=3.0)], ready_timeout=0.2):
        pass
    with pytest.raises(rio.RioError, match=r"not ready after 0 s: \['s'\]"):
        with ServerManager("thread", [serve(SlowToConnect, name="s")], ready_timeout=0.2):
            pass


def test_publish_only_loop_runs_at_its_rate():
    with ServerManager("thread", [serve(Counter, name="p", rate_hz=100)]):
        with connect(Counter, "thread", name="p") as c:
            i0 = c.get_state()["i"]
            time.sleep(0.3)
            n = c.get_state()["i"] - i0
            assert 10 <= n <= 0.3 * 100 * 1.5 + 2, n  # ran, and not faster than asked


def test_request_only_loop_wakes_on_requests():
    with ServerManager("thread", [serve(ReqOnly, name="r")]):
        with connect(ReqOnly, "thread", name="r") as c:
            for v in range(10):
                c.send_request(v=float(v))
            assert wait_until(lambda: len(c.seen()) == 10), "timed out"
            assert c.seen() == [float(v) for v in range(10)]


def test_combined_with_request_worker_thread_and_client_side_method():
    with ServerManager("thread", [serve(Both, name="b", rate_hz=200)]):
        with connect(Both, "thread", name="b") as c:
            c.move(2.5)
            assert wait_until(lambda: c.get_state()["v"] == 2.5), "timed out"
            assert c.loop_thread() == ["rio-b-worker"]  # requests handled in the worker thread
            with pytest.raises(rio.InvalidRequest, match="'v'"):
                c.move(float("nan"))


def test_error_in_loop_is_reported_by_name_to_clients():
    with ServerManager("thread", [serve(Crashes, name="enc", rate_hz=200)]):
        with connect(Crashes, "thread", name="enc") as c:
            with pytest.raises(rio.NodeDiedError, match="enc.*encoder read failed"):
                assert wait_until(lambda: c.get_state() is None, timeout=3), "timed out"


def test_duplicate_server_names_rejected():
    with pytest.raises(rio.errors.ConfigError, match="'x'"):
        ServerManager("thread", [serve(Counter, name="x"), serve(Counter, name="x")])


@pytest.mark.parametrize("mw", ["thread", "shm"])
def test_config_refused_by_setup_is_reported_with_the_node_name(mw):
    """A node is built once, where it runs: a config its `setup()` refuses stops the station's start, and the
    error names the node (in the manager's process for a thread, from the node's process for shm)."""
    served = serve(FakeArm, name="arm", dof=3, home=[0.0, 0.0])  # valid fields: accepted by the caller
    with pytest.raises(rio.RioError, match=r"node 'arm' \(FakeArm\): ValueError: home has 2 entries"):
        with ServerManager(mw, [served]):
            pass


def test_bad_node_config_fails_in_caller():
    with pytest.raises(rio.RioError, match=r"node 'x' \(Counter\) config:\n  nonsense: unknown field"):
        serve(Counter, name="x", nonsense=1)


def test_get_state_k_and_out_on_client():
    with ServerManager("thread", [serve(Counter, name="p", rate_hz=500)]):
        with connect(Counter, "thread", name="p") as c:
            assert wait_until(lambda: c.get_state()["i"] > 4), "timed out"
            out = {"i": np.zeros(3, np.int64)}
            c.get_state(k=3, out=out)
            assert np.all(np.diff(out["i"]) == 1)


class Arrivals(Node):
    """Samples made by a thread of its own (like a camera's grab thread), 25 of them, each announced
    through `arrival_event()`; the node's `rate_hz` is 1, so a paced loop would publish about one a second."""

    def setup(self):
        self.example_data = {"i": 0}
        self.arrived = threading.Event()
        self.made = self.taken = 0
        self.lock = threading.Lock()

    def open(self):
        def produce():
            for _ in range(25):
                time.sleep(0.02)
                with self.lock:
                    self.made += 1
                self.arrived.set()

        threading.Thread(target=produce, daemon=True).start()

    def arrival_event(self):
        return self.arrived

    def read_state(self):
        with self.lock:
            if self.made == self.taken:
                return None  # nothing new: publish nothing
            self.taken = self.made
            return {"i": self.made}


def test_a_node_with_an_arrival_event_publishes_each_sample_as_it_arrives():
    with ServerManager("thread", [serve(Arrivals, name="a", rate_hz=1)]):
        with connect(Arrivals, "thread", name="a") as c:
            seen = set()
            t_end = time.monotonic() + 10
            while time.monotonic() < t_end and 25 not in seen:
                try:
                    seen.add(int(c.get_state()["i"]))
                except rio.RioError:  # nothing published before the first arrival
                    pass
                time.sleep(0.002)
            assert 25 in seen
            assert len(seen) >= 10  # paced at 1 Hz it would have published a handful


def test_start_up_says_each_node_ready_and_who_is_awaited(monkeypatch):
    """`rio teleop` used to print nothing for 45-90 s between "starting station" and "teleop running"."""
    from rio.runtime import manager

    monkeypatch.setattr(manager, "_NAG_S", 0.3)
    said: list[str] = []
    nodes = [serve(Counter, name="quick"), serve(SlowToConnect, name="slow", delay_s=1.0)]
    with ServerManager("thread", nodes, progress=said.append):
        pass
    ready = [line for line in said if "ready (" in line]
    assert [line.split()[0] for line in ready] == ["quick", "slow"], said
    assert float(ready[1].split("(")[1].split(" s")[0]) >= 0.9  # the slow node's own time
    assert any(line.strip().startswith("waiting for slow (") for line in said), said  # named while awaited
    assert not any("quick" in line for line in said if "waiting" in line)


def test_a_start_that_times_out_names_the_node_and_what_to_try():
    with pytest.raises(rio.RioError) as e:
        with ServerManager("thread", [serve(SlowToConnect, name="s", delay_s=2.0)], ready_timeout=0.3):
            pass
    assert "['s']" in str(e.value) and "--ready-timeout" in str(e.value) and "ready_timeout_s" in str(e.value)
