"""Kits of the kinds that only publish: cameras, teleop devices and wrench (force/torque) sensors. See
`rio.conformance.drivers`."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
import pytest

from rio.conformance.driver_base import BOOL, BUTTONS, FLOAT, SI, DriverConformance, KeySpec
from rio.conformance.driving import expect, fmt
from rio.interfaces import CameraNode, TeleopNode, WrenchNode
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




TARE = "tare: after tare() an unchanged load reads zero (within the kit's tare_tol_n / tare_tol_nm)"


class WrenchConformance(DriverConformance):
    """The wrench contract (`rio.interfaces.WrenchNode`): force (3) N and torque (3) N m in the sensor frame,
    finite and within a cell's range, and `tare()` zeroing an unchanged load. Registered as a `sensor`."""

    kind: ClassVar[str] = "wrench"
    registered_as: ClassVar[str | None] = "sensor"
    node_base: ClassVar[type[Node]] = WrenchNode
    read_hook: ClassVar[str] = "read_wrench"
    #: Largest plausible |force| (N) and |torque| (N m) component: beyond them, counts were not converted.
    max_force_n: ClassVar[float] = 5000.0
    max_torque_nm: ClassVar[float] = 500.0
    #: What a tared, unchanged load may still read (the cell's noise): N, N m (mean over the samples).
    tare_tol_n: ClassVar[float] = 0.5
    tare_tol_nm: ClassVar[float] = 0.05

    def kind_keys(self, node: Node) -> KeySpec:
        return {"force": ((3,), FLOAT), "torque": ((3,), FLOAT), "timestamp": ((), FLOAT)}

    def measured_keys(self, node: Node) -> tuple[str, ...]:
        return ("force", "torque")

    def check_units(self, node: Any, sample: Mapping[str, Any], i: int) -> None:
        f, t = (np.asarray(sample[k], dtype=np.float64) for k in ("force", "torque"))
        expect(np.abs(f).max() <= self.max_force_n, self.kind, SI,
               f"sample {i}: force {fmt(f)} beyond +-{self.max_force_n:g} N: raw counts, not newtons?")
        expect(np.abs(t).max() <= self.max_torque_nm, self.kind, SI,
               f"sample {i}: torque {fmt(t)} beyond +-{self.max_torque_nm:g} N m: raw counts, or N mm?")

    def test_tare_zeroes_an_unchanged_load(self, driver_under_test, driver_fields):
        node: Any = self.make(driver_under_test, driver_fields)
        with lifecycle(node):
            self.loop(node).run(cycles=max(self.cycles, int(node.config.tare_samples)))
            bias = np.asarray(node.tare(), dtype=np.float64)
            expect(bias.shape == (6,), self.kind, TARE, f"tare() returned {fmt(bias)}, not the 6 bias values")
            loop = self.loop(node)
            loop.run(cycles=self.cycles)
        expect(loop.samples, self.kind, TARE, f"no sample in {loop.ticks} ticks after tare()")
        f = np.mean([np.asarray(s["force"], dtype=np.float64) for s in loop.samples], axis=0)
        t = np.mean([np.asarray(s["torque"], dtype=np.float64) for s in loop.samples], axis=0)
        expect(np.abs(f).max() <= self.tare_tol_n and np.abs(t).max() <= self.tare_tol_nm, self.kind, TARE,
               f"after tare() the mean reading is force {fmt(f)} N, torque {fmt(t)} N m (bias {fmt(bias)})")
