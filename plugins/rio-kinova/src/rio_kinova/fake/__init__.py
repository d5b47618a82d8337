"""The fake kortex backend: stand-ins for kortex's client objects, because kortex cannot run here (the
wheel is Kinova's own download, its wire format is proprietary, and no Gen3 is on the test machine).
See `fake.base` for what they do and what they leave out."""
