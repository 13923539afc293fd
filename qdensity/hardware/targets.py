"""Named hardware targets: connectivity, native gates, noise, and a matching Aer simulator.

A :class:`HardwareTarget` bundles what running a density QNN "on hardware" needs: the coupling
map and native gates to transpile against, a noise model, and factories for a seeded
``AerSimulator`` and a seeded ``SamplerV2`` that carry that noise. Users pick targets by name:

``ideal``
    Noiseless ``AerSimulator``, all-to-all, the standard gates Aer simulates natively (or any
    ``basis_gates`` given). ``backend`` is None.
``all_to_all``, ``line``, ``ring``, ``heavy_hex``
    A seeded ``GenericBackendV2`` (IBM-like basis ``cx, id, rz, sx, x`` unless ``basis_gates``
    is given) on ``CouplingMap.from_full`` / ``from_line`` / ``from_ring`` /
    ``from_heavy_hex``. Heavy-hex devices come in odd code distances ``d >= 3`` with
    ``(5 d^2 - 2 d - 1) / 2`` qubits (19, 57, 115, ...); the smallest one that fits the
    requested size is used, so ``num_qubits`` may exceed the request. The backend samples
    T1/T2, gate and readout errors from its seed: the same seed gives the same noise.
``rbs_native``
    A trapped-ion-like all-to-all device whose native two-qubit gate is the beam splitter
    ``xx_plus_yy`` (``XXPlusYYGate``), next to the Molmer-Sorensen gate ``rxx`` and the
    one-qubit gates ``rz`` (virtual), ``sx``, ``x``. Because ``RBSGate(theta)`` *equals*
    ``XXPlusYYGate(2 theta, pi/2)`` (docs/design.md, "Measured facts"),
    :meth:`HardwareTarget.transpile` first writes every RBS (also inside gates such as FBS whose
    definitions hold RBS gates) as that native gate, so a circuit of ``m`` RBS gates (paper
    eq. 8) transpiles to exactly ``m`` native two-qubit gates and nothing else; other two-qubit
    gates translate through ``rxx``.
    The noise is uniform across the chain (:data:`RBS_NATIVE_NOISE`); the seed only drives
    transpilation and sampling.
``fake_manila``, ``fake_torino``, ... (one per backend of ``qiskit_ibm_runtime.fake_provider``)
    A calibrated device snapshot (:mod:`qdensity.hardware.snapshots`): the real coupling map,
    native gates, T1/T2, gate and readout errors of an IBM device. Needs the optional extra
    ``ibm``; ``num_qubits`` may be omitted (the device's size) and ``basis_gates`` is refused.

A device can also be handed over as an object or a file: any ``BackendV2`` (a fake backend,
``GenericBackendV2``, a real ``IBMBackend``, ``AerSimulator.from_backend(...)``), a bare
``qiskit.transpiler.Target`` (with an optional noise model), or the path of a snapshot file
written by :func:`~qdensity.hardware.snapshot_files.save_snapshot`. Every size is bounded by
4,096 qubits, checked before anything is built.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from qiskit.circuit import QuantumCircuit
from qiskit.providers import BackendV2
from qiskit.transpiler import CouplingMap, Target
from qiskit.transpiler.exceptions import TranspilerError
from qiskit_aer import AerSimulator
from qiskit_aer.noise import NoiseModel

from qdensity.hardware._basis import _check_level, _ideal_basis
from qdensity.hardware._lazy_noise import NoiseModelField
from qdensity.hardware._named import heavy_hex_distance, named_fields
from qdensity.hardware._native import (
    RBS_NATIVE_BASIS,
    RBS_NATIVE_NOISE,
    _NativeXYSimulator,
    _rbs_to_native,
)
from qdensity.hardware._objects import backend_fields, target_fields
from qdensity.hardware._passmanagers import check_batch, transpile_with
from qdensity.hardware._served_noise import ServedNoiseSimulator
from qdensity.hardware.aer_sampling import aer_seed
from qdensity.hardware.snapshot_files import is_snapshot_path, load_snapshot
from qdensity.hardware.snapshots import (
    is_snapshot_name,
    snapshot_fields,
    snapshot_names,
)
from qdensity.validation import (
    Instance,
    Interval,
    Qubits,
    Seed,
    SeedLike,
    SequenceOf,
    TargetLike,
    Unchecked,
    seed_int,
    validates,
)

__all__ = [
    "HardwareTarget",
    "get_target",
    "as_target",
    "known_targets",
    "target_help",
    "gpu_available",
    "heavy_hex_distance",
    "RBS_NATIVE_NOISE",
    "RBS_NATIVE_BASIS",
    "SIMULATION_METHODS",
]

#: Simulation methods accepted by :meth:`HardwareTarget.simulator`.
SIMULATION_METHODS = ("automatic", "statevector", "density_matrix", "matrix_product_state")

_TARGETS = ("ideal", "all_to_all", "line", "ring", "heavy_hex", "rbs_native")
_DEVICES = ("CPU", "GPU")


def known_targets() -> list[str]:
    """Names accepted by :func:`get_target`.

    Returns
    -------
    list of str
        ``["ideal", "all_to_all", "line", "ring", "heavy_hex", "rbs_native"]``, then the
        device snapshots (``"fake_manila"``, ``"fake_torino"``, ...) when the ``ibm`` extra is
        installed.

    Examples
    --------
    >>> known_targets()[:6]
    ['ideal', 'all_to_all', 'line', 'ring', 'heavy_hex', 'rbs_native']
    """
    return list(_TARGETS) + list(snapshot_names())


def target_help() -> str:
    """A short description of the target names for command-line help (imports no provider).

    Returns
    -------
    str

    Examples
    --------
    >>> target_help().startswith("one of: ideal, all_to_all, line, ring, heavy_hex")
    True
    """
    return (f"one of: {', '.join(_TARGETS)}, a calibrated device snapshot fake_manila, "
            f"fake_torino, ... (needs pip install 'qdensity[ibm]'), or the path of a snapshot "
            f"file (.json, written by qdensity.hardware.snapshot_files.save_snapshot)")


def gpu_available() -> bool:
    """Whether qiskit-aer can simulate on a GPU here (``qiskit-aer-gpu`` and a CUDA device).

    Returns
    -------
    bool

    Examples
    --------
    >>> isinstance(gpu_available(), bool)  # True only with qiskit-aer-gpu and a CUDA device
    True
    """
    return "GPU" in AerSimulator().available_devices()


@validates(
    name=Instance(str), num_qubits=Qubits(1), backend=[Instance(BackendV2), None],
    coupling_map=[Instance(CouplingMap), None], basis_gates=SequenceOf(Instance(str), min_len=0),
    noise_model=Unchecked('a NoiseModel, None or the lazy field builder (NoiseModelField)'),
    target=[Instance(Target), None], seed=[Interval(int, 0), None],
)
@dataclass(frozen=True, eq=False)
class HardwareTarget:
    """A device to transpile for and simulate on (see :func:`get_target`).

    Attributes
    ----------
    name : str
        One of :func:`known_targets`.
    num_qubits : int
        Physical qubits of the device (the requested size, or more for ``heavy_hex``).
    backend : qiskit.providers.BackendV2 or None
        The seeded ``GenericBackendV2``, or the snapshot's fake backend (None for ``ideal`` and
        ``rbs_native``).
    coupling_map : CouplingMap or None
        Allowed two-qubit pairs; None means all-to-all without a fixed size (``ideal``).
    basis_gates : tuple of str
        Native gate names (without ``measure``, ``reset``, ``delay``).
    noise_model : qiskit_aer.noise.NoiseModel or None
        None when noiseless (``ideal``, ``noise=False``); else built on first read, then kept.
    target : qiskit.transpiler.Target or None
        What :meth:`transpile` compiles against (None for ``ideal``: basis only).
    seed : int or None
        Default seed of transpilation and simulation.

    Examples
    --------
    >>> tgt = get_target("line", 4, seed=3)
    >>> tgt.name, tgt.num_qubits, tgt.basis_gates, tgt.is_noisy
    ('line', 4, ('cx', 'id', 'rz', 'sx', 'x'), True)
    >>> sorted(tgt.coupling_map.get_edges())[:2]
    [(0, 1), (1, 0)]
    """

    name: str
    num_qubits: int
    backend: BackendV2 | None = field(repr=False)
    coupling_map: CouplingMap | None = field(repr=False)
    basis_gates: tuple[str, ...]
    noise_model: NoiseModel | None = field(repr=False)
    target: Target | None = field(repr=False)
    seed: int | None

    @property
    def label(self) -> str:
        """The name, with the basis appended for an ``ideal`` target with a custom basis.

        For example ``"ideal[cz,rz,sx,x]"``; used by resource reports to tell targets apart.
        """
        if self.name == "ideal" and self.basis_gates != _ideal_basis():
            return f"ideal[{','.join(self.basis_gates)}]"
        return self.name

    @property
    def is_noisy(self) -> bool:
        """Whether simulations of this target carry noise."""
        return self.noise_model is not None and not self.noise_model.is_ideal()

    # ------------------------------------------------------------------------------------------
    def simulator(
        self,
        method: str = "automatic",
        device: str = "CPU",
        seed: SeedLike = None,
    ) -> AerSimulator:
        """An ``AerSimulator`` with this target's noise and coupling, seeded.

        Parameters
        ----------
        method : {"automatic", "statevector", "density_matrix", "matrix_product_state"}
            Aer simulation method.
        device : {"CPU", "GPU"}
            ``"GPU"`` needs ``qiskit-aer-gpu`` (see :func:`gpu_available`).
        seed : int, numpy.random.Generator or None
            Seeds ``seed_simulator`` (through :func:`~qdensity.validation.aer_seed`, so nearby
            seeds give independent trajectories); None uses the target's seed.

        Returns
        -------
        qiskit_aer.AerSimulator
            ``AerSimulator.from_backend`` for ``GenericBackendV2`` targets (noise model passed
            explicitly, None when the target is noiseless). It does not transpile: run circuits
            from :meth:`transpile`. Each run hands Aer, as its public ``noise_model`` run
            option, a model of only the errors of the qubits its circuits act on, built and
            serialised once per set of qubits (``qdensity.hardware._served_noise``): the same
            channel and counts, without re-serialising the device's whole model per call.

        Examples
        --------
        >>> from qiskit import QuantumCircuit
        >>> tgt = get_target("line", 2, seed=1)
        >>> qc = QuantumCircuit(2)
        >>> _ = qc.x(0)
        >>> _ = qc.measure_all()
        >>> counts = tgt.simulator(seed=3).run(tgt.transpile(qc), shots=100).result().get_counts()
        """
        if method not in SIMULATION_METHODS:
            raise ValueError(f"method must be one of {list(SIMULATION_METHODS)}, got {method!r}")
        if device not in _DEVICES:
            raise ValueError(f"device must be one of {list(_DEVICES)}, got {device!r}")
        if device == "GPU" and not gpu_available():
            raise ValueError(
                "device='GPU' requested but qiskit-aer has no GPU here; install qiskit-aer-gpu "
                "(pip install qiskit-aer-gpu, CUDA required) or use device='CPU'"
            )
        sim_seed = self.seed if seed is None else seed_int(seed)
        options = {
            "method": method,
            "device": device,
            "seed_simulator": aer_seed(sim_seed),
            "noise_model": self.noise_model if self.is_noisy else None,
        }
        if self.backend is not None:
            return ServedNoiseSimulator.from_backend(self.backend, **options)
        if self.name == "rbs_native":
            return _NativeXYSimulator(**options)
        return ServedNoiseSimulator(**options)

    def transpile(
        self,
        circuits: QuantumCircuit | Sequence[QuantumCircuit],
        optimization_level: int = 1,
        seed: SeedLike = None,
    ) -> QuantumCircuit | list[QuantumCircuit]:
        """Compile circuits to this target's native gates and connectivity (reproducibly).

        Parameters
        ----------
        circuits : QuantumCircuit or sequence of QuantumCircuit
            At most ``num_qubits`` wide.
        optimization_level : int
            0 to 3, as ``qiskit.transpile``.
        seed : int, numpy.random.Generator or None
            ``seed_transpiler``; None uses the target's seed.

        Returns
        -------
        QuantumCircuit or list of QuantumCircuit
            Same shape as given. On devices with a coupling map the output has the device's
            width and a ``layout``. As ``qiskit.transpile`` (pass manager built once per seed).

        Examples
        --------
        >>> from qiskit import QuantumCircuit
        >>> from qdensity.circuits.gates import RBSGate
        >>> qc = QuantumCircuit(3)
        >>> _ = qc.append(RBSGate(0.4), [0, 2])
        >>> dict(get_target("rbs_native", 3).transpile(qc).count_ops())
        {'xx_plus_yy': 1}
        """
        single, batch = check_batch(circuits, self.num_qubits, self.name)
        level = _check_level(optimization_level)
        seed_transpiler = self.seed if seed is None else seed_int(seed)
        if not batch:
            return []
        if self.name == "rbs_native":
            batch = [_rbs_to_native(c) for c in batch]
        try:
                out = transpile_with(self, batch, level, seed_transpiler, self.target,
                                 self.basis_gates)
        except TranspilerError as exc:
            raise ValueError(
                f"circuits cannot run on target {self.name!r} (native gates "
                f"{list(self.basis_gates)}): {exc}"
            ) from exc
        return out[0] if single else list(out)


HardwareTarget.noise_model = NoiseModelField("_noise_model")  # built on first read


@validates(
    name=TargetLike(), num_qubits=[Qubits(1), None], seed=Seed(),
    noise=Instance((bool, np.bool_), 'bool'),
    basis_gates=[SequenceOf(Instance(str), max_len=64), None],
    noise_model=[Instance(NoiseModel), None],
)
def get_target(
    name,
    num_qubits: int | None = None,
    *,
    seed: SeedLike = 0,
    noise: bool = True,
    basis_gates: Sequence[str] | None = None,
    noise_model: NoiseModel | None = None,
) -> HardwareTarget:
    """Build a hardware target from a name, a snapshot file, a backend or a ``Target``.

    Parameters
    ----------
    name : str, os.PathLike, qiskit.providers.BackendV2 or qiskit.transpiler.Target
        One of :func:`known_targets` (the module docstring has the catalogue); a path to a
        snapshot file (``.json``, :func:`~qdensity.hardware.snapshot_files.save_snapshot`);
        any ``BackendV2`` (a fake backend, ``GenericBackendV2``, a real ``IBMBackend``,
        ``AerSimulator.from_backend(...)``): its ``Target``, coupling map, native gates and,
        for simulation, the noise model of its calibration (``NoiseModel.from_backend``, built
        on first read; an ``AerSimulator``'s own noise model); or a ``Target`` (noiseless
        unless ``noise_model`` is given).
    num_qubits : int or None
        Requested number of qubits, at most 4,096 (checked before anything is built): ``>= 1``
        for ``ideal``, ``>= 2`` for devices with two-qubit gates, ``>= 3`` for ``ring``.
        Optional for devices of fixed size (snapshots, backends, Targets: a request wider than
        the device is refused), required otherwise.
    seed : int, numpy.random.Generator or None, optional
        Seeds the ``GenericBackendV2`` (its sampled T1/T2, gate and readout errors) and is the
        default seed of transpilation and simulation. Default 0.
    noise : bool, optional
        If False the target keeps its connectivity and gates but simulates without noise.
    basis_gates : sequence of str or None, optional
        Native gates for ``ideal`` (default: every standard gate Aer simulates natively) and
        the ``GenericBackendV2`` targets (default ``cx, id, rz, sx, x``). Refused for
        ``rbs_native``, whose gate set is its point, and for devices of fixed size.
    noise_model : qiskit_aer.noise.NoiseModel or None, optional
        For a ``Target`` or a backend: the noise to simulate with (overrides the backend's).

    Returns
    -------
    HardwareTarget

    Raises
    ------
    ValueError
        Unknown name (the message lists the known ones), too few qubits, a request wider than a
        device snapshot, a snapshot without the ``ibm`` extra (the message says what to
        install), or a basis the backend cannot use.

    Examples
    --------
    >>> tgt = get_target("heavy_hex", 5, seed=7)
    >>> tgt.num_qubits
    19
    >>> get_target("ideal", 3).noise_model is None
    True
    """
    if num_qubits is not None:
        num_qubits = int(num_qubits)
    device = load_snapshot(name) if is_snapshot_path(name) else name
    if isinstance(device, (BackendV2, Target)):
        if basis_gates is not None:
            raise ValueError(f"basis_gates cannot be changed for a device given as a backend, "
                             f"Target or snapshot file (its native gates are its own), got "
                             f"{basis_gates!r}")
        build = backend_fields if isinstance(device, BackendV2) else target_fields
        fields = build(device, num_qubits, noise=bool(noise), noise_model=noise_model)
        return HardwareTarget(**fields, seed=seed_int(seed))
    if not isinstance(name, str):
        raise TypeError(f"name must be a target name (one of {list(_TARGETS)}, or a device "
                        f"snapshot), a snapshot file path, a BackendV2 or a "
                        f"qiskit.transpiler.Target, got {type(name).__name__}")
    if noise_model is not None:
        raise ValueError(f"noise_model is accepted with a backend or a Target; target {name!r} "
                         f"builds its own (noise=False turns it off)")
    if is_snapshot_name(name):
        fields = snapshot_fields(name, num_qubits, noise=bool(noise), basis_gates=basis_gates)
        return HardwareTarget(**fields, seed=seed_int(seed))
    if name not in _TARGETS:
        raise ValueError(f"unknown target {name!r}; known targets: {', '.join(known_targets())}")
    if num_qubits is None:
        raise ValueError(f"num_qubits is required for target {name!r} (only device snapshots "
                         "have a fixed size)")
    fields = named_fields(name, num_qubits, noise=bool(noise), basis_gates=basis_gates,
                          seed=seed_int(seed))
    return HardwareTarget(**fields, seed=seed_int(seed))

def as_target(target, num_qubits: int | None = None, *, seed: SeedLike = 0,
              noise: bool = True) -> HardwareTarget:
    """A :class:`HardwareTarget` as given, or :func:`get_target` of anything it accepts.

    Parameters
    ----------
    target : HardwareTarget, str, os.PathLike, BackendV2 or qiskit.transpiler.Target
    num_qubits : int or None
        Size for a named target (and the width a fixed-size device must have).
    seed : int, numpy.random.Generator or None
    noise : bool

    Returns
    -------
    HardwareTarget

    Examples
    --------
    >>> tgt = get_target("ring", 3)
    >>> as_target(tgt) is tgt, as_target("ring", 3).name
    (True, 'ring')
    """
    if isinstance(target, HardwareTarget):
        if num_qubits is not None and num_qubits > target.num_qubits:
            raise ValueError(f"num_qubits {num_qubits} is wider than target {target.name!r}, "
                             f"which has {target.num_qubits} qubits")
        return target
    return get_target(target, num_qubits, seed=seed, noise=noise)
