"""PolicyNode: hosts a `Policy` in its own node (its own process under shm/zmq/zenoh/portal), so the
model is served through the middleware itself and no separate policy server is needed.

The hot path uses the two channels every node already has, never a remote call:

- observations in: the request queue. One request is one observation (`ObsLayout` record). Camera
  frames go by reference where the middleware shares rings (`shm`, `thread`): the request carries each
  frame's timestamp and the node reads the frame from its camera's ring (`rio.policy.frames`); on network
  middlewares they are copied into the request. `frames="copy"` forces copying everywhere.
- chunks out: the ring buffer. Each inference publishes one fixed-size record (`actions` padded to
  `max_horizon` rows, `horizon`, the observation's `t_obs` and `seq`, and the times the request was
  received and inference ran). The client reads it locally, without blocking.

A request whose frame the camera has already overwritten is answered with an empty chunk (horizon 0),
never with another frame; `AsyncInference` counts it and asks again.

The node is request-driven (`loop = "req"`): it sleeps until an observation arrives, so it costs
nothing between inferences. An exception inside the policy ends the node, which every client then
reports as `NodeDiedError` naming it.

A policy registered by a plugin is a `PolicyNode` subclass naming its `policy_class`. Without an
`observation` layout (a station file's policy component started by `make_station`, e.g. under
`rio teleop`), the node is inert: it loads nothing and refuses requests; `rio deploy` supplies the
layout from the station's first observation.
"""

from __future__ import annotations

import logging
from typing import Any, ClassVar, Literal, cast

import numpy as np
from pydantic import Field, create_model

from rio.errors import FrameGone, InvalidRequest
from rio.policy.base import ActionChunk, Policy, PolicyMetadata
from rio.policy.frames import CameraFrames
from rio.policy.obs_layout import ObsLayout
from rio.runtime.node import Node, NodeConfig, client_side, remote
from rio.schema import Observation

log = logging.getLogger("rio.policy")


class PolicyNodeConfig(NodeConfig):
    """What the node adds to its policy's `Config`."""

    observation: dict[str, Any] | None = Field(None, description="the station's observation layout "
                                                                 "(`rio deploy` fills it in)")
    frames: Literal["auto", "copy"] = Field(
        "auto", description="camera frames: 'auto' reads them from the camera nodes' rings where the middleware "
                            "shares them (shm, thread) and copies them into each request elsewhere; 'copy' always "
                            "copies (a policy node on another machine than the cameras)")


def node_config(policy_class: type[Policy], name: str) -> type[NodeConfig]:
    """The policy's own config model plus the node's fields: what a station's policy table validates against."""
    # a model class made at run time: typed as what it is, a node config (it subclasses PolicyNodeConfig)
    return cast("type[NodeConfig]", create_model(name, __base__=(policy_class.Config, PolicyNodeConfig)))


def observation_layout(config: Any) -> ObsLayout | None:
    """The layout of the observations a policy node takes, from its config (None: none given yet)."""
    if not config.observation:
        return None
    layout = ObsLayout.from_dict(config.observation)
    return layout.copying() if config.frames == "copy" else layout


