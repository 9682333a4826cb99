"""Answers that read both as NumPy arrays and as Open3D tensors.

Open3D's ``RaycastingScene`` returns ``open3d.core.Tensor`` objects, and
code written for it calls ``.numpy()``, ``.cpu()``, ``.isfinite()`` or
``.item()`` on them. :class:`Answer` is a NumPy array (every NumPy
function and operator works on it as on any array) that also has those
methods. Making one is a view of the array arbor returned: no copy.
"""

import numpy as np


class Answer(np.ndarray):
    """A NumPy array with the methods of ``open3d.core.Tensor`` that code
    reading ray casting answers uses: ``numpy()``, ``cpu()``,
    ``contiguous()``, ``isfinite()``, ``isinf()``, ``isnan()``, ``item()``
    (NumPy's own), ``shape`` and ``dtype`` (NumPy's)."""

    def numpy(self):
        """This array as a plain ``numpy.ndarray`` sharing its memory, as
        Open3D's ``Tensor.numpy()`` shares the tensor's."""
        return self.view(np.ndarray)

    def cpu(self):
        """This array: it is already in CPU memory."""
        return self

    def contiguous(self):
        """This array in C order (itself when it already is)."""
        return np.ascontiguousarray(self).view(Answer)

    def isfinite(self):
        """Elementwise ``numpy.isfinite``."""
        return np.isfinite(self)

    def isinf(self):
        """Elementwise ``numpy.isinf``."""
        return np.isinf(self)

    def isnan(self):
        """Elementwise ``numpy.isnan``."""
        return np.isnan(self)


def answer(array):
    """``array`` viewed as an :class:`Answer` (no copy)."""
    return np.asarray(array).view(Answer)


def answers(arrays):
    """A dict of arrays with each viewed as an :class:`Answer`."""
    return {key: answer(value) for key, value in arrays.items()}
