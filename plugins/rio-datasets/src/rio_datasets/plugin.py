"""Entry point (`rio` group): registers the formats. Cheap: nothing heavy is imported here."""

from rio.plugins.hookspecs import hookimpl
from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec


@hookimpl
def rio_dataset_formats() -> list[Spec]:
    p = "rio_datasets"
    return [
        Spec("lerobot", "dataset_format", f"{p}.lerobot_format:LeRobotFormat",
             "LeRobotDataset v3 (parquet + one mp4 per camera), loadable by lerobot; export and import"),
        Spec("zarr", "dataset_format", f"{p}.zarr_format:ZarrFormat",
             "Zarr replay buffer (Diffusion Policy / UMI: data/*, meta/episode_ends); export and import"),
        Spec("hdf5", "dataset_format", f"{p}.hdf5_format:Hdf5Format",
             "HDF5, ALOHA (one file per episode) or robomimic (data/demo_N) layout; export and import"),
        Spec("rlds", "dataset_format", f"{p}.rlds_format:RldsFormat",
             "RLDS (Open X-Embodiment), TensorFlow Datasets' own writer; export (extra: rio-datasets[rlds])"),
    ]


@hookimpl
def rio_requirements() -> list[Requirement]:
    return [
        Requirement("pyarrow", "pip install pyarrow", "lerobot format: parquet tables"),
        Requirement("av", "pip install av", "lerobot format: one mp4 per camera (encode and decode)"),
        Requirement("zarr", "pip install 'zarr>=3.1'", "zarr format (zarr 3 needs Python 3.11+)"),
        Requirement("h5py", "pip install h5py", "hdf5 format (ALOHA, robomimic)"),
        Requirement("tensorflow_datasets", "pip install 'rio-datasets[rlds]'",
                    "rlds format (TensorFlow, ~1.7 GB: an extra, not in the workspace's uv sync)"),
    ]
