"""The xArm SDK's own prints, captured: on a healthy run it prints lines that read like faults
(`[motion_enable], xArm is not ready to move` while the driver enables the arm, as it should). Its two loggers
(`origin.print`, the SDK's `Logger`) write straight to stdout; `capture_sdk_output()` takes their stream handlers
away and passes every record on to the `rio_ufactory.sdk` logger at debug level, so they are in the log but not
on the terminal; under `rio --debug` (RIO_DEBUG=1, which node processes inherit) they are shown, on stderr,
marked as the SDK's."""

from __future__ import annotations

import logging
import sys

log = logging.getLogger("rio_ufactory.sdk")

#: The SDK's loggers that print to stdout.
SDK_LOGGERS = ("origin.print", "xarm.core.utils.log")


class _ToRio(logging.Handler):
    def emit(self, record: logging.LogRecord) -> None:
        from rio.errors import debug

        msg = record.getMessage()
        if debug():
            print(f"[xArm SDK] {msg}", file=sys.stderr, flush=True)
        else:
            log.debug("%s", msg)


def capture_sdk_output() -> None:
    """Route the SDK's prints into the log (idempotent; call it before making an `XArmAPI`)."""
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):  # importing the SDK prints its version (`SDK_VERSION: 1.18.4`)
        import xarm.core.utils.log as sdk
        import xarm.wrapper  # noqa: F401
    for line in out.getvalue().splitlines():
        _ToRio().emit(logging.makeLogRecord({"msg": line}))

    for name in SDK_LOGGERS:
        lg = logging.getLogger(name) if name != "xarm.core.utils.log" else sdk.logger
        for h in list(lg.handlers):
            if isinstance(h, logging.StreamHandler) and not isinstance(h, _ToRio):
                lg.removeHandler(h)
        if not any(isinstance(h, _ToRio) for h in lg.handlers):
            lg.addHandler(_ToRio())
        lg.propagate = False
