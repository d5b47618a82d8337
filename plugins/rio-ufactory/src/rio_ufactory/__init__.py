"""rio-ufactory plugin."""
