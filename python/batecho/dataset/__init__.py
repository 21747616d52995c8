"""Echo datasets at scale: draw scenes, poses and sonars from a spec, simulate their echoes,
and write them with their labels to a Zarr store, on this machine or on a Dask cluster.

    spec = DatasetSpec.from_toml("examples/dataset-small.toml")
    generate(spec, "out.zarr")                        # local processes, progress bar
    generate(spec, "out.zarr", client="tcp://host:8786")   # a Dask cluster
    verify("out.zarr")                                # complete, intact, spec matches
    ds = open_dataset("out.zarr")                     # xarray.Dataset

Needs ``zarr >= 3``; ``xarray`` to open the store, ``dask[distributed]`` for clusters, and
``tqdm`` for a nicer progress bar.
"""

from __future__ import annotations

from .guard import StoreLockedError
from .pipeline import (
    GenerateReport,
    Sample,
    SampleError,
    SceneCache,
    compute_chunk,
    draw_sample,
    generate,
    sample_seed,
)
from .scenes import SCENE_KINDS, BuiltScene, SceneKind
from .spec import (
    DatasetSpec,
    Dist,
    ForestSpec,
    LeafBoxSpec,
    LeafSpec,
    OutputSpec,
    PoseSpec,
    SceneSpec,
    SonarSpec,
    SpecError,
)
from .store import (
    DatasetError,
    SpecMismatchError,
    VerifyReport,
    open_dataset,
    read_spec,
    verify,
)

__all__ = [
    "SCENE_KINDS",
    "BuiltScene",
    "DatasetError",
    "DatasetSpec",
    "Dist",
    "ForestSpec",
    "GenerateReport",
    "LeafBoxSpec",
    "LeafSpec",
    "OutputSpec",
    "PoseSpec",
    "Sample",
    "SampleError",
    "SceneCache",
    "SceneKind",
    "SceneSpec",
    "SonarSpec",
    "SpecError",
    "SpecMismatchError",
    "StoreLockedError",
    "VerifyReport",
    "compute_chunk",
    "draw_sample",
    "generate",
    "open_dataset",
    "read_spec",
    "sample_seed",
    "verify",
]
