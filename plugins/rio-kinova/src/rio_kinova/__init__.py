"""rio-kinova plugin."""
