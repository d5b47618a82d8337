"""teleop.avp: Apple Vision Pro native hand tracking, through avp-stream and its visionOS app (Tracking
Streamer), over gRPC on the local network.

`node.VisionProTeleop` is the driver (a hand tracker: wrist poses, hand keypoints, pinch gripper);
`sdk` fits avp-stream's `VisionProStreamer` to a node (quiet, stoppable, no HTTP info server);
`loader` imports avp-stream without letting it take the process's signals; `emulator` an emulated
app speaking the real protocol (tests, and trying it without a headset); `specs` what the plugin
registers. Only `node.open()`, `sdk`, and the emulator import avp_stream. See docs/avp.md.
"""
