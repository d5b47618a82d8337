"""Kits of the kinds that only publish: cameras and teleop devices. See `rio.conformance.drivers`."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
import pytest

from rio.conformance.driver_base import BOOL, BUTTONS, FLOAT, SI, DriverConformance, KeySpec
from rio.conformance.driving import expect, fmt
from rio.interfaces import CameraNode, TeleopNode
from rio.runtime.node import Node
from rio.schema import DISTORTION_MODELS
from rio.testing import lifecycle


class CameraConformance(DriverConformance):
    """The camera contract (`rio.interfaces.CameraNode`): rgb uint8 (H, W, 3) as configured, pinhole
    intrinsics, and with `depth = true` uint16 depth with its scale in meters."""

    kind: ClassVar[str] = "camera"
    node_base: ClassVar[type[Node]] = CameraNode
    cycles: ClassVar[int] = 10

    def kind_keys(self, node: Any) -> KeySpec:
        h, w = node.height, node.width
        keys: KeySpec = {"rgb": ((h, w, 3), np.dtype(np.uint8)), "intrinsics": ((3, 3), FLOAT)}
        if node.has_depth:
            keys.update(depth=((h, w), np.dtype(np.uint16)), depth_scale=((), FLOAT))
        return keys

    def measured_keys(self, node: Node) -> tuple[str, ...]:
        return ("intrinsics",)

    def check_units(self, node: Any, sample: Mapping[str, Any], i: int) -> None:
        h, w = node.height, node.width
        rgb = np.asarray(sample["rgb"])
        expect(rgb.dtype == np.uint8 and rgb.shape == (h, w, 3), self.kind, SI,
               f"sample {i}: rgb is {rgb.dtype} {rgb.shape}; the config asks for uint8 ({h}, {w}, 3)")
        k = np.asarray(sample["intrinsics"], dtype=np.float64)
        expect(k.shape == (3, 3) and np.isfinite(k).all() and k[0, 0] > 0 and k[1, 1] > 0
               and np.allclose(k[2], [0, 0, 1]), self.kind, SI,
               f"sample {i}: intrinsics {fmt(k)} is not a pinhole matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] "
               "with fx, fy > 0 (pixels)")
        if node.has_depth:
            depth = np.asarray(sample["depth"])
            expect(depth.dtype == np.uint16 and depth.shape == (h, w), self.kind, SI,
                   f"sample {i}: depth is {depth.dtype} {depth.shape}; expected uint16 ({h}, {w})")
            scale = float(sample["depth_scale"])
            expect(0.0 < scale <= 0.1, self.kind, SI,
                   f"sample {i}: depth_scale {scale} is not meters per depth unit in (0, 0.1]")
        if "distortion" in node.example_data:  # declared (CameraNode.declare_distortion)
            model, coeffs = sample.get("distortion_model"), np.asarray(sample.get("distortion"), dtype=np.float64)
            expect(model is not None and 0 <= int(model) < len(DISTORTION_MODELS), self.kind, SI,
                   f"sample {i}: distortion_model {model} is not an index into rio.schema.DISTORTION_MODELS")
            expect(coeffs.shape == (5,) and bool(np.isfinite(coeffs).all()), self.kind, SI,
                   f"sample {i}: distortion {fmt(coeffs)} is not 5 finite coefficients")


class TeleopConformance(DriverConformance):
    """The teleop contract (`rio.interfaces.TeleopNode`): twist (6: m/s, rad/s), gripper 0..1, buttons;
    a leader arm (`leader_arm = True`) also joint_pos / joint_vel in rad."""

    kind: ClassVar[str] = "teleop"
    node_base: ClassVar[type[Node]] = TeleopNode
    #: Largest plausible |twist| component (m/s, rad/s).
    max_twist: ClassVar[float] = 10.0
    max_joint_abs: ClassVar[float] = 2 * math.pi

    def kind_keys(self, node: Any) -> KeySpec:
        keys: KeySpec = {"twist": ((6,), FLOAT), "gripper": ((), FLOAT),
                         "buttons": ((node.config.buttons,), BOOL)}
        if node.leader_arm:
            keys.update(joint_pos=(None, FLOAT), joint_vel=(None, FLOAT))
        return keys

    def measured_keys(self, node: Any) -> tuple[str, ...]:
        return ("twist", "gripper") + (("joint_pos",) if node.leader_arm else ())

    def test_buttons_follow_the_config(self, driver_under_test, driver_fields):
        if "buttons" in driver_under_test.preset:
            pytest.skip(f"{driver_under_test.label} fixes `buttons` to {driver_under_test.preset['buttons']}")
        n = int(self.make(driver_under_test, driver_fields).config.buttons) + 1
        node = self.make(driver_under_test, driver_fields, buttons=n)
        with lifecycle(node):
            loop = self.loop(node)
            loop.run(cycles=5)
        for i, s in enumerate(loop.samples):
            b = np.asarray(s["buttons"])
            expect(b.shape == (n,) and b.dtype == np.bool_, self.kind, BUTTONS,
                   f"with buttons = {n}, sample {i} has buttons {b.dtype} {b.shape}")

    def check_units(self, node: Any, sample: Mapping[str, Any], i: int) -> None:
        twist = np.asarray(sample["twist"], dtype=np.float64)
        expect(twist.shape == (6,) and np.abs(twist).max() <= self.max_twist, self.kind, SI,
               f"sample {i}: twist {fmt(twist)} is not 6 velocities in m/s and rad/s (|v| <= {self.max_twist})")
        g = float(sample["gripper"])
        expect(0.0 <= g <= 1.0, self.kind, SI, f"sample {i}: gripper {g} outside [0 closed, 1 open]")
        b = np.asarray(sample["buttons"])
        expect(b.dtype == np.bool_, self.kind, SI, f"sample {i}: buttons are {b.dtype}, not bool")
        if node.leader_arm:
            q = np.asarray(sample["joint_pos"], dtype=np.float64)
            expect(np.all(np.abs(q) <= self.max_joint_abs + 1e-6), self.kind, SI,
                   f"sample {i}: leader joint_pos {fmt(q)} beyond +-{self.max_joint_abs:.3f} rad: degrees?")


