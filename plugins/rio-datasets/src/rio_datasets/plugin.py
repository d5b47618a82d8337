"""Entry point (`rio` group): registers the formats. Cheap: nothing heavy is imported here."""

from rio.hookspecs import hookimpl
from rio.specs import Spec


@hookimpl
def rio_dataset_formats() -> list[Spec]:
    p = "rio_datasets"
    return [
        Spec("lerobot", "dataset_format", f"{p}.lerobot_format:LeRobotFormat",
             "LeRobotDataset v3 (parquet + one mp4 per camera), loadable by lerobot; export and import",
             config=f"{p}.lerobot_format:LeRobotOptions"),
        Spec("zarr", "dataset_format", f"{p}.zarr_format:ZarrFormat",
             "Zarr replay buffer (Diffusion Policy / UMI: data/*, meta/episode_ends); export and import",
             config=f"{p}.zarr_format:ZarrOptions"),
        Spec("hdf5", "dataset_format", f"{p}.hdf5_format:Hdf5Format",
             "HDF5, ALOHA (one file per episode) or robomimic (data/demo_N) layout; export and import",
             config=f"{p}.hdf5_format:Hdf5Options"),
    ]
