"""`cameras.zed`: Stereolabs ZED cameras (ZED 2/2i, ZED Mini, ZED X) through pyzed, which ships with the
ZED SDK (not on PyPI)."""
