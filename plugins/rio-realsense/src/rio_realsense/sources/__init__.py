"""Where framesets come from: a connected camera (`device.py`) or a software camera (`software.py`),
behind one small interface (`base.py`) so the driver processes both with the same code."""
