"""The cases every driver passes (`DriverConformance`, also `SensorConformance`) and what the kind kits
share: the contract rules as failure messages name them, and small checks. See `rio.conformance.drivers`."""

from __future__ import annotations

import contextlib
import inspect
import json
import uuid
from collections.abc import Iterator, Mapping
from typing import Any, ClassVar

import numpy as np
import pytest

from rio import ServerManager, connect, serve
from rio.conformance.driving import (
    DriverUnderTest,
    InjectedFault,
    Loop,
    build_node,
    caused_by,
    check_layout,
    expect,
    fmt,
    resolve_driver,
    run_with_fault,
    violated,
)
from rio.errors import RioError
from rio.runtime.node import Node
from rio.testing import lifecycle, wait_until

FLOAT, BOOL, INT = "f", "b", "iu"
#: {key: (shape, or None for any; dtype kind letters such as "f", or an exact dtype)}
KeySpec = dict[str, tuple[tuple[int, ...] | None, "str | np.dtype[Any]"]]

#: The rules, as failure messages name them.
LAYOUT = "every sample has exactly the keys, shapes and dtypes declared in example_data"
KIND_KEYS = "example_data / example_request declare the kind's keys"
MEASURED = "what the kind requires measured is never NaN"
SI = "values are in SI units (m, rad, s)"
CLIP = "limit clipping: a target beyond a limit ends at the limit, never beyond"
STEP = "maximum step: the goal moves at most max_step per cycle"
WATCHDOG = "watchdog hold: a stream that goes silent mid-move is held where it is"
WATCHDOG_DAMPS = ("watchdog damping: a driver that damps a silent stream (on_stale = 'damp') stops it with its "
                  "stale_commands fault, disabled, once watchdog_s has passed, and clear_faults() holds where it is")
DISABLED = "a disabled device refuses commands and is not driven"
ENABLE = "enable holds the present pose (nothing moves until the next command)"
FOLLOWS = "NaN for unmeasured values: a finite eef_pose follows the joints"
CLOSE = "close() after an error: closing() and close() run when the loop fails"
STARTUP = "start-up failure is reported with the node's name"
REQUESTS = "bad requests are rejected by the client with InvalidRequest naming the node and field"
SERVED = "the node serves its samples through the runtime"
BUTTONS = "a teleop device publishes the configured number of buttons (config `buttons`)"


def quat_ok(q: np.ndarray) -> bool:
    return bool(np.isfinite(q).all() and abs(float(np.linalg.norm(q)) - 1.0) < 1e-3)


def far_target(q0: np.ndarray, lower: np.ndarray, upper: np.ndarray, dist: float) -> np.ndarray:
    """Per coordinate, `dist` toward the side with more room (at most 80 % of that room)."""
    up, down = upper - q0, q0 - lower
    sign = np.where(up >= down, 1.0, -1.0)
    return q0 + sign * np.minimum(dist, 0.8 * np.maximum(up, down))


