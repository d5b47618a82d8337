"""What the OpenCV drivers (`cameras.uvc`, `cameras.stream`) share: opening a `cv2.VideoCapture`, reading
it as a grab-thread source, the node base class, and the synthetic test pattern."""
