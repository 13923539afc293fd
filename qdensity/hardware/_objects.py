"""The fields of a :class:`~qdensity.hardware.targets.HardwareTarget` read off objects a hardware
team already has: any ``BackendV2`` (a fake backend, ``GenericBackendV2``, a real
``IBMBackend``, an ``AerSimulator.from_backend(...)``) or a bare ``qiskit.transpiler.Target``.

A backend gives its ``Target`` (coupling map, native gates, calibrated errors and durations) and,
for simulation, a noise model built from that calibration (``NoiseModel.from_backend``, on first
read), or, for an ``AerSimulator`` that carries one, its own noise model. A ``Target`` gives the
same minus the noise model, which the caller may pass.
"""

from __future__ import annotations

from qiskit.circuit.library import get_standard_gate_name_mapping
from qiskit.providers import BackendV2
from qiskit.transpiler import Target
from qiskit_aer import AerSimulator
from qiskit_aer.noise import NoiseModel

from qdensity.hardware._basis import _NON_GATES
from qdensity.hardware._lazy_noise import LazyNoise
from qdensity.validation import MAX_CIRCUIT_QUBITS

__all__: list[str] = []


def _gates(target: Target) -> tuple[str, ...]:
    standard = get_standard_gate_name_mapping()
    return tuple(g for g in target.operation_names if g not in _NON_GATES and g in standard)


def _check_size(num_qubits: int, what: str) -> None:
    if num_qubits > MAX_CIRCUIT_QUBITS:
        raise ValueError(f"{what} has {num_qubits} qubits; targets are limited to "
                         f"{MAX_CIRCUIT_QUBITS} qubits (wider ones are beyond any device)")


def _check_noise_model(noise_model) -> None:
    if noise_model is not None and not isinstance(noise_model, NoiseModel):
        raise TypeError(f"noise_model must be a qiskit_aer.noise.NoiseModel or None, got "
                        f"{type(noise_model).__name__}")


def _check_wide_enough(num_qubits: int | None, width: int, name: str) -> None:
    if num_qubits is not None and num_qubits > width:
        raise ValueError(f"num_qubits {num_qubits} is wider than device {name!r}, which has "
                         f"{width} qubits; use a wider device or a smaller model")


def backend_fields(backend: BackendV2, num_qubits: int | None, *, noise: bool,
                   noise_model: NoiseModel | None) -> dict:
    """``HardwareTarget`` fields (all but ``seed``) of a ``BackendV2``."""
    _check_noise_model(noise_model)
    target = backend.target
    if target is None or target.num_qubits is None:
        raise ValueError(f"backend {backend.name!r} has no Target with a fixed number of "
                         f"qubits; pass a named target or a qiskit.transpiler.Target")
    _check_size(target.num_qubits, f"backend {backend.name!r}")
    _check_wide_enough(num_qubits, target.num_qubits, backend.name)
    if not noise:
        model = None
    elif noise_model is not None:
        model = noise_model
    elif isinstance(backend, AerSimulator):
        # an AerSimulator carries its noise (AerSimulator.from_backend built it already)
        model = backend.options.noise_model
        model = model if isinstance(model, NoiseModel) else None
    else:
        model = LazyNoise(backend)
    return {
        "name": backend.name, "num_qubits": target.num_qubits, "backend": backend,
        "coupling_map": target.build_coupling_map(), "basis_gates": _gates(target),
        "noise_model": model, "target": target,
    }


def target_fields(target: Target, num_qubits: int | None, *, noise: bool,
                  noise_model: NoiseModel | None) -> dict:
    """``HardwareTarget`` fields (all but ``seed``) of a bare ``Target`` (noiseless unless a
    ``noise_model`` is given)."""
    _check_noise_model(noise_model)
    if not target.num_qubits:
        raise ValueError("a Target without a fixed number of qubits cannot be a device; build "
                         "it with Target(num_qubits=...)")
    _check_size(target.num_qubits, "target")
    name = target.description or "target"
    _check_wide_enough(num_qubits, target.num_qubits, name)
    return {
        "name": name, "num_qubits": target.num_qubits, "backend": None,
        "coupling_map": target.build_coupling_map(), "basis_gates": _gates(target),
        "noise_model": noise_model if noise else None, "target": target,
    }
