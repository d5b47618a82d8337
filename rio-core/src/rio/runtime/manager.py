"""`serve`, `connect` and `ServerManager`: start node servers, connect clients, clean up always.

Process-per-node middlewares run each server in a *spawned* child (never forked: zenoh and zmq own
threads that fork would corrupt) whose SIGINT is ignored, so Ctrl+C in the main program stops nodes
through `ServerManager.__exit__` (closing hardware) rather than killing them mid-write. Resources
that must outlive a crash (shared memory, the run directory) are created and removed by the manager,
so a SIGKILLed child leaves nothing behind. A child whose parent dies stops itself (parent-death
signal plus control-pipe EOF).

Every way the manager's own process ends is covered too: `__exit__` (an exception, Ctrl+C) stops the
nodes with SIGINT, SIGTERM and SIGHUP held back until the last segment is released (`uv run` sends a
second SIGINT; it is delivered afterwards); a KeyboardInterrupt that escapes before `__exit__` runs is
caught up by an exit hook; and a SIGKILL, which nothing in the process can see, leaves leftovers that
the next `ServerManager` start removes (`sweep_dead_runs`, `rio.runtime.sweep`).
"""

from __future__ import annotations

import atexit
import json
import logging
import multiprocessing as mp
import multiprocessing.util  # noqa: F401  (its exit hook must be registered before ours: see _stop_live_managers)
import os
import shutil
import signal
import tempfile
import threading
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing import resource_tracker
from typing import Any, TypeVar, cast

from pydantic import ValidationError

from rio import clock
from rio.config import error_lines, validate_config
from rio.errors import ConfigError, NodeDiedError, RioError, shows_traceback
from rio.machine import host
from rio.runtime import description as D
from rio.runtime.client import NodeClient
from rio.runtime.node import Node
from rio.runtime.peer import client_reference
from rio.runtime.ring_ref import ring_reference
from rio.runtime.runner import Dispatcher, NodeRunner
from rio.runtime.sweep import MANIFEST, Swept, mark_run, sweep_dead_runs, unmark_run
from rio.runtime.transport import Middleware, NodeLayouts, machine_id

log = logging.getLogger("rio.runtime.manager")
# MANIFEST: the file in a running station's run directory that names its process and nodes (read by
# `rio top`, and by sweeps to tell a live run from a dead one).

N = TypeVar("N", bound=Node)

# Addresses of nodes served from this process: (middleware, station, node) -> address dict.
_ADDRESSES: dict[tuple[str, str, str], dict[str, Any]] = {}


def _middleware(mw: str | Middleware, station: str, options: dict | None = None) -> Middleware:
    if isinstance(mw, Middleware):
        return mw
    from rio.plugins import get_middleware

    return get_middleware(mw)(station=station, **(options or {}))


def _node_class(cls: Any) -> type[Node]:
    if not (isinstance(cls, type) and issubclass(cls, Node)):
        raise ConfigError(f"{cls!r} is not a rio.Node subclass")
    return cls


def _validated(cls: type[Node], name: str, config: Any, fields: dict[str, Any]) -> Any:
    """`cls.Config` validated from a config object and/or fields (no node is built)."""
    try:
        return validate_config(cls.Config, config, fields)
    except ValidationError as e:
        raise ConfigError(f"node '{name}' ({cls.__name__}) config:\n  "
                          + "\n  ".join(error_lines(e, "", cls.Config))) from None


def _build_node(cls: type[Node], name: str, config: Any) -> Node:
    """The node itself, built once where it runs (its server's process or thread): `setup()` runs here."""
    try:
        node = cls(config)
    except ValidationError as e:
        raise ConfigError(f"node '{name}' ({cls.__name__}) config:\n  "
                          + "\n  ".join(error_lines(e, "", cls.Config))) from None
    except Exception as e:  # setup() refused the config (an unknown model, a mismatched length, ...)
        raise ConfigError(f"node '{name}' ({cls.__name__}): {type(e).__name__}: {e}") from e
    node.name = name
    return node


