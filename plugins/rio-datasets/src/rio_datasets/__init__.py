"""rio-datasets: export and import RIO's native datasets as LeRobotDataset v3, Zarr replay
buffers (Diffusion Policy / UMI layout) and HDF5 (ALOHA or robomimic layout), registered through
the `rio_dataset_formats` hook so `rio export DATASET --format NAME OUT` finds them."""

__version__ = "0.1.0"
