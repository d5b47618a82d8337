"""rio-teleop: teleoperation devices (SpaceMouse, gamepads, GELLO leader arms, WebXR headsets and phones,
Apple Vision Pro hand tracking)."""
