"""`cameras.oak`: Luxonis OAK cameras (OAK-1, OAK-D, OAK-D Lite/Pro/W, PoE models) through depthai v3."""
