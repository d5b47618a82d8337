"""`so100.follower` / `so101.follower`: the arm joints of an SO-arm on its Feetech bus."""
