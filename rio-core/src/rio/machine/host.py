"""What RIO asks of the operating system, in the one place where Linux, macOS and Windows differ.

- Linux: anonymous shared memory is a memfd; process exit is watched through a pidfd; POSIX shared
  memory objects are files in /dev/shm, so leftovers can be listed and swept.
- macOS: no memfd (an unlinked temporary file serves), no pidfd (a kqueue exit filter serves; with
  neither, liveness is polled with `kill(pid, 0)` plus a zombie check), POSIX shm names are limited
  to 31 characters and cannot be listed at all: RIO keeps a marker file per object it creates
  (`registry_dir()`), which is what it lists and sweeps.
- Windows: no POSIX shared memory, no fcntl. The thread, zmq and zenoh middlewares, datasets and
  policies need none of this; the shm middleware and the simulator's world bus refuse with a clear
  error (`require_shared_memory`) instead of crashing on an import.

`RIO_HOST_FALLBACK=1` makes Linux take the portable paths (temporary files, polled liveness, hashed
short names, the marker registry), so CI on Linux exercises the code macOS runs. What was verified
only that way is listed in docs/platforms.md.
"""

from __future__ import annotations

import hashlib
import os
import platform
import signal
import sys
import tempfile
import threading
import time
from typing import Any

from rio.errors import ConfigError

try:  # POSIX shared memory: CPython's own binding (also what multiprocessing.shared_memory uses)
    import _posixshmem
except ImportError:  # Windows
    _posixshmem = None

try:
    import fcntl
except ImportError:  # Windows
    fcntl = None  # type: ignore[assignment]

#: Take the portable paths even on Linux (set RIO_HOST_FALLBACK=1; read once, at import).
FALLBACK = os.environ.get("RIO_HOST_FALLBACK", "") not in ("", "0") or sys.platform != "linux"
WINDOWS = os.name == "nt"
#: macOS's limit on a POSIX shared-memory name, leading slash included (PSHMNAMLEN is 31).
_SHM_NAME_MAX = 31


def describe() -> str:
    forced = " (portable fallbacks forced)" if FALLBACK and sys.platform == "linux" else ""
    return f"{platform.system()} {platform.machine()}, Python {platform.python_version()}{forced}"


def _sleep0() -> None:
    time.sleep(0)  # Windows: a zero sleep yields the time slice


#: Give the CPU to another runnable thread or process (sched_yield where it exists).
yield_cpu = getattr(os, "sched_yield", None) or _sleep0


# -- anonymous shared memory and process liveness ------------------------------------------------------
def shm_dir() -> str | None:
    """Where temporary files backed by memory live (/dev/shm on Linux; the temp dir elsewhere)."""
    return "/dev/shm" if not FALLBACK and os.path.isdir("/dev/shm") else None


def anonymous_memory(name: str, size: int) -> int:
    """A descriptor of `size` bytes of memory that other processes can map once handed the descriptor,
    and that the kernel frees with the last descriptor (nothing to clean up after a crash)."""
    if not FALLBACK and hasattr(os, "memfd_create"):
        fd = os.memfd_create(name)  # close-on-exec by default
    else:
        fd, path = tempfile.mkstemp(prefix=f"{name}-", dir=shm_dir())
        os.unlink(path)
    os.ftruncate(fd, size)
    return fd


class _PidFd:
    """Linux: a pidfd, readable once the process has exited (zombie or reaped)."""

    def __init__(self, pid: int):
        self.fd = os.pidfd_open(pid)

    def fileno(self) -> int:
        return self.fd

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1


class _KqueueExit:
    """macOS/BSD: a kqueue with a NOTE_EXIT filter on the process, readable once it has exited."""

    def __init__(self, pid: int):
        import select as select_module

        select: Any = select_module  # kqueue exists on macOS/BSD only (mypy checks with Linux stubs)
        self.kq = select.kqueue()
        ev = select.kevent(pid, filter=select.KQ_FILTER_PROC, flags=select.KQ_EV_ADD | select.KQ_EV_ONESHOT,
                           fflags=select.KQ_NOTE_EXIT)
        try:
            self.kq.control([ev], 0, 0)
        except OSError:
            self.kq.close()
            raise

    def fileno(self) -> int:
        return self.kq.fileno()

    def close(self) -> None:
        self.kq.close()


