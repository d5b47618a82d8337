"""A dataset recorded before Core v3 named the gripper's opening `obs.gripper_position`: it exports as one
recorded today does (the field is `gripper_width`, its values as recorded), and what is imported back reads
the same. The reading side (open, replay, merge) is tested in rio-core's test_old_dataset_names.py."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from rio.recording import Dataset
from rio.recording.format import get_format
from rio.testing import with_old_field_names


@pytest.fixture
def old(native, tmp_path):
    out = tmp_path / "old"
    shutil.copytree(native, out)
    with_old_field_names(out)
    fields = {f[0] for p in out.glob("*/steps.json") for f in json.loads(p.read_text())["fields"]}
    assert "obs.gripper_position" in fields and "obs.gripper_width" not in fields
    return out


def test_an_old_dataset_exports_and_imports_under_the_new_name(native, old, tmp_path):
    zarr = pytest.importorskip("zarr")
    f = get_format("zarr")
    f.export(Dataset(old), tmp_path / "old.zarr")
    f.export(Dataset(native), tmp_path / "new.zarr")
    was, now = (zarr.open_group(str(tmp_path / f"{name}.zarr"), mode="r") for name in ("old", "new"))
    assert "gripper_width" in was["data"] and "gripper_position" not in was["data"]
    np.testing.assert_array_equal(was["data/gripper_width"][:], now["data/gripper_width"][:])
    f.import_(tmp_path / "old.zarr", tmp_path / "back")
    for e0, e1 in zip(Dataset(native), Dataset(tmp_path / "back"), strict=True):
        np.testing.assert_array_equal(e0.column("obs.gripper_width"), e1.column("obs.gripper_width"))


def test_an_export_made_before_the_rename_imports_under_the_new_name(native, tmp_path):
    """A zarr export from before Core v3 has `data/gripper_position`: importing it keeps the opening."""
    zarr = pytest.importorskip("zarr")
    f = get_format("zarr")
    f.export(Dataset(native), tmp_path / "old.zarr")
    data = zarr.open_group(str(tmp_path / "old.zarr"), mode="r+")["data"]
    width = data["gripper_width"]
    data.create_array("gripper_position", data=width[:], chunks=width.chunks)
    del data["gripper_width"]
    f.import_(tmp_path / "old.zarr", tmp_path / "back")
    for e0, e1 in zip(Dataset(native), Dataset(tmp_path / "back"), strict=True):
        np.testing.assert_array_equal(e0.column("obs.gripper_width"), e1.column("obs.gripper_width"))
