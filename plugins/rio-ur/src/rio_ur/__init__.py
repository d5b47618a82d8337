"""rio-ur plugin."""
