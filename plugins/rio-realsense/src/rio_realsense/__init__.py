"""RIO plugin for Intel RealSense cameras: see README.md. Importing it imports no camera SDK."""
