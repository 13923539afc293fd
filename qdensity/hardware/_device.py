"""Checks of compiled circuits against the device behind a sampler, before any job is submitted.

A hardware provider's sampler (``qiskit_ibm_runtime.SamplerV2``, a ``BackendSamplerV2``) knows
its backend; a circuit wider than that device, or holding an instruction the device's
``Target`` does not list, would fail only after submission (or be refused by the provider with
its own message). :func:`device_of` finds the backend, :func:`check_for_device` refuses such
circuits with a ``ValueError`` that names the job, the device and what it supports.
"""

from __future__ import annotations

from qiskit.circuit import QuantumCircuit
from qiskit.providers import BackendV2

_ALWAYS = frozenset({"barrier", "measure"})


def device_of(sampler) -> BackendV2 | None:
    """The backend a sampler runs on, or None when it does not say (Aer's ``SamplerV2``)."""
    attr = getattr(sampler, "backend", None)
    try:
        backend = attr() if callable(attr) else attr
    except Exception:  # a provider's sampler without a backend in its mode
        return None
    return backend if isinstance(backend, BackendV2) else None


def check_width(circuit: QuantumCircuit, backend: BackendV2, label: str) -> None:
    """Refuse a template wider than the device (before transpiling it)."""
    if circuit.num_qubits > backend.num_qubits:
        raise ValueError(
            f"job {label!r} needs {circuit.num_qubits} qubits but device {backend.name!r} has "
            f"{backend.num_qubits}; use a wider device or a smaller model"
        )


def check_for_device(circuit: QuantumCircuit, backend: BackendV2, label: str) -> None:
    """Refuse a compiled circuit the device cannot run (too wide, or an unsupported gate)."""
    check_width(circuit, backend, label)
    supported = set(backend.target.operation_names) | _ALWAYS
    unknown = sorted({inst.operation.name for inst in circuit.data} - supported)
    if unknown:
        raise ValueError(
            f"job {label!r} holds instructions {unknown} that device {backend.name!r} cannot "
            f"run (it runs {sorted(supported)}); transpile for the device, e.g. "
            f"SamplerEngine(sampler=..., transpiler=generate_preset_pass_manager("
            f"backend=backend).run)"
        )
