"""RIO observation-to-action latency benchmark (rio.benchmarks.obs_to_action). See --help."""

from rio.benchmarks.obs_to_action import main

if __name__ == "__main__":  # spawned children re-import this file as __mp_main__: run nothing then
    raise SystemExit(main())
