"""rio-cameras: camera drivers in RIO's camera contract (`rio.interfaces.CameraNode`), one folder per
device family: `uvc` (USB webcams through OpenCV's V4L2 backend), `stream` (RTSP / HTTP MJPEG /
GStreamer / video files through OpenCV), `oak` (Luxonis, depthai), `zed` (Stereolabs, pyzed),
`record3d` (an iPhone over USB). The shared machinery (a grab thread that reopens lost devices, the
pinhole guess, resizing) sits at the top level. See README.md."""
