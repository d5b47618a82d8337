"""The driver kit's machinery: resolving the driver under test, building it from station fields, ticking
it in the caller's thread at its rate while recording the goals it writes, running it under the
runtime with a fault injected, and the sample checks shared by every kind.

Used by `rio.conformance.drivers`; also usable in a plugin's own tests (`Loop` to tick a node the way
the runtime does and see each goal its driver is asked to write).
"""

from __future__ import annotations

import threading
import uuid
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, NoReturn

import numpy as np

from rio import clock
from rio.runtime.node import Node

__all__ = ["DriverUnderTest", "resolve_driver", "build_node", "Loop", "run_with_fault", "InjectedFault", "caused_by",
           "violated", "expect", "fmt", "check_layout"]


# -- reporting ----------------------------------------------------------------------------------------
def fmt(x: Any) -> str:
    """Short text of a value for failure messages."""
    arr = np.asarray(x)
    if arr.dtype.kind in "fc":
        return np.array2string(arr, precision=4, suppress_small=True, max_line_width=200, threshold=12)
    if arr.ndim and arr.size > 12:
        return f"array of shape {arr.shape} {arr.dtype}"
    return repr(x) if not isinstance(x, np.ndarray) else np.array2string(arr, threshold=12)


def violated(kind: str, rule: str, seen: str) -> NoReturn:
    """Fail naming the contract rule that was broken and what was seen."""
    __tracebackhide__ = True
    raise AssertionError(f"{kind} contract, {rule}: {seen}")


def expect(ok: Any, kind: str, rule: str, seen: str | Callable[[], str]) -> None:
    __tracebackhide__ = True
    if not ok:
        violated(kind, rule, seen() if callable(seen) else seen)


# -- the driver under test ----------------------------------------------------------------------------
@dataclass
class DriverUnderTest:
    cls: type[Node]
    #: How the kit names it in messages: the registered name, or the class name.
    label: str
    preset: dict[str, Any] = field(default_factory=dict)
    #: The kind it is registered as (None for a class given directly).
    registered_kind: str | None = None


def resolve_driver(driver: str | type[Node]) -> DriverUnderTest:
    """A registered driver name (`rio drivers list`), a 'module:Class' path, or a node class."""
    if isinstance(driver, type):
        if not issubclass(driver, Node):
            raise TypeError(f"driver {driver!r} is not a rio.Node subclass")
        return DriverUnderTest(driver, driver.__name__)
    if not isinstance(driver, str) or not driver:
        raise TypeError(f"driver must be a registered name or a node class, got {driver!r}")
    if ":" in driver:
        from rio.plugins.specs import import_path

        return resolve_driver(import_path(driver))
    from rio.plugins import get_registry

    spec = get_registry().find("rio_drivers", driver, "driver")
    return DriverUnderTest(spec.load(), driver, dict(spec.preset), spec.kind)


def build_node(dut: DriverUnderTest, fields: Mapping[str, Any], name: str) -> Node:
    """The node as a station builds it: the spec's preset under the station fields, validated."""
    from pydantic import ValidationError

    from rio.config import apply_preset, error_lines

    values = apply_preset(dut.preset, dict(fields), dut.label)
    try:
        node = dut.cls(**values)
    except ValidationError as e:
        raise AssertionError(f"the kit cannot build {dut.label} from the fields {values}:\n  "
                             + "\n  ".join(error_lines(e, "", dut.cls.Config))) from None
    node.name = name
    return node


# -- ticking a node in this thread ----------------------------------------------------------------------
class Loop:
    """Ticks a node's `cycle()` at its rate in the caller's thread, as the runtime does, keeping
    every sample and (when `goal_hook` names the driver's write hook, e.g. "write_joints") every goal the
    kind asks the driver to write, as a vector. The hook is wrapped on the instance, so what is recorded
    is exactly what reaches the driver, with no physics in between."""

    def __init__(self, node: Node, goal_hook: str | None = None,
                 goal_of: Callable[..., Any] = lambda *args, **kwargs: args[0]):
        self.node = node
        self.rate = clock.Rate(node.rate_hz, spin_s=0.0)
        self.samples: list[dict[str, Any]] = []
        self.ticks = 0
        self.skipped = 0  # ticks whose cycle() returned None (nothing published)
        #: (tick number, goal) for every write
        self.writes: list[tuple[int, np.ndarray]] = []
        if goal_hook is not None:
            original = getattr(node, goal_hook)

            def record(*args: Any, **kwargs: Any) -> Any:
                goal = np.array(goal_of(*args, **kwargs), dtype=np.float64).reshape(-1)
                self.writes.append((self.ticks, goal))
                return original(*args, **kwargs)

            setattr(node, goal_hook, record)

    @property
    def goals(self) -> list[np.ndarray]:
        return [g for _, g in self.writes]

    def tick(self) -> dict[str, Any] | None:
        self.ticks += 1
        sample = self.node.cycle()
        if sample is None:
            self.skipped += 1
        else:
            sample = dict(sample)
            self.samples.append(sample)
        self.rate.sleep()
        return sample

    def run(self, *, cycles: int | None = None, seconds: float | None = None,
            until: Callable[[dict[str, Any]], bool] | None = None, timeout: float = 5.0) -> dict[str, Any] | None:
        """Tick `cycles` times, or for `seconds`, or until `until(sample)` holds (at most `timeout` s).
        Returns the last sample published."""
        t_end = clock.now() + (seconds if seconds is not None else timeout)
        n = 0
        while True:
            s = self.tick()
            n += 1
            if cycles is not None and n >= cycles:
                break
            if until is not None and s is not None and until(s):
                break
            if clock.now() >= t_end and (cycles is None or n >= cycles):
                break
        return self.last

    @property
    def last(self) -> dict[str, Any] | None:
        return self.samples[-1] if self.samples else None