class DriverConformance:
    """The cases every driver passes, whatever its kind. Subclass a kind's class (or this one, as
    `SensorConformance`, for a node of no standard kind) as `Test...` and set `driver` and `config`.

    `driver = None` takes the driver from `--rio-driver NAME` and its fields from `--rio-driver-config`.
    """

    #: Registered driver name (`rio drivers list`), a 'module:Class' path, or the node class.
    driver: ClassVar[str | type[Node] | None] = None
    #: Station fields the node is built with (the emulator's overrides go on top).
    config: ClassVar[Mapping[str, Any]] = {}
    #: Fields (over `config` and the emulator's) with which `open()` must fail; the start-up case
    #: is skipped without it.
    bad_config: ClassVar[Mapping[str, Any] | None] = None
    #: The node's name in every case (messages name it).
    node_name: ClassVar[str] = ""
    #: Samples read by the sample cases.
    cycles: ClassVar[int] = 20

    kind: ClassVar[str] = "sensor"
    #: The kind its spec is registered under, where it differs from `kind` (a wrench sensor is a "sensor").
    registered_as: ClassVar[str | None] = None
    node_base: ClassVar[type[Node]] = Node
    #: The driver hook the close-after-error case makes fail mid-run.
    read_hook: ClassVar[str] = "read_state"

    # -- the author's hook ------------------------------------------------------------------------------
    def emulator(self) -> contextlib.AbstractContextManager[Mapping[str, Any] | None]:
        """Start what the driver talks to (an emulator, a simulated world) for one case and yield the
        config fields that point the driver at it (or None). Default: nothing to start."""
        return contextlib.nullcontext()

    # -- fixtures -------------------------------------------------------------------------------------
    @pytest.fixture(scope="class")
    @classmethod
    def driver_under_test(cls, request: pytest.FixtureRequest) -> DriverUnderTest:
        """The driver class (and a registered name's preset) this class tests."""
        kit = request.cls
        driver = getattr(kit, "driver", None)
        selected = driver is None
        if selected:
            driver = request.config.getoption("rio_driver", None)
            if driver is None:
                pytest.skip(f"no driver to test: set `driver = ...` on {kit.__name__} or pass --rio-driver NAME")
        assert driver is not None
        dut = resolve_driver(driver)
        if kit.kind != "sensor" or selected:
            registered, expected = dut.registered_kind, kit.registered_as or kit.kind
            if registered is not None and registered != expected:
                if selected:
                    pytest.skip(f"{dut.label} is a {registered} driver, not a {expected}")
                pytest.fail(f"{dut.label} is registered as a {registered} driver; test it with "
                            f"{registered.capitalize()}Conformance, not {kit.kind.capitalize()}Conformance",
                            pytrace=False)
        if not issubclass(dut.cls, kit.node_base):
            if selected and dut.registered_kind is None:
                pytest.skip(f"{dut.cls.__name__} is not a {kit.node_base.__name__}")
            pytest.fail(f"{dut.label} ({dut.cls.__module__}.{dut.cls.__qualname__}) does not subclass "
                        f"{kit.node_base.__name__}: a {kit.kind} driver gets its contract from that kind",
                        pytrace=False)
        return dut

    @pytest.fixture
    def driver_fields(self, driver_under_test: DriverUnderTest, request: pytest.FixtureRequest) -> Iterator[dict]:
        """The station fields of one case, with the emulator running."""
        if type(self).driver is None:
            raw = request.config.getoption("rio_driver_config", None) or "{}"
            try:
                base = json.loads(raw)
            except json.JSONDecodeError as e:
                raise pytest.UsageError(f"--rio-driver-config is not JSON ({e}): {raw}") from None
            if not isinstance(base, dict):
                raise pytest.UsageError(f"--rio-driver-config must be a JSON object of fields, got {raw}")
        else:
            base = dict(self.config)
        cm = self.emulator()
        if inspect.isgenerator(cm):  # a generator method without @contextmanager
            cm = contextlib.contextmanager(lambda: cm)()
        with cm as overrides:
            yield {**base, **(overrides or {})}

    # -- helpers --------------------------------------------------------------------------------------
    @property
    def name(self) -> str:
        return self.node_name or f"{self.kind}_under_test"

    def make(self, dut: DriverUnderTest, fields: Mapping[str, Any], **extra: Any) -> Node:
        return build_node(dut, {**fields, **extra}, self.name)

    def loop(self, node: Node) -> Loop:
        return Loop(node)

    def kind_keys(self, node: Node) -> KeySpec:
        """{key: (shape or None for any, dtype kind letters or an exact dtype)} every sample of the kind has."""
        return {}

    def request_keys(self, node: Node) -> KeySpec:
        return {}

    def measured_keys(self, node: Node) -> tuple[str, ...]:
        """Keys that are always measured: never NaN."""
        return ()

    def check_units(self, node: Node, sample: Mapping[str, Any], i: int) -> None:
        """The kind's checks of one sample's values (SI units, ranges)."""

    # -- cases every driver passes --------------------------------------------------------------------
    def test_example_data_declares_the_kind_keys(self, driver_under_test, driver_fields):
        node = self.make(driver_under_test, driver_fields)
        for what, declared, keys in (("example_data", node.example_data, self.kind_keys(node)),
                                     ("example_request", node.example_request, self.request_keys(node))):
            expect(declared or not keys, self.kind, KIND_KEYS, f"{what} is empty; a {self.kind} has {sorted(keys)}")
            for key, (shape, dtype) in keys.items():
                expect(key in declared, self.kind, KIND_KEYS,
                       lambda key=key, what=what, declared=declared: f"{what} lacks '{key}' (has {sorted(declared)})")
                v = np.asarray(declared[key])
                expect(shape is None or v.shape == shape, self.kind, KIND_KEYS,
                       f"{what}['{key}'] has shape {v.shape}, the kind's is {shape}")
                ok = v.dtype == dtype if isinstance(dtype, np.dtype) else v.dtype.kind in dtype
                expect(ok, self.kind, KIND_KEYS, f"{what}['{key}'] has dtype {v.dtype}, the kind's is "
                                                 f"{dtype if isinstance(dtype, np.dtype) else kind_text(dtype)}")
        expect(node.example_data, self.kind, KIND_KEYS, "example_data is empty: the node publishes nothing")

    def test_samples_match_the_declared_layout(self, driver_under_test, driver_fields):
        node = self.make(driver_under_test, driver_fields)
        declared = dict(node.example_data)  # what the runtime sizes its buffers from, before open()
        with lifecycle(node):
            loop = self.loop(node)
            loop.run(cycles=self.cycles)
        expect(len(loop.samples) >= 2, self.kind, LAYOUT,
               f"{len(loop.samples)} samples in {loop.ticks} ticks (cycle() returned None {loop.skipped} times)")

        for i, s in enumerate(loop.samples):
            check_layout(self.kind, declared, s, i)

    def test_samples_are_measured_in_si_units(self, driver_under_test, driver_fields):
        node = self.make(driver_under_test, driver_fields)
        with lifecycle(node):
            loop = self.loop(node)
            loop.run(cycles=self.cycles)
            expect(loop.samples, self.kind, SI, f"no sample in {loop.ticks} ticks")
            for i, s in enumerate(loop.samples):
                for key in self.measured_keys(node):
                    v = np.asarray(s.get(key, np.nan), dtype=np.float64)
                    expect(not np.isnan(v).any(), self.kind, MEASURED, lambda key=key, v=v, i=i: f"sample {i}: "
                           f"'{key}' = {fmt(v)}: a {self.kind} always measures it")
                self.check_units(node, s, i)

    def test_close_runs_after_an_error_mid_run(self, driver_under_test, driver_fields):
        node = self.make(driver_under_test, driver_fields)
        hook = self.read_hook
        error, calls = run_with_fault(node, hook)
        expect(error is not None, self.kind, CLOSE,
               f"{hook}() raised mid-run but the node kept running (the error must end the loop, so the "
               f"runtime reports it); closing/close calls: {calls}")
        expect(caused_by(error, InjectedFault), self.kind, CLOSE,
               f"the run ended with {type(error).__name__}: {error}, not with the error {hook}() raised")
        expect(calls == ["closing", "close"], self.kind, CLOSE,
               f"after {hook}() raised, the calls were {calls}; expected closing() then close(), once each")

    def test_served_by_the_runtime(self, driver_under_test, driver_fields):
        node = self.make(driver_under_test, driver_fields)
        declared = set(node.example_data)
        with self._served(driver_under_test, driver_fields) as c:
            s = self._first_sample(c)
            expect(set(s) == declared | {"timestamp"}, self.kind, SERVED,
                   f"a served sample has keys {sorted(s)}; declared {sorted(declared)} plus 'timestamp'")
            t0 = float(s["timestamp"])
            expect(wait_until(lambda: float(c.get_state()["timestamp"]) > t0, timeout=5.0), self.kind, SERVED,
                   "no new sample within 5 s of the first")

    def test_startup_failure_names_the_node(self, driver_under_test, driver_fields):
        if self.bad_config is None:
            pytest.skip("no bad_config: set `bad_config = {...}` (fields with which open() fails) to test it")
        values = {**self._values(driver_under_test, driver_fields), **self.bad_config}
        try:
            node = build_node(driver_under_test, values, self.name)
            with lifecycle(node):
                pass
        except Exception as e:  # noqa: BLE001 - the failure the case expects
            underlying = e
        else:
            violated(self.kind, STARTUP, f"open() did not fail with bad_config {dict(self.bad_config)}")
        with pytest.raises(Exception) as ei:  # noqa: B017 - any error, checked by its text below
            with ServerManager("thread", [serve(driver_under_test.cls, name=self.name, **values)],
                               station=f"kit-{uuid.uuid4().hex[:8]}"):
                pass
        text = str(ei.value)
        expect(self.name in text, self.kind, STARTUP,
               f"the error does not name node '{self.name}': {type(ei.value).__name__}: {text}")
        detail = str(underlying).strip().splitlines()[0] if str(underlying).strip() else type(underlying).__name__
        if isinstance(underlying, AssertionError):  # the config itself was rejected: the fields are named
            detail = next(iter(self.bad_config))
        expect(detail in text, self.kind, STARTUP,
               f"the error does not carry the underlying message {detail!r}: {type(ei.value).__name__}: {text}")

    # -- helpers of the cases -------------------------------------------------------------------------
    def _values(self, dut: DriverUnderTest, fields: Mapping[str, Any]) -> dict[str, Any]:
        from rio.config import apply_preset

        return apply_preset(dut.preset, dict(fields), dut.label)

    @contextlib.contextmanager
    def _served(self, dut: DriverUnderTest, fields: Mapping[str, Any]) -> Iterator[Any]:
        """The node served by `ServerManager` on the thread middleware, and a client of it."""
        values, station = self._values(dut, fields), f"kit-{uuid.uuid4().hex[:8]}"
        manager = ServerManager("thread", [serve(dut.cls, name=self.name, **values)], station=station)
        try:
            manager.__enter__()
        except RioError as e:
            violated(self.kind, SERVED, f"the node did not start under the runtime: {e}")
        try:
            with connect(dut.cls, "thread", name=self.name, station=station, **values) as client:
                yield client
        finally:
            manager.__exit__(None, None, None)

    def _first_sample(self, client: Any) -> dict[str, Any]:
        got: dict[str, Any] = {}

        def ready() -> bool:
            try:
                got.update(client.get_state())
            except RioError as e:
                if "published nothing" not in str(e):
                    raise
                return False
            return True

        expect(wait_until(ready, timeout=5.0), self.kind, SERVED, "no sample within 5 s of start-up")
        return got


SensorConformance = DriverConformance


def kind_text(letters: str) -> str:
    return {"f": "float", "b": "bool", "iu": "integer"}.get(letters, letters)


