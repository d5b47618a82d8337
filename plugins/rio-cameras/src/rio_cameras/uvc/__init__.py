"""`cameras.uvc`: USB (UVC) webcams through OpenCV's V4L2 backend (AVFoundation / Media Foundation on
macOS / Windows): selecting the device, negotiating its mode, listing what is connected."""
