"""The arm contract: a joint-space device (`JointNode`) that also takes end-effector targets and reports
the end-effector pose.

End-effector targets reach the hardware one of two ways:
- the driver streams poses itself (`write_pose(pose)` defined, e.g. a vendor's Cartesian servo mode):
  a `PoseCommander` (workspace box, `max_tool_step_m` / `max_tool_step_rad` per cycle, slerp, watchdog)
  feeds it;

- otherwise the kind solves IK on the driver's `robot_description()` (shared IK, `rio.kinematics`),
  warm-started from the last joint target, and the joint commander takes it from there.

With `force_limit` set in the station, a driver's `read_wrench()` (the external wrench at the tool: a wrist
force/torque cell it reads, or its controller's estimate), or with `wrench_source` a separate wrench node's
samples (`rio.interfaces.wrench_peer`), is checked every cycle before the commander steps;
over the limit the arm holds where it is (`rio.interfaces.force`, `rio.control.force_limit`), and every
sample carries `ext_wrench` (6: N, N m, zeroed at enable) and `force_holds` (how many times it held; with
`wrench_source`, also `source_holds`: how many of those because the source was silent or gone).

`eef_pose` is what the driver measured when it reports one; else forward kinematics of the measured
joints on `robot_description()`; else NaN. So an arm that ships a model can be teleoperated, recorded
and deployed in end-effector space without any Cartesian code of its own (docs/drivers.md).

Every arm's tool is bounded in task space, whoever commands it (a policy, a replay, a teleop device): a
workspace box (the station's `workspace`, else the model's reach, `rio.kinematics.reach`: computed by the
solver, or without one the published reach in the model table) and a Cartesian
speed limit (`max_tool_speed_m_s`), in the commanders (`rio.control.workspace`): end-effector targets are
clipped into the box; joint targets too, through forward kinematics, where the arm has a model. An arm
without a model bounds its joint targets by its joint limits and `max_step_rad` only. Samples carry
`clipped`, the number of targets the box has cut since the node started (the run's summary counts them).

The IK solver is optional (`rio-core[ik]`, which a vendor plugin re-exports as its own `[ik]` extra): an
arm whose controller does the Cartesian control needs none. A driver that has Cartesian control but was
told to use RIO's IK instead (its `eef_control = "ik"`) refuses to open without the solver, naming the
extra that installs it; any other arm without one reports NaN for `eef_pose` unless its hardware measures it.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from pydantic import Field, model_validator

from rio import clock
from rio.control.commander import PoseCommander
from rio.control.workspace import ToolBound, Workspace
from rio.errors import InvalidRequest
from rio.interfaces.force import ForceLimitConfig, WrenchSource
from rio.interfaces.joints import JointConfig, JointNode, as_vector, t_target
from rio.interfaces.wrench_peer import PeerWrench
from rio.runtime.node import client_side, remote

if TYPE_CHECKING:
    from rio.interfaces.model_table import ModelTable

log = logging.getLogger("rio.interfaces")

#: Request `mode` values of an arm.
JOINT, EEF = 0, 1

IDENTITY_POSE = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
_NAN_POSE = np.full(7, np.nan)


class ArmNode(JointNode):
    class Config(JointConfig):
        renamed = {"max_step_m": "max_tool_step_m", "max_step_eef_rad": "max_tool_step_rad"}
        workspace: tuple[tuple[float, float, float], tuple[float, float, float]] | None = Field(
            None, description="[[x, y, z] lower, [x, y, z] upper] (m, base frame): the box the tool stays in, "
                              "for end-effector targets and, where the arm has a model, joint targets; default: "
                              "the model's reach (every pose its joints reach, plus 5%; without an IK solver: "
                              "the published reach of the model table, plus 25%), else unbounded")
        max_tool_speed_m_s: float = Field(1.0, gt=0, description="largest tool speed (m/s) of every move the "
                                                                 "commander makes: end-effector goals, and joint "
                                                                 "goals where the arm has a model")
        max_tool_step_m: float = Field(0.005, gt=0, description="largest tool travel per cycle (m), for drivers "
                                                                "streaming poses")
        max_tool_step_rad: float = Field(0.05, gt=0, description="largest tool rotation per cycle (rad), for "
                                                                 "drivers streaming poses")
        force_limit: ForceLimitConfig | None = Field(
            None, description="hold the arm where it is when the external wrench at the tool exceeds these "
                              "limits (needs a driver with a wrench source, read_wrench(), or wrench_source)")
        wrench_source: str | None = Field(
            None, description="the station's wrench sensor node (its role: 'ft_sensor') whose samples the force "
                              "limit checks, instead of the driver's read_wrench(); its silence holds the arm")

        @model_validator(mode="after")
        def _source_needs_a_limit(self) -> ArmNode.Config:
            if self.wrench_source is not None and self.force_limit is None:
                raise ValueError(f"wrench_source = '{self.wrench_source}' is set but force_limit is not: the source "
                                 "feeds the force limit (force_limit = {force_n = ...})")
            return self

    #: The vendor's table of arm models (`rio.interfaces.ModelTable`), for a driver serving a family of arms:
    #: joints, home, limits and robot description are then those of the station's `model`.
    models: ClassVar[ModelTable | None] = None

    # -- driver hooks (besides JointNode's) ---------------------------------------------------------
    def write_pose(self, eef_pose: np.ndarray) -> None:
        """Stream this cycle's end-effector goal. Define it only where the hardware has Cartesian control."""
        raise NotImplementedError

    def read_wrench(self) -> Any:
        """The external wrench at the tool now: 6 values, force (N) then torque (N m), as a wrist force/torque
        sensor or the controller's estimate gives it; None when there is no reading this cycle. Define it
        where the hardware has one: `force_limit` needs it."""
        raise NotImplementedError

    @remote
    def robot_description(self) -> dict[str, Any] | None:
        """The arm's kinematic model, or None:
        `{"format": "mjcf" | "urdf", "xml": <model text>, "frame": <tool frame>, "frame_type": "site" | "body"
        (MJCF), "joints": [<names, in this node's joint order>], "home": [<rad>] (optional)}`. Default: the
        model table's, if the driver has one."""
        if self.models is None:
            return None
        return self.models.describe(self.config.model, getattr(self.config, "tcp_offset", None))

    # -- from the model table, where the driver has one -----------------------------------------------
    def default_joint_names(self) -> list[str]:
        if self.models is None:
            return super().default_joint_names()
        return list(self.models.entry(self.config.model).joint_names)

    def default_home(self) -> Any:
        return None if self.models is None else [float(v) for v in self.models.entry(self.config.model).home]

    def hardware_limits(self) -> Any:
        if self.models is None:
            return None
        lim = np.asarray(self.models.entry(self.config.model).limits, dtype=np.float64)
        return lim[:, 0], lim[:, 1]

    # -- contract -----------------------------------------------------------------------------------
    @property
    def streams_poses(self) -> bool:
        return type(self).write_pose is not ArmNode.write_pose

    @property
    def needs_solver(self) -> bool:
        """Whether end-effector targets must go through RIO's IK although the driver can stream poses: its
        config chose IK over the controller's Cartesian control (`eef_control = "ik"`)."""
        return type(self).write_pose is not ArmNode.write_pose and not self.streams_poses

    def setup(self) -> None:
        super().setup()
        self.example_data = {**self.example_data, "eef_pose": IDENTITY_POSE.copy(), "clipped": np.int64(0)}
        self.example_request = {"mode": JOINT, **self.example_request, "eef_pose": IDENTITY_POSE.copy()}
        self.kinematics: Any = None
        self.workspace_box: Workspace | None = None
        self.poses: PoseCommander | None = None
        self.mode = JOINT
        self._eef = _NAN_POSE
        self.wrench: WrenchSource | None = None
        source, limit = self.config.wrench_source, self.config.force_limit
        if limit is not None:
            if source is None and type(self).read_wrench is ArmNode.read_wrench:
                raise ValueError(f"force_limit is set but {type(self).__name__} has no wrench source (read_wrench(), "
                                 "or a wrench sensor node named by wrench_source)")
            peer = None if source is None else PeerWrench(self, source, limit.source_timeout_s)
            self.wrench = WrenchSource(self, limit, peer)
            self.example_data.update(ext_wrench=np.zeros(6), force_holds=0)
            if peer is not None:
                self.example_data.update(source_holds=0)
        self._eef_clipped = 0  # end-effector targets clipped before IK
        self._no_solver: str | None = None  # why a robot description has no solver (its backend is missing)

    def opened(self) -> None:
        self.kinematics = self._load_kinematics()
        if self._no_solver is not None and self.needs_solver:
            raise ImportError(f"node '{self.name}': {self._no_solver}; end-effector targets through RIO's IK need "
                              "it (or let the controller do them: eef_control = \"native\")")
        self.workspace_box = self._workspace()
        super().opened()
        if self.streams_poses:
            ws = self.workspace_box
            step = min(self.config.max_tool_step_m, ws.max_step_m)
            self.poses = PoseCommander(ws.lower, ws.upper, step, self.config.max_tool_step_rad,
                                       self.config.watchdog_s, start=self._eef_of(self.read_joints()))
            self.poses.owner = f"node '{self.name}' (end-effector poses)"
        if self.wrench is not None:
            limit = self.wrench.config.limit()
            for commander in (self.commander, self.poses):
                if commander is not None:
                    commander.force_limit = limit

    def _workspace(self) -> Workspace:
        """The tool's box (the station's, else the model's reach, else unbounded) and its step per cycle (the
        Cartesian speed limit over one cycle)."""
        step = self.config.max_tool_speed_m_s / self.rate_hz
        if self.config.workspace is not None:
            lower, upper = self.config.workspace
            return Workspace(lower, upper, step)
        if self.kinematics is not None:
            from rio.kinematics.reach import reach_box

            desc_home = self.config.home if self.config.home is not None else self.default_home()
            ws = Workspace(*reach_box(self.kinematics, desc_home), step)
            log.info("node '%s': workspace from the model's reach: %s", self.name, ws.describe())
            return ws
        published = self.models.reach(self.config.model) if self.models is not None else None
        if published is not None:
            from rio.kinematics.reach import reach_box_from_table

            ws = Workspace(*reach_box_from_table(*published), step)
            log.info("node '%s': workspace from the published reach of model '%s' (%.3f m; no IK solver): %s",
                     self.name, self.config.model, published[0], ws.describe())
            return ws
        log.info("node '%s': no workspace box (no robot model, none in the station): end-effector targets are "
                 "bounded by the tool speed only, joint targets by the joint limits", self.name)
        return Workspace((-np.inf,) * 3, (np.inf,) * 3, step)

    def tool_bound(self) -> ToolBound | None:
        """Joint targets bounded in task space through the model's forward kinematics (None without one)."""
        if self.kinematics is None or self.workspace_box is None:
            return None
        return ToolBound(self.kinematics.fk, self.workspace_box)

    @property
    def clipped(self) -> int:
        """Targets the workspace box has cut since the node opened (joint, end-effector and before IK)."""
        n = self._eef_clipped + (self._commander.clipped if self._commander is not None else 0)
        return n + (self.poses.clipped if self.poses is not None else 0)

    def _load_kinematics(self) -> Any:
        desc = self.robot_description()
        if not desc:
            return None
        joints = list(desc.get("joints") or [])
        if joints != self.joint_list:
            raise ValueError(f"node '{self.name}': robot_description() joints {joints} differ from the node's "
                             f"joint_names {self.joint_list}")
        try:
            from rio.kinematics import solver_from_description

            return solver_from_description(desc, orientation_cost=1.0 if self.dof >= 6 else 0.1, damping=1e-4)
        except ImportError as e:
            self._no_solver = self._solver_missing(e)
            if self.streams_poses:  # the controller measures the pose and does the Cartesian control
                log.info("node '%s': %s: the controller's Cartesian control and measured pose are used", self.name,
                         self._no_solver)
            elif not self.needs_solver:
                log.warning("node '%s': %s: eef_pose is NaN unless the hardware measures it", self.name,
                            self._no_solver)
            return None

    def _solver_missing(self, e: ImportError) -> str:
        """"no IK solver for its robot model (No module named 'mujoco'): pip install '<extra>'", the extra
        being the plugin's own where its model table names one."""
        cause = e.__cause__ if isinstance(e.__cause__, ImportError) else e
        install = self.models.ik_install if self.models is not None else "pip install 'rio-core[ik]'"
        return f"no IK solver for its robot model ({cause}): {install}"

    def _eef_of(self, sample: Any) -> np.ndarray:
        pose = sample.get("eef_pose")
        if pose is not None and np.isfinite(pose).all():  # measured by the hardware
            return np.asarray(pose, dtype=np.float64)
        if self.kinematics is not None:
            return self.kinematics.fk(sample["joint_pos"])
        return _NAN_POSE

    def cycle(self) -> dict[str, Any]:
        """One tick at `rate_hz` (the runtime calls it): read the hardware, step the commander of the mode the
        arm is in (joint targets, or end-effector poses the driver streams), write the goal it allows."""
        sample = self.read_arm()
        if self.wrench is not None and self.enabled:
            self._guard(sample)
        if self.enabled and self.mode == EEF:
            assert self.poses is not None  # EEF mode is entered only where opened() made the pose commander
            self.write_pose(self.poses.step(clock.now()))
        elif self.enabled:
            self.write_joints(self.commander.step(clock.now()))
        else:
            self.write_disabled()
        return self.complete(sample)

    def _guard(self, sample: dict[str, Any]) -> None:
        """The force limit, before the commander of the arm's mode steps (it holds there when over)."""
        assert self.wrench is not None
        w, now = self.wrench.read(), clock.now()
        if self.mode == EEF and self.poses is not None:
            self.poses.guard(w, self._eef, now, self.wrench.fault, self.wrench.starting)
        else:
            self.commander.guard(w, sample["joint_pos"], now, self.wrench.fault, self.wrench.starting)

    def read_state(self) -> dict[str, Any]:
        """The arm now with the kind's keys: a read only, nothing is written (see `cycle()`)."""
        return self.complete(self.read_arm())

    def read_arm(self) -> dict[str, Any]:
        """`read_joints()` and `eef_pose`: measured, else forward kinematics of the joints, else NaN."""
        sample = dict(self.read_joints())
        sample["eef_pose"] = self._eef = self._eef_of(sample)
        return sample

    def complete(self, sample: dict[str, Any]) -> dict[str, Any]:
        sample = super().complete(sample)
        if self.wrench is not None:
            sample["ext_wrench"] = self.wrench.last
            sample["force_holds"] = self.commander.force_holds + (self.poses.force_holds if self.poses else 0)
            if self.wrench.peer is not None:
                sample["source_holds"] = self.commander.source_holds + (self.poses.source_holds if self.poses else 0)
        sample["clipped"] = self.clipped
        if self.mode == EEF and self.enabled:
            assert self.poses is not None  # EEF mode is entered only where opened() made the pose commander
            sample["holding"] = self.poses.holding
        elif self.mode == EEF:
            sample["holding"] = True
        return sample

    def handle_request(self, request: dict[str, Any]) -> None:
        if int(request["mode"]) == EEF:
            self.command_eef(np.asarray(request["eef_pose"]), float(request["t_cmd_target"]))
        else:
            self.command_joints(np.asarray(request["joint_pos"]), float(request["t_cmd_target"]))

    def command_joints(self, joint_pos: np.ndarray, t_cmd_target: float, single: bool = False) -> None:
        if self.mode == EEF and self.enabled:  # leave Cartesian streaming from where the arm is
            self.commander.reset(self.measured(), clock.now())
        super().command_joints(joint_pos, t_cmd_target, single)
        self.mode = JOINT

    def command_eef(self, eef_pose: np.ndarray, t_cmd_target: float) -> None:
        self.check_ready()
        if not self.enabled:
            raise InvalidRequest(self.name, "eef_pose", "the arm is disabled (call enable() first)")
        if np.linalg.norm(eef_pose[3:]) < 1e-9:
            raise InvalidRequest(self.name, "eef_pose", "the quaternion is zero")
        now = clock.now()
        if self.streams_poses:
            assert self.poses is not None  # made in opened() where the driver streams poses
            if self.mode != EEF:
                self.poses.reset(self._eef, now)
            self.poses.command(eef_pose, t_cmd_target, now)
            self.mode = EEF
            return
        if self.kinematics is None:
            if self._no_solver is not None:
                raise InvalidRequest(self.name, "eef_pose", f"{type(self).__name__} has no Cartesian control and "
                                                            f"{self._no_solver}")
            raise InvalidRequest(self.name, "eef_pose", f"{type(self).__name__} has no Cartesian control and no "
                                                        "robot_description() for IK: send joint targets")
        ws = self.workspace_box
        if ws is not None and ws.outside(eef_pose) > 0:  # clipped before IK chases it
            eef_pose = np.array(eef_pose, dtype=np.float64)
            eef_pose[:3] = ws.clip(eef_pose)
            self._eef_clipped += 1
        q = self.kinematics.solve(eef_pose, self.commander.target, max_iters=15).q
        self.command_joints(q, t_cmd_target)

    @remote
    def workspace(self) -> dict[str, Any]:
        """The box the tool stays in and its step per cycle, as enforced: {"lower": [x, y, z], "upper": [x, y,
        z] (m, base frame; inf where unbounded), "max_tool_step_m", "source": "station" | "model" (the reach
        computed on the robot model) | "table" (the model table's published reach) | "none"}."""
        ws = self.workspace_box
        if ws is None:
            raise InvalidRequest(self.name, None, "the arm is not open yet: it has no workspace")
        source = "station" if self.config.workspace is not None else "model" if self.kinematics is not None \
            else "table" if self.models is not None and self.models.reach(self.config.model) is not None \
            else "none"
        step = self.poses.max_step_m if self.poses is not None else ws.max_step_m
        return {"lower": ws.lower.tolist(), "upper": ws.upper.tolist(), "max_tool_step_m": step, "source": source}

    @remote
    def enable(self) -> bool:
        self.mode = JOINT
        enabled = super().enable()
        if self.wrench is not None:
            self.wrench.tare()  # holding still, nothing touched yet: the tool's own weight is the zero
        return enabled

    @remote
    def use_wrench_source(self, reference: dict[str, Any]) -> None:
        """Read the force limit's wrench from the node `reference` names (`client.reference` of the station's
        `wrench_source` node, `rio.runtime.peer`), through a client this arm's process connects. The station's
        `Env` calls it once every node is up; without it the arm holds (its limit has nothing to measure).
        Called again (the sensor restarted), it reconnects. Retakes the zero when the arm is enabled."""
        if self.wrench is None or self.wrench.peer is None:
            raise InvalidRequest(self.name, "wrench_source", "this arm names no wrench_source in its station")
        self.wrench.peer.connect(reference, clock.now())
        if self.enabled:
            self.wrench.tare()

    def closing(self) -> None:
        try:
            super().closing()
        finally:
            if self.wrench is not None and self.wrench.peer is not None:
                self.wrench.peer.close()

    @remote
    def hold(self) -> None:
        super().hold()
        if self.poses is not None:  # streaming poses: stop there too
            self.poses.hold(clock.now())

    # -- client side --------------------------------------------------------------------------------
    @client_side
    def move_joints(self, joint_pos: Any, t_cmd_target: float | None = None) -> None:
        """Joint target (rad), to be reached at `t_cmd_target`."""
        self.send_request(mode=JOINT, joint_pos=as_vector("joint_pos", joint_pos, self.dof),
                          eef_pose=IDENTITY_POSE, t_cmd_target=t_target(t_cmd_target))

    @client_side
    def move_eef(self, eef_pose: Any, t_cmd_target: float | None = None) -> None:
        """End-effector target `[x, y, z, qw, qx, qy, qz]` (m), to be reached at `t_cmd_target`."""
        self.send_request(mode=EEF, joint_pos=np.zeros(self.dof),
                          eef_pose=as_vector("eef_pose", eef_pose, 7), t_cmd_target=t_target(t_cmd_target))


ArmConfig = ArmNode.Config
