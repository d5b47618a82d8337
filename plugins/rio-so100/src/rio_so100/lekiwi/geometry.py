"""LeKiwi's base as its wheels and servos see it: ids, names, mounting and the servo's speed units.

The three omni wheels sit 120 degrees apart at `BASE_RADIUS` from the center: the left wheel in front at
+60 degrees, the back wheel at 180, the right wheel in front at -60 (x forward, y left). Each pushes the
body along its tangent (mount angle + 90 degrees) when its servo turns forward, which gives the push
directions of `rio.control.omni.OmniKinematics`: 150, -90 and 30 degrees. Figures from LeRobot's LeKiwi
(wheel ids 7-9, 5 cm wheels, 12.5 cm base radius, at most 3000 steps/s per wheel); the math is core's.
"""

from __future__ import annotations

import math

WHEEL_IDS = (7, 8, 9)
WHEELS = ("left_wheel", "back_wheel", "right_wheel")
#: Direction each wheel pushes the body (deg from x toward y), in WHEELS order.
PUSH_ANGLES_DEG = (150.0, -90.0, 30.0)
WHEEL_RADIUS = 0.05   # m
BASE_RADIUS = 0.125   # m, wheel contact to center
#: The fastest wheel speed LeKiwi commands (steps/s); a faster twist is scaled down as a whole.
MAX_WHEEL_STEPS = 3000
#: Encoder steps per radian of wheel rotation (4096 per turn).
STEPS_PER_RAD = 4096 / (2 * math.pi)
