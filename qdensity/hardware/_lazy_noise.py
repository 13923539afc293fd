"""A hardware target's noise model, built from its backend on first read.

``NoiseModel.from_backend`` of a 193-qubit heavy-hex ``GenericBackendV2`` takes 7-14 s on a
2-core machine (one depolarising and one thermal-relaxation channel per gate and qubit), while
transpiling and counting resources never read it. :class:`LazyNoise` stands in for the model
until :attr:`HardwareTarget.noise_model` is first read (a simulator, a sampler, ``is_noisy``),
then the model is built once and kept: every read returns the same object, equal to what
``noise_from_backend(backend)`` returns (the backend's errors are fixed by its seed).
"""

from __future__ import annotations

from qiskit.providers import BackendV2

from qdensity.hardware.noise import noise_from_backend

__all__: list[str] = []


class LazyNoise:
    """The noise model of ``backend``, not built yet."""

    __slots__ = ("backend",)

    def __init__(self, backend: BackendV2):
        self.backend = backend

    def __getstate__(self):
        return self.backend

    def __setstate__(self, backend) -> None:
        self.backend = backend


class NoiseModelField:
    """Data descriptor for ``HardwareTarget.noise_model``: the value lives in the instance's
    ``__dict__`` under ``slot`` (so targets pickle and copy as plain objects); a
    :class:`LazyNoise` there is replaced by the built model on first read."""

    def __init__(self, slot: str):
        self.slot = slot

    def __get__(self, obj, owner=None):
        if obj is None:
            return self
        value = obj.__dict__[self.slot]
        if isinstance(value, LazyNoise):
            value = noise_from_backend(value.backend)
            obj.__dict__[self.slot] = value
        return value

    def __set__(self, obj, value) -> None:
        # reached only from the dataclass __init__ (object.__setattr__); the frozen class's
        # own __setattr__ still refuses assignments
        obj.__dict__[self.slot] = value