@dataclass
class ServedNode:
    """What to serve, started by `ServerManager`: the node's class, name and validated config (the
    node itself is built where it runs)."""

    cls: type[Node]
    name: str
    config: Any = None
    mw: str | Middleware | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.config, self.cls.Config):  # fields (or none), as a hand-made ServedNode has
            self.config = _validated(self.cls, self.name, None, dict(self.config or {}))


def serve(cls: type[Node], mw: str | Middleware | None = None, *, name: str | None = None, config: Any = None,
          **fields: Any) -> ServedNode:
    """What `ServerManager` serves: `cls` built from `config` (a validated `cls.Config`, as a station's
    component carries) and/or `fields`. The config is checked now, in the caller's process; the node is
    built and set up once, where it runs."""
    cls = _node_class(cls)
    name = name or cls.__name__.lower()
    return ServedNode(cls, name, _validated(cls, name, config, fields), mw)


def connect(cls: type[N], mw: str | Middleware, *, name: str | None = None, station: str = "rio",
            address: dict[str, Any] | None = None, config: Any = None, **fields: Any) -> N:
    """Client for a running node of class `cls`. The address is found automatically for nodes served by
    a ServerManager in this process; pass `address` for a server elsewhere.

    The object returned is a `NodeClient` proxy, typed as `cls` so that type checkers and editors know
    the node's methods and their signatures (`arm.move_joints(q)`). It exposes only the node's API
    (`cls.__api__`: the methods marked `@remote` or `@client_side`, inherited ones included), so any
    other attribute of the class, even one a type checker accepts, raises AttributeError at run time.
    It is a context manager (`with connect(Arm, "shm") as arm:`) and has `close()`, `check_alive()`
    and `name`.

    The client's node is made from the description its server put in the address (`rio.runtime.description`):
    it is not built and its `setup()` does not run here, except for a node whose address carries none (one
    served on another machine of a station), which is built here to learn its layouts.
    """
    node_cls: type[Node] = _node_class(cls)
    name = name or node_cls.__name__.lower()
    mwo = _middleware(mw, station)
    addr = address or _ADDRESSES.get((mwo.name, mwo.station, name))
    if addr is None:
        raise NodeDiedError(name, f"no '{mwo.name}' server for it is running in station '{mwo.station}' "
                                  "(start it with ServerManager, or pass address=)")
    node: Node
    if D.KEY in addr:
        try:
            cfg = D.client_config(node_cls, name, config, fields, addr[D.KEY])
        except ValidationError as e:
            raise ConfigError(f"node '{name}' ({node_cls.__name__}) config:\n  "
                              + "\n  ".join(error_lines(e, "", node_cls.Config))) from None
        node = D.client_node(node_cls, name, cfg, addr[D.KEY])
        layouts = D.layouts_of(addr[D.KEY], name)
    else:
        node = _build_node(node_cls, name, _validated(node_cls, name, config, fields))
        layouts = NodeLayouts.of(node)
    transport = mwo.make_client(node, layouts, addr)
    # the proxy stands in for the node: typed as its class (see the docstring), not as NodeClient
    return cast(N, NodeClient(node, transport, ring_reference(mwo, layouts, addr),
                              client_reference(node_cls, mwo, name, addr)))


