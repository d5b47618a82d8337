"""An export that fails, fails clean, in every format: a full disk, a file-size limit, an interrupt or too
little free space ends in one error line (never a traceback, never a native crash: the HDF5 writer used to
die with SIGSEGV after ENOSPC) and leaves no partial output; what is refused is refused before anything is
written: an output inside the dataset it reads, episodes the dataset does not have (a huge range at once)."""

from __future__ import annotations

import os
import resource
import shutil
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from rio.cli import main as rio_main
from rio.recording import Dataset
from rio.recording import recorder as recorder_mod
from rio.recording.format import ExportError, export_dataset, get_format
from rio.recording.synthetic import record_synthetic

#: (format, options) of every exporter, both HDF5 layouts
FORMATS = [("zarr", []), ("hdf5", []), ("hdf5", ["-o", "style=robomimic"]), ("lerobot", [])]
IDS = ["zarr", "hdf5-aloha", "hdf5-robomimic", "lerobot"]


@pytest.fixture(scope="module")
def bigger(tmp_path_factory) -> Path:
    """Large enough that every format writes a file of more than 16 KB."""
    root = tmp_path_factory.mktemp("bigger") / "ds"
    record_synthetic(str(root), episodes=2, steps=30, size=(96, 128), cameras=("front",), depth=True)
    return root


def _one_line(stderr: str) -> str:
    assert "Traceback" not in stderr, stderr
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), stderr
    return " ".join(lines[0].split())


def _limited(limit: int):
    """preexec_fn: files may not grow past `limit` bytes; a write past it fails with EFBIG (SIGXFSZ, which
    would kill the process instead, ignored): a full disk for one file, without root or a mount."""

    def apply() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return apply


@pytest.mark.parametrize(("fmt", "opts"), FORMATS, ids=IDS)
def test_a_write_that_fails_ends_in_one_line_and_leaves_nothing(bigger, tmp_path, fmt, opts):
    out = tmp_path / "out"
    p = subprocess.run([sys.executable, "-m", "rio", "export", str(bigger), str(out), "-f", fmt, *opts],
                       capture_output=True, text=True, preexec_fn=_limited(16 << 10), timeout=240,
                       env={**os.environ, "COLUMNS": "250"})
    assert p.returncode == 1, (p.returncode, p.stderr[-3000:])  # not 139 / -11: no native crash
    assert "File too large [EFBIG]" in _one_line(p.stderr)
    assert not out.exists()


def test_a_full_tmpfs_refuses_to_start_and_a_real_enospc_ends_clean(bigger, tmp_path):
    """On a real 64 KB tmpfs (in a mount namespace of its own, so nothing outlives the test): the CLI
    refuses to start for lack of free space; through the library, with the margin set to zero, each format
    runs into ENOSPC itself and ends in one ExportError, the tmpfs left empty."""
    if os.geteuid() != 0 or shutil.which("unshare") is None or shutil.which("mount") is None or \
            subprocess.run(["unshare", "-m", "true"], capture_output=True).returncode != 0:
        pytest.skip("a real full disk needs root and a mount namespace (unshare -m, mount -t tmpfs); "
                    "test_a_write_that_fails_ends_in_one_line_and_leaves_nothing covers the same paths with "
                    "RLIMIT_FSIZE")
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    script = textwrap.dedent(f"""
        import subprocess, sys, os
        from pathlib import Path
        from rio.recording import Dataset
        from rio.recording.format import export_dataset, get_format
        p = subprocess.run([sys.executable, "-m", "rio", "export", {str(bigger)!r}, {str(mnt / "cli")!r}, "-f", "zarr"],
                           capture_output=True, text=True)
        print("CLI", p.returncode, repr(p.stderr))
        for fmt, opts in (("zarr", {{}}), ("hdf5", {{}}), ("hdf5", {{"style": "robomimic"}}), ("lerobot", {{}})):
            try:
                export_dataset(get_format(fmt, opts), Dataset({str(bigger)!r}), Path({str(mnt)!r}) / "out",
                               min_free_bytes=0)
                print(fmt, "FINISHED")
            except Exception as e:
                print(fmt, type(e).__name__, str(e).replace(chr(10), " "))
            print(fmt, "LEFT", os.listdir({str(mnt)!r}))
    """)
    p = subprocess.run(["unshare", "-m", "sh", "-c", f"mount -t tmpfs -o size=64k tmpfs {mnt} && exec "
                        f"{sys.executable} -c \"$0\"", script], capture_output=True, text=True, timeout=400,
                       env={**os.environ, "COLUMNS": "250"})
    assert p.returncode == 0, p.stdout + p.stderr
    lines = p.stdout.splitlines()
    cli = next(line for line in lines if line.startswith("CLI "))
    assert cli.startswith("CLI 1 ") and "not starting the export" in cli and "free on its disk" in cli, cli
    for fmt in ("zarr", "hdf5", "lerobot"):
        said = [line for line in lines if line.startswith(f"{fmt} ") and "LEFT" not in line]
        assert said and all("ExportError" in s and "No space left on device [ENOSPC]" in s for s in said), lines
        assert all(line.endswith("[]") for line in lines if line.startswith(f"{fmt} LEFT")), lines


