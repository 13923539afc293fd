"""What the torch engines share: the lazy ``torch`` import, devices, and the memory check.

PyTorch is an optional extra (``pip install "qdensity[torch]"``): nothing here imports it at
module level, so ``import qdensity`` never needs it. :func:`is_tensor` answers without
importing torch (a tensor can only exist once torch is imported).
"""

from __future__ import annotations

import os
import sys
import weakref

__all__: list[str] = []


def torch():
    """The ``torch`` module, or an ImportError that names the extra."""
    try:
        import torch as _torch
    except ImportError as exc:  # pragma: no cover - the CI machines have torch
        raise ImportError("the torch engines need PyTorch: pip install 'qdensity[torch]'"
                          ) from exc
    return _torch


def is_tensor(x) -> bool:
    """True for a ``torch.Tensor`` (False, without importing torch, when torch is not loaded)."""
    mod = sys.modules.get("torch")
    return mod is not None and isinstance(x, mod.Tensor)


def available() -> str:
    """What devices torch can see, in words (for error messages)."""
    t = torch()
    ok = t.cuda.is_available()
    count = t.cuda.device_count() if ok else 0
    return (f"torch.cuda.is_available() is {ok}, {count} CUDA device(s); 'cpu' is always "
            "available")


def resolve_device(device, name: str = "device"):
    """A ``torch.device`` that exists here.

    Parameters
    ----------
    device : None, str, int or torch.device
        None is ``"cpu"``; an int is a CUDA ordinal.

    Raises
    ------
    TypeError
        Not a device description.
    ValueError
        A CUDA device where none is visible (or an ordinal past the count), naming the device
        and what is available.
    """
    t = torch()
    if device is None:
        return t.device("cpu")
    if isinstance(device, bool) or not isinstance(device, (str, int, t.device)):
        raise TypeError(f"{name} must be a str, an int or a torch.device, got "
                        f"{type(device).__name__} {device!r}")
    try:
        dev = t.device(device)
    except (RuntimeError, ValueError) as exc:
        raise ValueError(f"{name}={device!r} is not a device torch knows ({exc}); "
                         f"{available()}") from None
    if dev.type == "cuda":
        count = t.cuda.device_count() if t.cuda.is_available() else 0
        index = 0 if dev.index is None else dev.index
        if index >= count:
            raise ValueError(f"{name}={str(dev)!r} is not available: {available()}")
    elif dev.type not in ("cpu", "meta"):
        raise ValueError(f"{name}={str(dev)!r}: the torch engines run on 'cpu' or 'cuda' "
                         f"devices; {available()}")
    return dev


#: Fraction of a device's free memory one call may plan to use.
FREE_FRACTION = 0.9


def free_bytes(device) -> int | None:
    """Bytes a new allocation may use on ``device``: ``torch.cuda.mem_get_info`` on a GPU,
    the available physical memory (``MemAvailable``) on the CPU, None where nothing is
    allocated (``meta``) or nothing is known."""
    t = torch()
    if device.type == "cuda":
        return int(t.cuda.mem_get_info(device)[0])
    if device.type == "cpu":
        return _host_available()
    return None


def _host_available() -> int | None:
    """The kernel's ``MemAvailable`` (free plus reclaimable caches), else free pages."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        return None


def check_fits(device, nbytes: int, what: str) -> None:
    """Refuse, before allocating, ``nbytes`` that would not fit in ``device``'s free memory.

    Raises
    ------
    ValueError
        Naming the bytes needed, ``what`` they are, and the bytes free.
    """
    free = free_bytes(device)
    if free is not None and nbytes > FREE_FRACTION * free:
        raise ValueError(f"{what} needs {int(nbytes)} bytes ({nbytes / 2**30:.2f} GiB) on "
                         f"{device}, which has {free} bytes ({free / 2**30:.2f} GiB) free; "
                         "use fewer rows per chunk (memory_budget), fewer qubits, or a "
                         "device with more memory")


def real_dtype(x):
    """float32 or float64 of a floating tensor, else a TypeError naming the dtype."""
    t = torch()
    if x.dtype not in (t.float32, t.float64):
        raise TypeError(f"tensors must be float32 or float64, got dtype {x.dtype}")
    return x.dtype


_CACHES: dict[int, tuple] = {}


def cache_of(owner) -> dict:
    """A dict for the device objects (index tables, matrices, observables) kept for ``owner``
    while it lives, held outside its attributes: pickling or copying ``owner`` never carries
    device tensors, and a pickle written after a GPU run loads where no GPU is."""
    key = id(owner)
    hit = _CACHES.get(key)
    if hit is not None and hit[0]() is owner:
        return hit[1]
    def drop(_ref: object, key: int = key) -> None:
        _CACHES.pop(key, None)

    ref = weakref.ref(owner, drop)
    _CACHES[key] = (ref, {})
    return _CACHES[key][1]
