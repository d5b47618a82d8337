"""Benchmarks shipped with rio-core (run them with `rio bench ...` or the scripts in bench/).

- `middleware_latency`: node API round-trip latency on every middleware against the raw transport
  underneath it, and an image-stream test (the RIO paper's method).
- `raw_transports`: the bare transports (threading.Condition, pipe + shared memory, pyzmq, zenoh,
  portal) as echo ping-pongs.
"""
