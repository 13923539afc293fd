"""Calibrated device snapshots as targets: the fake backends of ``qiskit-ibm-runtime``.

``qiskit_ibm_runtime.fake_provider`` ships, for each of several dozen IBM devices, a snapshot of
a real calibration: the coupling map, the native gates, per-qubit T1/T2, per-gate errors and
durations, and per-qubit readout errors (``FakeManilaV2``: 5 qubits on a line-like graph;
``FakeTorino``: 133 qubits, heavy-hex, ``cz``). Each of its V2 backends is a named target of
:func:`qdensity.hardware.targets.get_target` under the backend's own name (``"fake_manila"``,
``"fake_torino"``, ...), with a noisy ``AerSimulator`` built from its calibration through
``NoiseModel.from_backend``.

The fake provider comes with the optional extra ``ibm`` (``pip install 'qdensity[ibm]'``).
Without it every other target keeps working and a snapshot name (any name starting with
``fake_``) raises a ``ValueError`` that says which extra to install.

Loading is cached per process: the list of names is read once from the provider, and the noise
model of each device (8 s for the 133 qubits of ``fake_torino``, 0.4 s for ``fake_manila``) is
built once, when a noisy target of that device is first asked for. A fresh backend object is
made for every target, so options set on one target's backend do not leak into another's.
"""

from __future__ import annotations

import functools
import importlib.util
import warnings

from qiskit.circuit.library import get_standard_gate_name_mapping
from qiskit.providers import BackendV2
from qiskit_aer.noise import NoiseModel

from qdensity.hardware._basis import _NON_GATES
from qdensity.hardware.noise import noise_from_backend
from qdensity.validation import check_positive_int

__all__ = [
    "SNAPSHOT_PREFIX",
    "SNAPSHOT_EXTRA",
    "snapshots_available",
    "snapshot_names",
    "is_snapshot_name",
    "snapshot_backend",
    "snapshot_noise_model",
    "snapshot_fields",
]

#: Every snapshot name starts with this prefix (the fake provider's naming).
SNAPSHOT_PREFIX = "fake_"

#: The optional extra of qdensity that brings the fake provider.
SNAPSHOT_EXTRA = "ibm"

_INSTALL = f"pip install 'qdensity[{SNAPSHOT_EXTRA}]' (or pip install qiskit-ibm-runtime)"


def snapshots_available() -> bool:
    """Whether ``qiskit-ibm-runtime`` (the ``ibm`` extra) is installed, without importing it.

    Returns
    -------
    bool

    Examples
    --------
    >>> snapshots_available() == bool(snapshot_names())  # names only with the ibm extra
    True
    """
    return importlib.util.find_spec("qiskit_ibm_runtime") is not None


@functools.cache
def _snapshot_classes() -> dict[str, type]:
    """``{backend name: backend class}`` for every V2 backend of the fake provider."""
    from qiskit_ibm_runtime.fake_provider import FakeProviderForBackendV2

    with warnings.catch_warnings():
        # FakeNighthawk warns that its numbers are not typical of the device family.
        warnings.simplefilter("ignore", UserWarning)
        backends = FakeProviderForBackendV2().backends()
    return {b.name: type(b) for b in sorted(backends, key=lambda b: b.name)}


def snapshot_names() -> tuple[str, ...]:
    """Names of the device snapshots, sorted; empty without the ``ibm`` extra.

    Returns
    -------
    tuple of str
        For example ``("fake_aachen", ..., "fake_manila", ..., "fake_torino", ...)``.

    Examples
    --------
    >>> all(name.startswith("fake_") for name in snapshot_names())
    True
    """
    if not snapshots_available():
        return ()
    return tuple(_snapshot_classes())


def is_snapshot_name(name: str) -> bool:
    """Whether ``name`` asks for a device snapshot (it starts with ``"fake_"``).

    Parameters
    ----------
    name : str

    Returns
    -------
    bool
        True also for names the provider does not have; :func:`snapshot_backend` refuses those.

    Examples
    --------
    >>> is_snapshot_name("fake_manila"), is_snapshot_name("heavy_hex")
    (True, False)
    """
    return isinstance(name, str) and name.startswith(SNAPSHOT_PREFIX)