# -- child process ----------------------------------------------------------------------------------
def _child_main(cls: type[Node], name: str, config: dict, mw_cls: type[Middleware], station: str,
                mw_options: dict, conn: Any, parent_pid: int) -> None:
    """A node's process: build the node (once), tell the manager its layouts, take the resources the manager
    made for them (shared memory that must outlive this process), serve until told to stop."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})  # blocked since the exec: see _ProcessHandle
    host.exit_with_parent(parent_pid)
    clock.set_timer_slack()
    node = None
    started = threading.Event()

    def report(kind: str, **payload: Any) -> None:
        try:
            conn.send_bytes(json.dumps({"kind": kind, **payload}).encode())
        except OSError:
            pass

    try:
        if os.getppid() != parent_pid:
            return
        node = _build_node(cls, name, config)
        signal.signal(signal.SIGTERM, lambda *_: node.exit_event.set())
        mw = mw_cls(station=station, **mw_options)
        layouts = NodeLayouts.of(node)
        described = D.describe(node, layouts)
        report("layouts", node=described)
        try:
            answer = conn.recv_bytes()
        except (EOFError, OSError):  # the manager is gone
            return
        if answer == b"stop":
            return
        transport = mw.make_server(node, layouts, json.loads(answer))
        node.ring_buffer, node.request_queue = transport.ring_buffer, transport.request_queue
        runner = NodeRunner(node)
        address = transport.start(Dispatcher(node, runner.lock))
        address["pid"], address["machine"], address[D.KEY] = os.getpid(), machine_id(), described

        def control() -> None:
            try:
                conn.recv_bytes()
            except (EOFError, OSError):
                pass
            node.exit_event.set()

        threading.Thread(target=control, name=f"rio-{name}-control", daemon=True).start()

        def ready() -> None:
            started.set()
            report("ready", address=address)

        try:
            runner.run(on_ready=ready)
        finally:
            transport.close()
    except BaseException as e:  # reported to the manager by name, then the child exits non-zero
        _log_node_error(name, e, started.is_set())
        report("error", type=type(e).__name__, message=str(e))
        raise SystemExit(1) from None


def _log_node_error(name: str, e: BaseException, after_start: bool) -> None:
    """Say why a node stopped: a bug (or anything under `rio --debug`) with its traceback, always; an error
    the user can act on (`rio.errors.expected`: a RioError such as a policy's NaN action, no calibration, an
    unplugged port; a device or link lost) in one line, and only once the station has started: during start-up
    the manager reports it, as the command's one error line. The traceback of an expected error goes to the
    log at DEBUG level (and to the console under `rio --debug`)."""
    if shows_traceback(e):
        log.exception("node '%s' stopped with an error", name)
    elif after_start:
        log.error("node '%s' stopped with an error: %s: %s", name, type(e).__name__, e)
        log.debug("node '%s': where the error was raised", name, exc_info=e)


# -- handles ----------------------------------------------------------------------------------------
#: A node that says how long it waits for its device (`connect_timeout_s`) gets that long to be ready,
#: plus this for what `open()` does after connecting.
_AFTER_CONNECT_S = 15.0
#: While nodes start, who is still awaited is said this often.
_NAG_S = 5.0


def _connect_timeout(config: Any) -> float:
    return float(getattr(config, "connect_timeout_s", 0.0) or 0.0)


class _ThreadHandle:
    def __init__(self, spec: ServedNode, mw: Middleware):
        self.name, self.mw = spec.name, mw
        self.node = _build_node(spec.cls, spec.name, spec.config)
        self.connect_timeout_s = _connect_timeout(spec.config)
        self.layouts = NodeLayouts.of(self.node)
        self.transport = mw.make_server(self.node, self.layouts, {})
        self.node.ring_buffer = self.transport.ring_buffer
        self.node.request_queue = self.transport.request_queue
        self.runner = NodeRunner(self.node)
        self.address = self.transport.start(Dispatcher(self.node, self.runner.lock))
        self.address[D.KEY] = D.describe(self.node, self.layouts)
        self.ready = threading.Event()
        self.error: str | None = None
        self.thread = threading.Thread(target=self._run, name=f"rio-{spec.name}", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        try:
            self.runner.run(on_ready=self.ready.set)
        except BaseException as e:
            _log_node_error(self.name, e, self.ready.is_set())
            self.error = f"{type(e).__name__}: {e}"
            self.transport.ended = self.error
        finally:
            self.transport.close()

    def poll_ready(self) -> bool:
        if self.error:
            raise RioError(f"node '{self.name}' failed to start: {self.error}")
        return self.ready.is_set()

    def cause(self) -> str | None:
        return self.error

    def stop(self, timeout: float) -> None:
        self.node.exit_event.set()
        self.thread.join(timeout)
        if self.thread.is_alive():
            log.warning("node '%s' did not stop within %.1f s (thread left running)", self.name, timeout)


class _ProcessHandle:
    """A node in a spawned process. The node is built there, once; it reports its layouts, for which the
    manager makes the resources that must outlive the process (`Middleware.prepare`) and sends them back."""

    def __init__(self, spec: ServedNode, mw: Middleware, run_dir: str):
        self.name, self.mw, self.run_dir = spec.name, mw, run_dir
        self.connect_timeout_s = _connect_timeout(spec.config)
        self.layouts: NodeLayouts | None = None
        self.resources: dict[str, Any] | None = None
        ctx = mp.get_context("spawn")
        self.conn, child_conn = ctx.Pipe(duplex=True)
        # the config travels as data (a station's policy config is a model made at run time: not picklable)
        self.proc = ctx.Process(
            target=_child_main, name=f"rio-{spec.name}", daemon=False,
            args=(spec.cls, spec.name, spec.config.model_dump(), type(mw), mw.station, mw.config.model_dump(),
                  child_conn, os.getpid()),
        )
        # SIGINT stays blocked from the child's exec until `_child_main` ignores it (the manager stops its nodes
        # itself): a Ctrl-C while the child's interpreter started killed it there, with "Fatal Python error:
        # init_import_site" and a traceback. multiprocessing's resource tracker unblocks SIGINT in this thread
        # when it starts: started first.
        resource_tracker.ensure_running()
        blocked = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            self.proc.start()
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, blocked)
        child_conn.close()
        self.address: dict[str, Any] | None = None
        self.error: str | None = None

    def _prepare(self, described: dict[str, Any]) -> None:
        self.layouts = D.layouts_of(described, self.name)
        self.resources = self.mw.prepare(self.layouts, self.run_dir)
        self.conn.send_bytes(json.dumps(self.resources).encode())

    def cause(self) -> str | None:
        """Why the node's process stopped ("ValueError: ..."), as it reported it, if it did."""
        if self.error is None:
            try:
                while self.conn.poll(0):
                    msg = json.loads(self.conn.recv_bytes())
                    if msg.get("kind") == "error":
                        self.error = f"{msg['type']}: {msg['message']}"
            except (EOFError, OSError, ValueError):
                pass
        return self.error

    def poll_ready(self) -> bool:
        if self.address is not None:
            return True
        if self.conn.poll(0):
            try:
                msg = json.loads(self.conn.recv_bytes())
            except EOFError:
                msg = {"kind": "error", "type": "exit", "message": "exited before ready"}
            if msg["kind"] == "layouts":
                self._prepare(msg["node"])
                return False
            if msg["kind"] == "ready":
                self.address = msg["address"]
                return True
            # one line: a traceback worth showing was logged by the node's process already (_log_node_error)
            raise RioError(f"node '{self.name}' failed to start: {msg['type']}: {msg['message']}")
        if not self.proc.is_alive():
            raise RioError(f"node '{self.name}' exited during start-up (exit code {self.proc.exitcode})")
        return False

    def stop(self, timeout: float) -> None:
        try:
            try:
                self.conn.send_bytes(b"stop")
            except OSError:
                pass
            self.proc.join(timeout)
            if self.proc.is_alive():
                log.warning("node '%s' did not stop within %.1f s; terminating", self.name, timeout)
                self.proc.terminate()
                self.proc.join(1.0)
            if self.proc.is_alive():
                self.proc.kill()
                self.proc.join(1.0)
            self.conn.close()
        finally:  # whatever went wrong above, the segments must not outlive the run
            if self.resources is not None:
                self.mw.release(self.resources)


