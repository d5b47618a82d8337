"""Importing avp-stream without letting it take over the process's signals or its stderr.

`import avp_stream` (any of its modules: the package imports its streamer) registers SIGINT and SIGTERM
handlers that print and raise KeyboardInterrupt, when imported in the main thread. A RIO node process
ignores SIGINT (Ctrl+C belongs to the parent) and ends gracefully on SIGTERM (`rio.runtime.manager`), so the
handlers in place before the import are put back.

gRPC's core logs connection events at INFO to stderr ("Got goaway ..." when the app stops streaming);
unless the user chose a level (GRPC_VERBOSITY), errors only, set before gRPC is first imported.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from types import ModuleType

from rio.errors import RioError

INSTALL = "pip install 'rio-teleop[avp]'"
#: The port avp-stream dials (`VisionProStreamer.stream()` connects to f"{ip}:12345"; the app serves it).
GRPC_PORT = 12345


def import_avp(module: str = "avp_stream.streamer") -> ModuleType:
    """Import `module` of avp-stream, keeping this process's SIGINT/SIGTERM handlers; a missing package
    (or one of its own dependencies) is a RioError naming the install command."""
    if "grpc" not in sys.modules:
        os.environ.setdefault("GRPC_VERBOSITY", "ERROR")
    main = threading.current_thread() is threading.main_thread()
    saved = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)} if main else {}
    try:
        __import__(module)  # through builtins.__import__, as an `import` statement (rio.testing.block_import)
        return sys.modules[module]
    except ImportError as e:
        raise RioError(f"teleop.avp needs avp-stream ({e}): {INSTALL}") from None
    finally:
        for sig, handler in saved.items():
            if signal.getsignal(sig) is not handler and handler is not None:
                signal.signal(sig, handler)
