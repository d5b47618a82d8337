"""`cameras.stream`: network streams (RTSP, HTTP MJPEG), GStreamer pipelines, video files and image
sequences through OpenCV, plus the synthetic `test:pattern`."""