def process_exit_watch(pid: int) -> Any | None:
    """Something `select` reports readable once `pid` has exited (a pidfd on Linux, a kqueue exit
    filter on macOS), or None where there is none: then poll `pid_alive`."""
    import select

    try:
        if not FALLBACK and hasattr(os, "pidfd_open"):
            return _PidFd(pid)
        if hasattr(select, "kqueue"):
            return _KqueueExit(pid)
    except OSError:  # already gone, or not ours to watch
        return None
    return None


def process_state(pid: int) -> str | None:
    """The kernel's one-letter state of process `pid` ("R", "S", "T" stopped, "Z" zombie, ...), from /proc
    (Linux only); None where it cannot tell (no /proc, no such process)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return None


def _zombie(pid: int) -> bool:
    """An exited child not yet reaped still answers kill(pid, 0); /proc tells (Linux only)."""
    return process_state(pid) == "Z"


def _windows_pid_alive(pid: int) -> bool:
    """Windows has no signal 0 (`os.kill(pid, 0)` there *terminates* the process): ask for its exit code."""
    import ctypes

    kernel32 = ctypes.WinDLL("kernel32", use_last_error=True)  # type: ignore[attr-defined]
    handle = kernel32.OpenProcess(0x1000, False, pid)  # PROCESS_QUERY_LIMITED_INFORMATION
    if not handle:
        return bool(ctypes.get_last_error() == 5)  # type: ignore[attr-defined]  # ERROR_ACCESS_DENIED: not ours
    try:
        code = ctypes.c_ulong()
        return bool(kernel32.GetExitCodeProcess(handle, ctypes.byref(code))) and code.value == 259  # STILL_ACTIVE
    finally:
        kernel32.CloseHandle(handle)


def pid_alive(pid: int) -> bool:
    if pid <= 0:
        return False
    if WINDOWS:
        return _windows_pid_alive(pid)
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process
        return True
    return not _zombie(pid)


def pid_namespace() -> str:
    """An id of this process's pid namespace ("" where there is none: macOS, Windows). Two processes
    that share /dev/shm need not share pids (a container run with `--ipc=host`): a pid recorded by the
    other namespace says nothing about liveness here, so sweepers leave its runs alone."""
    if sys.platform != "linux":
        return ""
    try:
        return str(os.stat("/proc/self/ns/pid").st_ino)
    except OSError:
        return ""


def exit_with_parent(parent_pid: int) -> None:
    """SIGTERM this process once `parent_pid`, the process that started it, is gone: a helper process (a
    node, an emulator) must never outlive a parent killed before it could clean up; an orphan keeps its
    ports and shared memory, and the next run finds them taken. Linux: the kernel's PR_SET_PDEATHSIG (it
    fires when the parent's *thread* that started us ends: start helpers from a thread that outlives
    them). Elsewhere: a daemon thread looks every half second."""

    def terminate() -> None:
        os.kill(os.getpid(), signal.SIGTERM)

    if not FALLBACK:
        try:
            import ctypes

            ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass
        else:
            if os.getppid() != parent_pid:  # it died before the prctl
                terminate()
            return

    def watch() -> None:
        while os.getppid() == parent_pid and pid_alive(parent_pid):  # Windows never re-parents
            time.sleep(0.5)
        terminate()

    threading.Thread(target=watch, name="rio-exit-with-parent", daemon=True).start()


# -- file locks -----------------------------------------------------------------------------------------
def _msvcrt() -> Any:
    import importlib

    return importlib.import_module("msvcrt")  # Windows only


def try_lock(fd: int) -> bool:
    """Take an exclusive lock on an open file without waiting; False when another process holds it.
    The kernel drops the lock when its holder dies (flock; msvcrt's region lock on Windows)."""
    try:
        if fcntl is not None:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        else:
            msvcrt = _msvcrt()
            msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
    except OSError:
        return False
    return True


class FileLock:
    """Cross-process lock on a file descriptor, plus a thread lock because threads sharing one
    descriptor do not exclude each other under flock."""

    def __init__(self, fd: int):
        self.fd = fd
        self._tlock = threading.Lock()

    def reopen(self, fd: int) -> None:
        """In a forked child: flock belongs to the open file, which the child shares with its parent,
        so the two would not exclude each other. Use a descriptor of the child's own (and a fresh
        thread lock: another thread may have held the old one at the moment of the fork)."""
        self.fd = fd
        self._tlock = threading.Lock()

    def __enter__(self) -> None:
        self._tlock.acquire()
        if fcntl is not None:
            fcntl.flock(self.fd, fcntl.LOCK_EX)
        else:
            msvcrt = _msvcrt()
            msvcrt.locking(self.fd, msvcrt.LK_LOCK, 1)

    def __exit__(self, *exc: Any) -> None:
        if fcntl is not None:
            fcntl.flock(self.fd, fcntl.LOCK_UN)
        else:
            msvcrt = _msvcrt()
            msvcrt.locking(self.fd, msvcrt.LK_UNLCK, 1)
        self._tlock.release()


# -- named POSIX shared memory --------------------------------------------------------------------------
def has_shared_memory() -> bool:
    return _posixshmem is not None


def require_shared_memory(what: str) -> None:
    """Refuse, naming the alternatives, where there is no POSIX shared memory (Windows)."""
    if not has_shared_memory():
        raise ConfigError(f"{what} needs POSIX shared memory (Linux or macOS); on Windows use the thread, zmq "
                          "or zenoh middleware, or run RIO inside WSL2 (see docs/platforms.md)")


def _os_name(name: str) -> str:
    """The object's name as the OS sees it: the name itself on Linux; where names are short (macOS,
    and the forced fallback), a digest of it when it is too long."""
    if FALLBACK and len(name) + 1 > _SHM_NAME_MAX:
        return "/rio" + hashlib.blake2b(name.encode(), digest_size=13).hexdigest()
    return "/" + name


#: The longest AF_UNIX socket path (`sun_path`: 108 bytes on Linux, 104 on macOS and the BSDs, less the NUL).
_SUN_PATH_MAX = 107 if sys.platform.startswith("linux") else 103
#: What a run directory adds to its base: `/rio-<run id>-<8>` and a node's `/<run id>_<8>.sock`.
_RUN_PATH_ROOM = 48


def run_dir_base() -> str:
    """Where `ServerManager` makes its run directories (sockets, FIFOs, the station manifest) and where
    `rio top` looks for them: the temp directory, unless its path leaves no room for the AF_UNIX socket
    paths a run keeps there (a deep `TMPDIR`: a socket bind then fails with "AF_UNIX path too long"), in
    which case `/tmp`."""
    base = tempfile.gettempdir()
    if len(base) + _RUN_PATH_ROOM <= _SUN_PATH_MAX or not os.path.isdir("/tmp"):
        return base
    return "/tmp"


def registry_dir() -> str:
    """Marker files of the shared-memory objects this user's RIO processes created (fallback only)."""
    path = os.path.join(tempfile.gettempdir(), f"rio-shm-{os.getuid() if hasattr(os, 'getuid') else 0}")
    os.makedirs(path, mode=0o700, exist_ok=True)
    return path


def shm_create(name: str, size: int) -> int:
    """Create object `name` (FileExistsError if it exists) of `size` bytes; returns a descriptor."""
    require_shared_memory("shared memory")
    fd = _posixshmem.shm_open(_os_name(name), os.O_CREAT | os.O_EXCL | os.O_RDWR, mode=0o600)
    try:
        os.ftruncate(fd, size)
        if FALLBACK:
            open(os.path.join(registry_dir(), name), "w").close()
    except BaseException:
        os.close(fd)
        shm_unlink(name)
        raise
    return fd


def shm_open(name: str, readonly: bool = False) -> int:
    """A descriptor of existing object `name` (FileNotFoundError if there is none)."""
    require_shared_memory("shared memory")
    return _posixshmem.shm_open(_os_name(name), os.O_RDONLY if readonly else os.O_RDWR, mode=0o600)


def shm_unlink(name: str) -> bool:
    """Remove object `name`; False if it was already gone."""
    require_shared_memory("shared memory")
    if FALLBACK:
        try:
            os.unlink(os.path.join(registry_dir(), name))
        except FileNotFoundError:
            pass
    try:
        _posixshmem.shm_unlink(_os_name(name))
    except FileNotFoundError:
        return False
    return True


def shm_list(prefix: str = "") -> set[str]:
    """Names of existing objects starting with `prefix`: /dev/shm on Linux, the marker registry elsewhere."""
    if _posixshmem is None:
        return set()
    if FALLBACK:
        where = registry_dir()
    elif os.path.isdir("/dev/shm"):
        where = "/dev/shm"
    else:
        return set()
    return {n for n in os.listdir(where) if n.startswith(prefix)}


def shm_stat(name: str) -> os.stat_result | None:
    """The entry `shm_list` lists for object `name` (its /dev/shm file, or its registry marker under the
    fallback): its owner and when it was made, which sweepers use to leave others' and young objects
    alone. None if it is gone."""
    where = registry_dir() if FALLBACK else "/dev/shm"
    try:
        return os.stat(os.path.join(where, name))
    except OSError:
        return None


def shm_size(name: str) -> int:
    """Bytes held by object `name` (0 if it is gone or unreadable): what a sweep reports freeing."""
    try:
        fd = shm_open(name, readonly=True)
    except (OSError, ConfigError):
        return 0
    try:
        return os.fstat(fd).st_size
    finally:
        os.close(fd)


# -- signals --------------------------------------------------------------------------------------------
def catch_stop_signals(handler: Any) -> dict[int, Any]:
    """Install `handler` for SIGINT, SIGTERM and SIGHUP (the ones this platform has: Windows has no
    SIGHUP); returns the handlers they had, for `restore_signals`. Main thread only."""
    old = {}
    for name in ("SIGINT", "SIGTERM", "SIGHUP"):
        sig = getattr(signal, name, None)
        if sig is not None:
            old[sig] = signal.signal(sig, handler)
    return old


def restore_signals(old: dict[int, Any]) -> None:
    """Put back the handlers `catch_stop_signals` returned."""
    for sig, handler in old.items():
        signal.signal(sig, handler if handler is not None else signal.SIG_DFL)


class DeferredSignals:
    """`with DeferredSignals():` holds SIGINT, SIGTERM and SIGHUP back while the block runs, then delivers
    the first one received, to whatever handler was in place before (KeyboardInterrupt, a `StopSignals`
    flag, the default termination). For cleanup that must finish: `uv run` forwards the terminal's
    Ctrl+C, so a program gets SIGINT twice, and a second KeyboardInterrupt in the middle of releasing
    shared memory leaks what is left. Only the main thread can take signals; elsewhere this does nothing."""

    def __init__(self, notice: str = ""):
        self.notice = notice
        self.pending: int | None = None
        self._old: dict[int, Any] = {}

    def _hold(self, signum: int, _frame: Any) -> None:
        if self.pending is None and self.notice:
            try:  # os.write, not print: a handler that prints while the main thread prints raises
                os.write(2, f"{signal.Signals(signum).name}: {self.notice}\n".encode())
            except OSError:
                pass
        if self.pending is None:
            self.pending = signum

    def __enter__(self) -> DeferredSignals:
        if threading.current_thread() is threading.main_thread():
            self._old = catch_stop_signals(self._hold)
        return self

    def __exit__(self, *exc: Any) -> None:
        restore_signals(self._old)
        self._old = {}
        if self.pending is not None:
            signum, self.pending = self.pending, None
            signal.raise_signal(signum)  # now handled as if it had arrived just after the block


__all__ = ["FALLBACK", "WINDOWS", "describe", "yield_cpu", "shm_dir", "run_dir_base", "anonymous_memory",
           "process_exit_watch",
           "pid_alive", "exit_with_parent", "try_lock", "FileLock", "has_shared_memory", "require_shared_memory",
           "shm_create", "shm_open", "shm_unlink", "shm_list", "shm_stat", "shm_size", "registry_dir", "pid_namespace",
           "DeferredSignals", "catch_stop_signals", "restore_signals"]
