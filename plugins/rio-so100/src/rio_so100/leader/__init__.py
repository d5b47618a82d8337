"""`so100.leader` / `so101.leader`: a torque-off SO-arm moved by hand, as a teleop device."""
