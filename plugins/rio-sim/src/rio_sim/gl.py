"""Offscreen OpenGL for the sim cameras: which backend MuJoCo uses and what to do without one.

MuJoCo picks its backend from `MUJOCO_GL`. On Linux rio-sim defaults it to `egl`, which renders
headless (no X server, works over SSH and in CI) on any GPU driver or on the CPU through Mesa
(llvmpipe); Debian/Ubuntu packages: libegl1, libopengl0, libgl1-mesa-dri (libegl-mesa0, libgbm1).
Where libEGL is not installed (a bare Debian) it leaves MuJoCo's default instead: with `MUJOCO_GL=egl`
and no libEGL, `import mujoco` itself raises (PyOpenGL's EGL platform finds no library), which would
take the physics down with the cameras. macOS uses `cgl`; Windows `glfw` (wgl). Set `MUJOCO_GL`
yourself to override (e.g. `glfw` to use your display).

`gl_problem()` tries to create a tiny context once per process and says why it failed, so a
camera can fall back (or refuse, if configured to) with a message that names the fix.
"""

from __future__ import annotations

import os
import sys
import threading

from rio.machine.system_needs import SystemNeed

#: Creating or freeing OpenGL contexts from several threads at once can deadlock inside EGL/Mesa
#: (seen with two cameras opening together under the thread middleware): hold this around both.
CONTEXT_LOCK = threading.Lock()

#: The Debian packages of headless rendering on the CPU: EGL (with Mesa's EGL vendor library) and Mesa's
#: software rasterizer (llvmpipe: `dri/swrast_dri.so`, which Mesa's EGL opens).
GL_PACKAGES = "libegl1 libopengl0 libgl1-mesa-dri"

_FIX = ("MuJoCo renders through CGL on macOS (no install needed); MUJOCO_GL=glfw uses a window's context instead"
        if sys.platform == "darwin" else
        f"install the EGL/Mesa libraries (Debian/Ubuntu: apt-get install {GL_PACKAGES}), "
        "or set MUJOCO_GL to a backend this machine has (egl, glfw with a display, osmesa)")


#: The EGL library PyOpenGL loads for MuJoCo's `egl` backend (Debian package libegl1).
LIBEGL = SystemNeed("libegl1", library="libEGL.so.1", purpose="MuJoCo's egl backend")


def default_backend() -> None:
    """Set MUJOCO_GL to `egl` before MuJoCo's renderer is imported, on Linux where libEGL is installed,
    unless the user chose a backend."""
    if sys.platform.startswith("linux") and "MUJOCO_GL" not in os.environ and LIBEGL.problem() is None:
        os.environ["MUJOCO_GL"] = "egl"


_BACKENDS = {"egl": "mujoco.egl", "osmesa": "mujoco.osmesa", "glfw": "mujoco.glfw"}


def ensure_backend() -> None:
    """Make MuJoCo's renderer use the backend `MUJOCO_GL` names now.

    MuJoCo picks its backend once, when `mujoco` is first imported. A process that imported it
    before rio-sim set the default (a script or test that used `rio.kinematics` first) would be left
    on GLFW, which fails without a display; switch such a process to the backend asked for."""
    import mujoco

    try:
        from mujoco.rendering.classic import gl_context
    except ImportError:  # older MuJoCo layout
        from mujoco import gl_context
    wanted = os.environ.get("MUJOCO_GL", "").lower().strip()
    loaded = getattr(gl_context, "_MUJOCO_GL", wanted)
    if not sys.platform.startswith("linux") or wanted == loaded or wanted not in _BACKENDS:
        return
    import importlib

    cls = importlib.import_module(_BACKENDS[wanted]).GLContext
    gl_context.GLContext = cls
    gl_context._MUJOCO_GL = wanted
    mujoco.GLContext = cls


_PROBLEM: str | None | bool = False  # False: not probed yet


def gl_problem() -> str | None:
    """None when offscreen rendering works here, else one line saying why and how to fix it."""
    global _PROBLEM
    with CONTEXT_LOCK:
        if _PROBLEM is not False:
            return _PROBLEM
        try:
            import mujoco

            ensure_backend()
            ctx = mujoco.GLContext(16, 16)
            ctx.make_current()
            try:
                # MuJoCo's render context, as a camera makes it: it fails (FatalError) where no context is
                # current, which GLFW without a display only warns about (the default backend without libEGL)
                empty = mujoco.MjModel.from_xml_string("<mujoco/>")
                mujoco.MjrContext(empty, mujoco.mjtFontScale.mjFONTSCALE_100).free()
            finally:
                ctx.free()
            _PROBLEM = None
        except Exception as e:  # ImportError from PyOpenGL, mujoco.FatalError, RuntimeError, ...
            backend = os.environ.get("MUJOCO_GL", "default")
            _PROBLEM = f"no OpenGL for offscreen rendering (MUJOCO_GL={backend}: {type(e).__name__}: {e}); {_FIX}"
    return _PROBLEM


def _gl_missing() -> str | None:
    """`gl_problem()` without its advice: the skip reason names the packages itself."""
    problem = gl_problem()
    return None if problem is None else problem.removesuffix(f"; {_FIX}")


#: What a test that checks rendered pixels needs (`rio.testing.skip_tests_without(OFFSCREEN_GL)`): a bare
#: Debian has no EGL, and the cameras then publish placeholder frames.
OFFSCREEN_GL = SystemNeed(GL_PACKAGES, probe=_gl_missing, purpose="offscreen rendering (MuJoCo on EGL)")
