"""Conformance kits: the tests a third-party implementation of a RIO interface must pass, shipped
with rio-core so a plugin runs exactly the cases the built-in implementations run.

Middleware kit (`rio.conformance.middleware`): a base test class whose cases start echo and image
nodes (`rio.testing`) through the public API only (serve / connect / ServerManager) and check
latest-state reads, request delivery from concurrent clients, API calls with large arrays, errors
named by node, rejected requests, death of a node process within a second, and that stopping,
crashing or failing to start leaves no child process and no /dev/shm entry behind. In a test file
of the plugin:

    from rio.conformance.middleware import MiddlewareConformance

    class TestMyMiddleware(MiddlewareConformance):
        middleware = "mymw"  # a registered middleware name, or a Middleware instance

Or without a file, against any registered middleware: `pytest --rio-middleware mymw`. The option
comes from the pytest plugin `rio.conformance.pytest_plugin`, which pytest loads by itself (entry
point `pytest11: rio`) wherever rio-core is installed.

Driver kit (`rio.conformance.drivers`): one base class per driver kind (`ArmConformance`,
`GripperConformance`, `HandConformance`, `HumanoidConformance`, `CameraConformance`,
`TeleopConformance`, `SensorConformance`) checking the kind's contract: keys, shapes and dtypes, SI
units, NaN for what is not measured, limit clipping, maximum step, the watchdog, disable/enable,
`close()` after an error and start-up failures named by node. A plugin names its driver, its config
and its emulator:

    from rio.conformance.drivers import ArmConformance

    class TestAcmeArm(ArmConformance):
        driver = "acme.arm"
        config = {"port": "emulator"}

or, without a file, `pytest --rio-driver acme.arm --rio-driver-config '{"port": "/dev/ttyUSB0"}'`.
The kits live in `driver_base` (every driver), `commandable` (joints, grippers) and `sensing`
(cameras, teleop), with the ticking and fault-injection helpers in `driving`.

Helpers (`rio.conformance.process`): `child_pids()`, `shm_entries()` and `assert_no_shm_left()`,
to check in a plugin's own tests that nothing is left behind.

Importing this package is cheap (no numpy); the kit modules import what they test.
"""