class PolicyNode(Node):
    policy_class: ClassVar[type[Policy]] = Policy
    #: The policy's config plus `PolicyNodeConfig`; made for each subclass from its `policy_class`.
    Config: type[NodeConfig] = node_config(Policy, "PolicyNodeConfig")
    loop = "req"
    buffer_capacity: ClassVar[int] = 4
    #: The client keeps at most one observation in flight; two slots leave room for a retry.
    request_capacity: ClassVar[int] = 2

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "Config" not in cls.__dict__:
            cls.Config = node_config(cls.policy_class, f"{cls.__name__}Config")

    #: The record a client fills in place for each request (thread, shm), made on the first request.
    _request_rec: np.ndarray | None = None

    def setup(self) -> None:
        # the node's own fields, except those the policy declares too (`rate_hz`: the node loop's rate, which a
        # request-driven node does not use, and a policy's action rate, which it does)
        own = set(PolicyNodeConfig.model_fields) - set(self.policy_class.Config.model_fields)
        fields = self.config.model_dump(exclude=own)
        self.policy = self.policy_class(fields)
        self.layout = observation_layout(self.config)
        cfg = self.policy.config
        dim = self.layout.action_dim if self.layout is not None else 1
        self.example_data: dict[str, Any] = {
            "actions": np.zeros((cfg.max_horizon, dim)), "horizon": 0, "seq": np.int64(-1), "t_obs": 0.0, "dt": 0.0,
            "offset": 0.0, "t_recv": 0.0, "t_start": 0.0, "t_end": 0.0}
        self.example_request = self.layout.example_request() if self.layout is not None else {"seq": np.int64(0)}
        self._meta: PolicyMetadata | None = None
        self._frames: CameraFrames | None = None
        #: Requests answered with an empty chunk because a referenced frame was gone (server side).
        self.frame_misses = 0

    # -- server side --------------------------------------------------------------------------------
    def open(self) -> None:
        if self.layout is None:
            return
        if self.layout.sources:
            self._frames = CameraFrames(self.layout.sources)
        self.policy.load(self.layout)
        meta = self.policy._meta()
        if meta.action_dim != self.layout.action_dim:
            raise ValueError(f"policy '{self.policy.name}' acts in {meta.action_dim} dimensions, the station "
                             f"in {self.layout.action_dim} (set action_indices)")
        self._meta = meta

    def close(self) -> None:
        if self._frames is not None:
            self._frames.close()
            self._frames = None
        if self.layout is not None:
            self.policy.close()

    def read_state(self) -> dict[str, Any]:
        """Only the first, empty sample (seq -1); chunks are published by `handle_request`."""
        return dict(self.example_data)

    def handle_request(self, request: dict[str, Any]) -> None:
        from rio import clock

        t_recv = clock.now()
        if self.layout is None:
            raise InvalidRequest(self.name, None, "this policy node has no observation layout (start it with "
                                                  "`rio deploy`, or pass observation=ObsLayout.of(obs).to_dict())")
        if request["reset"]:  # before the frames are read: a run's first request resets even if it misses
            self.policy.reset()
        if self._frames is not None:
            self._frames.forget()  # what an earlier request took (one that failed half-way) is not this one's
        try:
            obs, instruction, t_obs, seq, _ = self.layout.decode(request, self._frames)
            chunk = self.policy(obs, instruction, t_obs, seq, t_recv=t_recv)
            if self._frames is not None:  # the frames were read in place: were they still those frames?
                self._frames.verify()
        except FrameGone as e:
            self.frame_misses += 1
            log.warning("policy node '%s': request %d not run: %s (%d so far)", self.name, int(request["seq"]), e,
                        self.frame_misses)
            self.publish(self._record(self._missed(request, t_recv)))
            return
        self.publish(self._record(chunk))

    def _missed(self, request: dict[str, Any], t_recv: float) -> ActionChunk:
        """The answer to a request whose frames were gone: no actions (horizon 0), so the client asks again."""
        meta = self.policy._meta()
        empty = np.zeros((0, self.example_data["actions"].shape[1]))
        return ActionChunk(empty, float(request["t_obs"]), meta.dt, meta.offset, int(request["seq"]), t_recv,
                           t_recv, t_recv)

    def _record(self, chunk: ActionChunk) -> dict[str, Any]:
        actions = np.zeros_like(self.example_data["actions"])
        actions[: chunk.horizon] = chunk.actions
        return {"actions": actions, "horizon": chunk.horizon, "seq": np.int64(chunk.seq), "t_obs": chunk.t_obs,
                "dt": chunk.dt, "offset": chunk.offset, "t_recv": chunk.t_recv, "t_start": chunk.t_start,
                "t_end": chunk.t_end}

    @remote
    def metadata(self) -> dict[str, Any]:
        """The loaded policy's `PolicyMetadata` as a dict (a remote call; not on the hot path)."""
        if self._meta is None:
            raise InvalidRequest(self.name, None, "no policy is loaded (the node has no observation layout)")
        return self._meta.to_dict()

    # -- client side (never blocks) -----------------------------------------------------------------
    @client_side
    def request(self, obs: Observation, instruction: str | None, t_obs: float, seq: int, reset: bool = False) -> None:
        """Enqueue one observation for inference; its chunk appears in `latest_chunk()` with this `seq`.
        Where the queue takes whole records (thread, shm) one reused record is filled in place."""
        from rio import clock

        if "layout" not in self.__dict__:  # a client: made without setup(), from the same config
            self.layout = observation_layout(self.config)
        if self.layout is None:
            raise InvalidRequest(self.name, None, "this policy node has no observation layout (pass "
                                                  "observation=ObsLayout.of(obs).to_dict())")
        values = self.layout.encode(obs, instruction, t_obs, seq, reset)
        put_record = getattr(self.request_queue, "put_record", None)
        if put_record is None:  # a network sender: it encodes the dict itself
            self.send_request(values)
            return
        if self._request_rec is None:
            self._request_rec = np.zeros((), dtype=self.request_queue.layout.dtype)
        rec = self.layout.pack(self._request_rec, values, owner=self.name)
        rec["timestamp"] = clock.now()
        put_record(rec)

    @client_side
    def chunk_count(self) -> int:
        """Samples published so far (1 before the first chunk): a cheap 'anything new?' check."""
        return self.ring_buffer.count

    @client_side
    def latest_chunk(self) -> ActionChunk | None:
        """The newest chunk (None before the first). Horizon 0: the request's frames were gone (not run)."""
        s = self.ring_buffer.get()
        if int(s["seq"]) < 0:
            return None
        h = int(s["horizon"])
        return ActionChunk(np.array(s["actions"][:h]), float(s["t_obs"]), float(s["dt"]), float(s["offset"]),
                           int(s["seq"]), float(s["t_recv"]), float(s["t_start"]), float(s["t_end"]))