class ServerManager:
    """Start servers, block until every one is ready, and always clean up. Ready means within
    `ready_timeout`, or a node's own `connect_timeout_s` (plus 15 s) where that is longer.

    `ServerManager(servers)` or the paper's `ServerManager(mw, servers)`; a spec's own middleware
    wins over the manager's default.
    """

    def __init__(self, mw_or_servers: Any, servers: Any = None, *, station: str = "rio",
                 mw_options: dict[str, Any] | None = None, ready_timeout: float = 60.0,
                 stop_timeout: float = 5.0, progress: Callable[[str], None] | None = None):
        if servers is None:
            default_mw, servers = None, mw_or_servers
        else:
            default_mw = mw_or_servers
        self.specs: list[ServedNode] = list(servers.values() if isinstance(servers, dict) else servers)
        names = [s.name for s in self.specs]
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            raise ConfigError(f"two servers share the name(s) {dupes}; give each a distinct name=")
        self.station, self.default_mw, self.mw_options = station, default_mw, mw_options or {}
        self.ready_timeout, self.stop_timeout = ready_timeout, stop_timeout
        #: Told each node's start ("arm ready (1.2 s)") and, every few seconds, who is still awaited.
        self.progress = progress
        self.handles: list[_ThreadHandle | _ProcessHandle] = []
        #: Tags everything this manager creates (run directory, shared-memory names).
        self.run_id = uuid.uuid4().hex[:8]
        self.run_dir: str | None = None
        self._marker: str | None = None
        self._owner_pid = os.getpid()
        self._mws: dict[str, Middleware] = {}

    def _mw_for(self, spec: ServedNode) -> Middleware:
        mw = spec.mw or self.default_mw
        if mw is None:
            raise ConfigError(f"no middleware given for node '{spec.name}'")
        if isinstance(mw, Middleware):
            return mw
        if mw not in self._mws:
            self._mws[mw] = _middleware(mw, self.station, self.mw_options)
        return self._mws[mw]

    def __enter__(self) -> ServerManager:
        _sweep_at_start()
        self._owner_pid = os.getpid()
        _LIVE.add(self)
        try:
            # In this order, removed in the reverse one: a concurrent sweep that sees any of this run's
            # segments also sees the marker and the manifest that say the run is alive (see rio.runtime.sweep).
            self._marker = mark_run(self.run_id)
            self.run_dir = tempfile.mkdtemp(prefix=f"rio-{self.run_id}-", dir=host.run_dir_base())
            self._write_manifest(strict=True)
            for spec in self.specs:
                mw = self._mw_for(spec)
                if mw.process_per_node:
                    self.handles.append(_ProcessHandle(spec, mw, self.run_dir))
                else:
                    self.handles.append(_ThreadHandle(spec, mw))
            self._wait_ready()
        except BaseException:
            self._stop_all()
            raise
        return self

    def _wait_ready(self) -> None:
        timeout = max([self.ready_timeout] + [h.connect_timeout_s + _AFTER_CONNECT_S for h in self.handles
                                              if h.connect_timeout_s > 0])
        t0 = clock.now()
        deadline, nag = t0 + timeout, t0 + _NAG_S
        say = self.progress or (lambda _line: None)
        pending = list(self.handles)
        while pending:
            still = []
            for h in pending:
                if h.poll_ready():
                    say(f"  {h.name} ready ({clock.now() - t0:.1f} s)")
                else:
                    still.append(h)
            pending = still
            now = clock.now()
            if pending and now > deadline:
                raise RioError(f"nodes not ready after {timeout:.0f} s: {[h.name for h in pending]}. A node that is "
                               "only slow to start (a loaded machine, a first model compile, a device that boots) "
                               "needs more time: "
                               f"--ready-timeout {2 * timeout:.0f}, or ready_timeout_s in the station file; one that "
                               "never starts: check its device and `rio doctor`")
            if pending and now >= nag:
                nag = now + _NAG_S
                say(f"  waiting for {', '.join(h.name for h in pending)} ({now - t0:.0f} s of {timeout:.0f} s)")
            if pending:
                clock.precise_wait(clock.now() + 0.002)
        for h in self.handles:
            assert h.address is not None  # every handle is ready
            _ADDRESSES[(h.mw.name, h.mw.station, h.name)] = h.address
        self._write_manifest()

    def _write_manifest(self, strict: bool = False) -> None:
        """`station.json` in the run directory: what `rio top` reads to find this station's nodes, their
        processes and (where the middleware shares them) their ring buffers, and what sweeps read to know
        the run is alive. Written first with no node, before any segment exists (`strict`: a run that
        cannot say it is alive must not start), then again once every node is ready. Removed with the
        directory."""
        if not self.run_dir:
            return
        pids = self.pids()

        def ring(h: _ThreadHandle | _ProcessHandle) -> dict[str, Any] | None:
            if h.layouts is None:  # a process that has not reported its layouts yet
                return None
            try:
                return ring_reference(h.mw, h.layouts, h.address or {})
            except Exception:  # a middleware whose address lacks what a reference needs: process only
                return None

        nodes = [{"name": h.name, "middleware": h.mw.name, "pid": pids.get(h.name, os.getpid()), "ring": ring(h)}
                 for h in self.handles]
        manifest = {"station": self.station, "run_id": self.run_id, "pid": os.getpid(),
                    "pidns": host.pid_namespace(), "started": time.time(), "nodes": nodes}
        path = os.path.join(self.run_dir, MANIFEST)
        try:
            with open(path + ".tmp", "w") as f:
                json.dump(manifest, f)
            os.replace(path + ".tmp", path)  # atomic: a reader sees the old manifest or the new one
        except (OSError, TypeError, ValueError) as e:  # the first one says the run is alive; later ones, for `rio top`
            if strict:
                raise
            log.warning("could not write %s: %s", path, e)

    def address(self, name: str) -> dict[str, Any]:
        for h in self.handles:
            if h.name == name:
                assert h.address is not None  # handles are kept only once all are ready
                return h.address
        raise KeyError(name)

    def ended(self) -> list[str]:
        """Nodes that stopped while the manager serves them, each as "name (why)" (`rio serve` watches)."""
        out = []
        for h in self.handles:
            if isinstance(h, _ProcessHandle) and not h.proc.is_alive():
                out.append(f"{h.name} (exit code {h.proc.exitcode})")
            elif isinstance(h, _ThreadHandle) and (h.error or not h.thread.is_alive()):
                out.append(f"{h.name} ({h.error or 'stopped'})")
        return out

    def cause(self, name: str) -> str | None:
        """Why node `name` stopped, as it said ("PolicyError: ..."); None when it did not say (or runs on)."""
        for h in self.handles:
            if h.name == name:
                return h.cause()
        return None

    def pids(self) -> dict[str, int]:
        pids = {}
        for h in self.handles:
            if isinstance(h, _ProcessHandle):
                assert h.proc.pid is not None  # started in _ProcessHandle.__init__
                pids[h.name] = h.proc.pid
        return pids

    def _stop_all(self) -> None:
        """Stop every node and remove everything of the run, with SIGINT, SIGTERM and SIGHUP held back
        until done (then delivered): an interrupted stop would leak what it had not yet released."""
        with host.DeferredSignals("stopping the nodes and releasing their resources first"):
            for h in self.handles:
                _ADDRESSES.pop((h.mw.name, h.mw.station, h.name), None)
            for h in reversed(self.handles):
                try:
                    h.stop(self.stop_timeout)
                except Exception:
                    log.exception("while stopping node '%s'", h.name)
            self.handles.clear()
            if self.run_dir:
                shutil.rmtree(self.run_dir, ignore_errors=True)
                self.run_dir = None
            try:
                unmark_run(self._marker)  # last: until now, it told sweeps this run was alive
            except OSError as e:
                log.warning("could not remove the run marker %s: %s", self._marker, e)
            self._marker = None
            _LIVE.discard(self)

    def __exit__(self, *exc: Any) -> None:
        self._stop_all()


# -- after a crash ----------------------------------------------------------------------------------
#: Managers entered and not yet stopped, for the exit hook below (held strongly: one dropped without
#: `__exit__` still has node processes to stop).
_LIVE: set[ServerManager] = set()


def _stop_live_managers() -> None:
    """At interpreter exit, stop the managers whose `__exit__` never ran: a KeyboardInterrupt that
    arrives between a first one and the `with` block's exit escapes to the top level. Registered after
    multiprocessing's own exit hook, so it runs first (that one waits for node processes, which would
    otherwise wait for a stop message forever)."""
    for mgr in list(_LIVE):
        if mgr._owner_pid != os.getpid():
            continue  # a forked child exiting: the station is its parent's to stop
        log.warning("station '%s' was not stopped; stopping it at exit", mgr.station)
        mgr._stop_all()


atexit.register(_stop_live_managers)


def _sweep_at_start() -> Swept | None:
    """Remove dead runs' leftovers before starting a new run; never fails the start."""
    try:
        swept = sweep_dead_runs()
    except Exception as e:  # a sweep is a courtesy: a run must start without it
        log.warning("could not sweep dead runs: %s: %s", type(e).__name__, e)
        return None
    if swept:
        log.warning(swept.summary())
    return swept
