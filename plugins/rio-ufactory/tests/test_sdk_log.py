"""The xArm SDK's prints on a healthy run (`[motion_enable], xArm is not ready to move`) go into the log, not the
terminal; `rio --debug` (RIO_DEBUG=1) shows them on stderr, marked as the SDK's."""

from __future__ import annotations

import logging

import pytest

pytest.importorskip("xarm")

from rio_ufactory.sdk_log import capture_sdk_output  # noqa: E402

LINE = "[motion_enable], xArm is not ready to move"


def _sdk_prints():
    from xarm.core.utils.log import logger, origin_logger

    origin_logger.info(LINE)
    logger.warning("sdk warning")


def test_sdk_prints_are_logged_at_debug_not_printed(capfd, caplog, monkeypatch):
    monkeypatch.delenv("RIO_DEBUG", raising=False)
    capture_sdk_output()
    capture_sdk_output()  # idempotent: one record per print
    with caplog.at_level(logging.DEBUG, logger="rio_ufactory.sdk"):
        _sdk_prints()
    out, err = capfd.readouterr()
    assert LINE not in out and LINE not in err
    assert [r.getMessage() for r in caplog.records if r.name == "rio_ufactory.sdk"] == [LINE, "sdk warning"]
    assert all(r.levelno == logging.DEBUG for r in caplog.records if r.name == "rio_ufactory.sdk")


def test_rio_debug_shows_them_on_stderr(capfd, monkeypatch):
    monkeypatch.setenv("RIO_DEBUG", "1")
    capture_sdk_output()
    _sdk_prints()
    out, err = capfd.readouterr()
    assert f"[xArm SDK] {LINE}" in err and LINE not in out