# -- a fault under the runtime ------------------------------------------------------------------------------
class InjectedFault(RuntimeError):
    """Raised by the kit inside a driver hook, to see the runtime stop the node properly."""


def caused_by(e: BaseException | None, cls: type) -> bool:
    seen = set()
    while e is not None and id(e) not in seen:
        if isinstance(e, cls):
            return True
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return False


def run_with_fault(node: Node, hook: str, after: int = 3,
                   timeout: float = 10.0) -> tuple[BaseException | None, list[str]]:
    """Serve `node` with `rio.runtime.runner.NodeRunner` on the thread middleware, in this thread; once it is
    ready, its `hook` (e.g. "read_joints") raises `InjectedFault` on the call after `after` good ones.
    Returns (the error `run()` ended with, or None if it ran until `timeout`; the calls of
    `closing` / `close` in order)."""
    from rio.middleware.thread import ThreadMiddleware
    from rio.runtime.runner import Dispatcher, NodeRunner
    from rio.runtime.transport import NodeLayouts

    calls: list[str] = []
    for name in ("closing", "close"):
        def wrap(original: Callable[[], None], name: str = name) -> Callable[[], None]:
            def called() -> None:
                calls.append(name)
                original()
            return called
        setattr(node, name, wrap(getattr(node, name)))
    good = [-1]  # -1: not ready yet

    original = getattr(node, hook)

    def faulty(*args: Any, **kwargs: Any) -> Any:
        if good[0] >= 0:
            if good[0] >= after:
                raise InjectedFault(f"injected by the conformance kit: {hook}() failed mid-run")
            good[0] += 1
        return original(*args, **kwargs)

    setattr(node, hook, faulty)
    mw = ThreadMiddleware(station=f"rio-kit-{uuid.uuid4().hex[:8]}")
    transport = mw.make_server(node, NodeLayouts.of(node), {})
    node.ring_buffer, node.request_queue = transport.ring_buffer, transport.request_queue
    runner = NodeRunner(node)
    transport.start(Dispatcher(node, runner.lock))
    timer = threading.Timer(timeout, node.exit_event.set)
    timer.daemon = True
    timer.start()
    error: BaseException | None = None
    try:
        runner.run(on_ready=lambda: good.__setitem__(0, 0))
    except Exception as e:  # what the runtime reports
        error = e
    finally:
        timer.cancel()
        timer.join()  # a cancelled Timer's thread still takes a moment to end: none is left behind
        transport.close()
    return error, calls


# -- sample checks --------------------------------------------------------------------------------------------
def check_layout(kind: str, declared: Mapping[str, Any], sample: Mapping[str, Any], index: int) -> None:
    """`sample` has exactly the declared keys, each with the declared shape and a dtype the ring buffer
    accepts for it, and no inf anywhere (NaN is how an unmeasured value is published)."""
    __tracebackhide__ = True
    rule = "every sample has exactly the keys, shapes and dtypes declared in example_data"
    keys, want = set(sample), set(declared)
    expect(keys == want, kind, rule,
           lambda: f"sample {index} has keys {sorted(keys)}; undeclared {sorted(keys - want)}, "
                   f"missing {sorted(want - keys)}")
    for name, example in declared.items():
        ex = np.asarray(example)
        try:
            v = np.asarray(sample[name])
        except Exception as e:  # noqa: BLE001 - reported as the contract failure it is
            violated(kind, rule, f"sample {index}: '{name}' is not an array or number ({e})")
        expect(v.shape == ex.shape, kind, rule,
               f"sample {index}: '{name}' has shape {v.shape}, example_data declares {ex.shape}")
        expect(v.dtype.kind in "biufc" and np.can_cast(v.dtype, ex.dtype, casting="same_kind"), kind, rule,
               f"sample {index}: '{name}' has dtype {v.dtype}, example_data declares {ex.dtype}")
        if v.dtype.kind in "fc" and np.isinf(v).any():
            violated(kind, "values are finite, or NaN where not measured (never inf)",
                     f"sample {index}: '{name}' = {fmt(v)}")
