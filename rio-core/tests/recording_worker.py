"""Records episodes forever at ~60 Hz with two small cameras (one with depth), printing
'kept N' after each kept episode and 'step N' every 10 steps, until it is killed.
Used by test_recording_crash.py, which SIGKILLs it at chosen moments."""

import sys
import time

import numpy as np

from rio import clock
from rio.recording import Recorder
from rio.recording.synthetic import SyntheticCamera, synthetic_step


def main(root: str, steps_per_episode: int) -> None:
    cam = SyntheticCamera(48, 64, noise=1.0)
    with Recorder(root, fps=60, video={"gop_s": 0.25}) as rec:
        ep = 0
        while True:
            rate = clock.Rate(60)
            for i in range(steps_per_episode):
                t = clock.now()
                step = synthetic_step(i, t, {"front": (cam.frame(t), t)})
                step.observation.cameras["front"].depth = cam.depth(t) + np.float32(0.001 * (i % 7))
                rec.add(step)
                if i % 10 == 0:
                    print(f"step {ep} {i}", flush=True)
                rate.sleep()
            meta = rec.keep()
            print(f"kept {meta['index']}", flush=True)
            ep += 1
            time.sleep(0.01)


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]))
