"""rio-franka plugin."""
