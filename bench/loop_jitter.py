"""RIO control-loop wake-up jitter benchmark (rio.benchmarks.loop_jitter). See --help."""

from rio.benchmarks.loop_jitter import main

if __name__ == "__main__":  # spawned children re-import this file as __mp_main__: run nothing then
    raise SystemExit(main())
