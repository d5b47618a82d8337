"""RIO middleware latency benchmark; same as `rio bench middleware`. See --help."""

from rio.benchmarks.middleware_latency import main

if __name__ == "__main__":  # spawned children re-import this file as __mp_main__: run nothing then
    raise SystemExit(main())
