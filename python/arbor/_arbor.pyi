"""Type stubs of arbor's native module (the Rust binding)."""

from os import PathLike
from typing import Dict, Union

import numpy as np
import numpy.typing as npt

_Floats = npt.ArrayLike
_Scalars = Union[float, npt.ArrayLike]

class Mesh:
    """A triangle mesh prepared for ray queries (see ``help(arbor.Mesh)``)."""

    def __init__(
        self, vertices: _Floats, faces: npt.ArrayLike, accel: str = "bvh-wide", quality: str = "fast"
    ) -> None: ...
    @property
    def vertices(self) -> npt.NDArray[np.float32]: ...
    @property
    def faces(self) -> npt.NDArray[np.int64]: ...
    @property
    def accel(self) -> str: ...
    @property
    def quality(self) -> str: ...
    def __len__(self) -> int: ...
    def intersect(
        self,
        origins: _Floats,
        directions: _Floats,
        tmin: _Scalars | None = None,
        tmax: _Scalars | None = None,
        out: Dict[str, np.ndarray] | None = None,
    ) -> Dict[str, np.ndarray]: ...
    def occluded(
        self,
        origins: _Floats,
        directions: _Floats,
        tmin: _Scalars | None = None,
        tmax: _Scalars | None = None,
    ) -> npt.NDArray[np.bool_]: ...
    def all_hits(
        self,
        origins: _Floats,
        directions: _Floats,
        tmin: _Scalars | None = None,
        tmax: _Scalars | None = None,
    ) -> Dict[str, np.ndarray]: ...
    def count(
        self,
        origins: _Floats,
        directions: _Floats,
        tmin: _Scalars | None = None,
        tmax: _Scalars | None = None,
    ) -> npt.NDArray[np.uint32]: ...
    def contains(self, points: _Floats) -> npt.NDArray[np.bool_]: ...
    def winding_number(self, points: _Floats) -> npt.NDArray[np.float32]: ...
    def closest_points(
        self, points: _Floats, max_distance: _Scalars | None = None
    ) -> Dict[str, np.ndarray]: ...
    def signed_distance(self, points: _Floats) -> npt.NDArray[np.float32]: ...
    def open_edges(self) -> int: ...

def load_mesh(
    path: Union[str, PathLike[str]], accel: str = "bvh-wide", quality: str = "fast"
) -> Mesh: ...
def render(
    scene_or_model_path: Union[str, PathLike[str]],
    width: int | None = None,
    height: int | None = None,
    samples: int | None = None,
    accel: str | None = None,
    instancing: str | None = None,
) -> npt.NDArray[np.float32]: ...
def write_image(path: Union[str, PathLike[str]], image: npt.ArrayLike) -> None: ...