@pytest.mark.parametrize(("fmt", "opts"), FORMATS, ids=IDS)
def test_free_space_running_out_during_an_export_stops_it_clean(bigger, tmp_path, monkeypatch, fmt, opts):
    checks = {"n": 0}

    def free(path):
        checks["n"] += 1
        return 10**12 if checks["n"] == 1 else 1 << 20  # plenty at the start, 1 MB at the first progress

    monkeypatch.setattr(recorder_mod, "free_bytes", free)
    monkeypatch.setattr("rio.recording.format._SPACE_EVERY_S", 0.0)
    out = tmp_path / "out"
    with pytest.raises(ExportError, match=r"export stopped: 1\.0 MB free on its disk.*partial output was removed"):
        export_dataset(get_format(fmt, dict(o.split("=") for o in opts[1::2])), Dataset(bigger), out)
    assert checks["n"] >= 2 and not out.exists()


@pytest.mark.parametrize(("fmt", "opts", "nth"), [("zarr", [], 2), ("hdf5", [], 2), ("lerobot", [], 3)],
                         ids=["zarr", "hdf5", "lerobot"])
def test_ctrl_c_during_an_export_removes_its_partial_output(bigger, tmp_path, monkeypatch, capsys, fmt, opts, nth):
    import rio_datasets.common as common

    out = tmp_path / "out"
    seen = {"n": 0, "out_existed": False}

    def interrupting(ep):
        seen["n"] += 1
        if seen["n"] == nth:  # the second episode (LeRobot reads the first once more for its features)
            seen["out_existed"] = out.exists()
            raise KeyboardInterrupt
        return common.lowdim(ep)

    monkeypatch.setattr(f"rio_datasets.{fmt}_format.lowdim", interrupting)
    assert rio_main(["export", str(bigger), str(out), "-f", fmt, *opts]) == 130
    assert capsys.readouterr().err.strip() == "error: interrupted"
    assert seen["out_existed"] and not out.exists()


@pytest.mark.parametrize("where", ["sub", ".", "link/sub", "episode_000000"])
def test_an_output_inside_the_dataset_is_refused(bigger, tmp_path, capsys, where):
    ds = tmp_path / "ds"
    shutil.copytree(bigger, ds)
    (tmp_path / "link").symlink_to(ds)
    before = sorted(str(p.relative_to(ds)) for p in ds.rglob("*"))
    out = tmp_path / where if where.startswith("link") else ds / where
    assert rio_main(["export", str(ds), str(out), "-f", "hdf5"]) == 1
    assert "inside the dataset it would be exported from" in _one_line(capsys.readouterr().err)
    assert sorted(str(p.relative_to(ds)) for p in ds.rglob("*")) == before


@pytest.mark.timeout(120)  # before: '0-99999999999' was expanded into a list, one index at a time (a hang)
@pytest.mark.parametrize(("episodes", "said"), [
    ("0-99999999999", "no episode 2"), ("99999999999", "no episode 99999999999"), ("0,1,7-9", "no episode 7"),
    ("1-1,0-3", "no episode 2"), ("9" * 40, "is not an episode index")])
def test_episodes_the_dataset_does_not_have_are_refused_before_any_work(bigger, tmp_path, capsys, episodes, said):
    out = tmp_path / "out"
    assert rio_main(["export", str(bigger), str(out), "-f", "zarr", "--episodes", episodes]) == 1
    line = _one_line(capsys.readouterr().err)
    assert said in line and ("its episodes: 0-1" in line or "not an episode index" in line), line
    assert not out.exists()


def test_episode_ranges_keep_the_order_given_once_each(bigger, tmp_path):
    from rio.cli.export_cmd import choose_episodes, parse_episodes

    assert choose_episodes("1,0-1", parse_episodes("1,0-1"), [0, 1]) == [1, 0]
    assert choose_episodes("0-3", parse_episodes("0-3"), [3, 0, 2, 1]) == [0, 1, 2, 3]