def snapshot_backend(name: str) -> BackendV2:
    """A fresh fake backend (calibration snapshot) of the fake provider.

    Parameters
    ----------
    name : str
        One of :func:`snapshot_names`.

    Returns
    -------
    qiskit_ibm_runtime.fake_provider.fake_backend.FakeBackendV2
        A ``BackendV2``: ``target``, ``coupling_map``, calibrated errors; it also serves as the
        ``mode`` of ``qiskit_ibm_runtime.SamplerV2`` in local testing mode.

    Raises
    ------
    ValueError
        Without the ``ibm`` extra (the message says what to install), or for a name the
        provider does not have (the message lists the known ones).

    Examples
    --------
    >>> snapshot_backend("fake_athens").num_qubits  # needs the ibm extra
    5
    """
    if not isinstance(name, str):
        raise TypeError(f"name must be a str, got {type(name).__name__}")
    if not snapshots_available():
        raise ValueError(
            f"target {name!r} is a device snapshot of qiskit-ibm-runtime's fake provider, which "
            f"is not installed; install the optional extra: {_INSTALL}"
        )
    classes = _snapshot_classes()
    if name not in classes:
        raise ValueError(
            f"unknown device snapshot {name!r}; known snapshots: {', '.join(classes)}"
        )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return classes[name]()


@functools.cache
def snapshot_noise_model(name: str) -> NoiseModel:
    """The noise model of a snapshot's calibration (cached: built once per process).

    Parameters
    ----------
    name : str
        One of :func:`snapshot_names`.

    Returns
    -------
    qiskit_aer.noise.NoiseModel
        ``NoiseModel.from_backend`` of the snapshot: thermal relaxation from T1/T2 and gate
        durations, depolarizing gate errors, and per-qubit readout errors. Shared between
        targets of the same device: do not modify it.
    """
    return noise_from_backend(snapshot_backend(name))


def snapshot_fields(name: str, num_qubits: int | None = None, *, noise: bool = True,
                    basis_gates=None) -> dict:
    """The fields of a snapshot's :class:`qdensity.hardware.targets.HardwareTarget` (all but
    ``seed``).

    Parameters
    ----------
    name : str
        One of :func:`snapshot_names`.
    num_qubits : int or None
        Qubits the caller needs; refused when wider than the device. None: no check.
    noise : bool
        Whether the target carries the calibration's noise model.
    basis_gates : None
        Refused when given: a snapshot's native gates are those of its calibration.

    Returns
    -------
    dict
        ``name``, ``num_qubits`` (the device's), ``backend``, ``coupling_map``,
        ``basis_gates``, ``noise_model``, ``target``.

    Examples
    --------
    >>> fields = snapshot_fields("fake_athens")  # needs the ibm extra
    >>> fields["name"], fields["num_qubits"], fields["noise_model"] is not None
    ('fake_athens', 5, True)
    """
    backend = snapshot_backend(name)
    if basis_gates is not None:
        raise ValueError(f"basis_gates cannot be changed for device snapshot {name!r} (its "
                         f"native gates are those of its calibration), got {basis_gates!r}")
    if num_qubits is not None:
        n = check_positive_int(num_qubits, "num_qubits")
        if n > backend.num_qubits:
            raise ValueError(f"num_qubits {n} is wider than device snapshot {name!r}, which "
                             f"has {backend.num_qubits} qubits")
    standard = get_standard_gate_name_mapping()
    gates = tuple(g for g in backend.operation_names if g not in _NON_GATES and g in standard)
    return {
        "name": name, "num_qubits": backend.num_qubits, "backend": backend,
        "coupling_map": backend.coupling_map, "basis_gates": gates,
        "noise_model": snapshot_noise_model(name) if noise else None, "target": backend.target,
    }
