"""Array arguments as NumPy arrays, from whatever a caller of Open3D or
trimesh passes: NumPy arrays (used as they are), objects with ``__array__``
(CPU torch tensors, array-likes), objects with ``.numpy()``
(``open3d.core.Tensor``) and nested lists.

NumPy views the memory of arrays and tensors wherever it can, so a float32
or float64 argument reaches the Rust queries without a copy; integers and
booleans become float64, float16 becomes float32. Tensors on a GPU, and
values that are not real numbers, are a ValueError naming the argument.
"""

import numpy as np


def is_cpu(device):
    """Whether ``device`` names the CPU: ``None``, an ``open3d.core.Device``
    or ``torch.device`` of the CPU, a string such as ``"CPU:0"``, or
    anything else whose name says CPU (a JAX CPU device is "TFRT_CPU_0";
    some libraries give the device as a method)."""
    if callable(device):
        device = device()
    return device is None or "cpu" in str(device).lower()


def check_device(device, what):
    """Raises ValueError unless ``device`` (named ``what``) is the CPU."""
    if not is_cpu(device):
        raise ValueError(
            f"{what}: arbor runs on the CPU, got device {device}; "
            'use "CPU:0" (or move the data to the CPU first)'
        )


def _numpy_of(value, what):
    """``value`` as a NumPy array, viewing its memory where NumPy can."""
    if isinstance(value, np.ndarray):
        return value
    check_device(getattr(value, "device", None), what)
    detach = getattr(value, "detach", None)
    if callable(detach):
        # A torch tensor that requires grad refuses __array__ until detached
        # (a view: no copy).
        value = detach()
    if not hasattr(value, "__array__") and callable(getattr(value, "numpy", None)):
        # open3d.core.Tensor has no __array__: its numpy() shares memory.
        return value.numpy()
    try:
        return np.asarray(value)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{what}: cannot be read as an array of numbers ({error})") from None


def as_array(value, what, floats=True):
    """``value`` (named ``what`` in errors) as a NumPy array of numbers.

    With ``floats``, float32 and float64 arrays are returned as they are
    and other real numbers converted (integers and booleans to float64,
    float16 to float32); without, any integer or float dtype is kept.
    """
    array = _numpy_of(value, what)
    kind = array.dtype.kind
    if kind not in "biuf":
        raise ValueError(f"{what}: expected real numbers, got dtype {array.dtype}")
    if not floats or array.dtype in (np.float32, np.float64):
        return array
    return array.astype(np.float32 if array.dtype == np.float16 else np.float64)


def last_axis(value, what, n):
    """``value`` as an array of shape ``(..., n)`` of floats, flattened to
    ``(k, n)``, and its leading shape."""
    array = as_array(value, what)
    if array.ndim < 1 or array.shape[-1] != n:
        raise ValueError(
            f"{what}: expected an array of shape (..., {n}), got shape {array.shape}"
        )
    return array.reshape(-1, n), array.shape[:-1]
