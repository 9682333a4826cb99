"""Type stubs of arbor's native module (the Rust binding)."""

from os import PathLike
from typing import Dict, Union

import numpy as np
import numpy.typing as npt

_Floats = npt.ArrayLike
_Scalars = Union[float, npt.ArrayLike]

class Mesh:
    """A triangle mesh prepared for ray queries (see ``help(arbor.Mesh)``)."""

    def __init__(self, vertices: _Floats, faces: npt.ArrayLike, accel: str = "bvh-wide") -> None: ...
    @property
    def vertices(self) -> npt.NDArray[np.float32]: ...
    @property
    def faces(self) -> npt.NDArray[np.int64]: ...
    @property
    def accel(self) -> str: ...
    def __len__(self) -> int: ...
    def intersect(
        self,
        origins: _Floats,
        directions: _Floats,
        tmin: _Scalars | None = None,
        tmax: _Scalars | None = None,
    ) -> Dict[str, np.ndarray]: ...
    def occluded(
        self,
        origins: _Floats,
        directions: _Floats,
        tmin: _Scalars | None = None,
        tmax: _Scalars | None = None,
    ) -> npt.NDArray[np.bool_]: ...

def load_mesh(path: Union[str, PathLike[str]], accel: str = "bvh-wide") -> Mesh: ...
