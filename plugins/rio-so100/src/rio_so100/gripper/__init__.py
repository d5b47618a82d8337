"""`so100.gripper` / `so101.gripper`: an SO-arm's jaw servo as a gripper node of its own."""
