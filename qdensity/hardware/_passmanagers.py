"""Preset pass managers built once per hardware target, optimisation level and seed (and the
checks of the circuits given to ``HardwareTarget.transpile``).

``qiskit.transpile`` builds Qiskit's preset pass manager on every call (``generate_preset_pass_
manager`` then ``run``). :meth:`~qdensity.hardware.targets.HardwareTarget.transpile` is called
once per template, so a model of 63 sub-unitaries rebuilt it 126 times for the same device.
:func:`transpile_with` keeps the pass manager of each ``(target, level, seed)`` and runs it on the
whole batch, which is exactly what ``qiskit.transpile`` does with the same arguments (the same
stages, the same seeded layout and routing; a batch is parallelised by Qiskit's ``parallel_map``
as before).

The cache is keyed weakly by the :class:`HardwareTarget` object (compared by identity), so it
lives as long as the target and is not part of its state: targets pickle and copy as before,
and a copy builds its own pass manager on first use.
"""

from __future__ import annotations

import threading
import weakref
from collections.abc import Sequence

from qiskit import transpile as qiskit_transpile
from qiskit.circuit import QuantumCircuit
from qiskit.transpiler import PassManager, Target, generate_preset_pass_manager

from qdensity.validation import check_circuit

__all__: list[str] = []

_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_LOCK = threading.Lock()


def check_batch(circuits, num_qubits: int, name: str) -> tuple[bool, list[QuantumCircuit]]:
    """``(single, batch)`` of ``HardwareTarget.transpile``'s ``circuits``, each checked and at
    most ``num_qubits`` wide (the message names target ``name``)."""
    single = isinstance(circuits, QuantumCircuit)
    if single:
        batch = [circuits]
    else:
        if isinstance(circuits, (str, bytes)) or not isinstance(circuits, Sequence):
            raise TypeError(
                f"circuits must be a QuantumCircuit or a sequence of them, "
                f"got {type(circuits).__name__}"
            )
        batch = list(circuits)
    for k, circ in enumerate(batch):
        check_circuit(circ, "circuits" if single else f"circuits[{k}]")
        if circ.num_qubits > num_qubits:
            raise ValueError(
                f"circuit {circ.name!r} has {circ.num_qubits} qubits but target "
                f"{name!r} has {num_qubits}; use a target with >= {circ.num_qubits} qubits"
            )
    return single, batch


def _where(target: Target | None, basis_gates: tuple[str, ...]) -> dict:
    """What the circuits are compiled for: the ``target``, else the ``basis_gates``."""
    return {"target": target} if target is not None else {"basis_gates": list(basis_gates)}


def _pass_manager(owner: object, level: int, seed: int, where: dict) -> PassManager:
    """The preset pass manager of ``owner`` at ``(level, seed)``, built on first use."""
    with _LOCK:
        per_owner = _CACHE.get(owner)
        if per_owner is None:
            per_owner = _CACHE[owner] = {}
        pm = per_owner.get((level, seed))
    if pm is None:
        pm = generate_preset_pass_manager(level, seed_transpiler=seed, **where)
        with _LOCK:
            pm = per_owner.setdefault((level, seed), pm)
    return pm


def transpile_with(owner: object, batch: list[QuantumCircuit], level: int, seed: int | None,
                   target: Target | None, basis_gates: tuple[str, ...]) -> list[QuantumCircuit]:
    """``qiskit.transpile(batch, optimization_level=level, seed_transpiler=seed, target=...)``
    with the pass manager kept on ``owner`` (or ``basis_gates=...`` when ``target`` is None).

    A seed of None keeps ``qiskit.transpile`` itself (its seed then comes from the environment
    or the user's Qiskit configuration, read per call).
    """
    where = _where(target, basis_gates)
    if seed is None:
        return list(qiskit_transpile(batch, optimization_level=level, **where))
    pm = _pass_manager(owner, level, seed, where)
    out = pm.run(batch)
    for circ, compiled in zip(batch, out, strict=True):
        compiled.name = circ.name  # as qiskit.transpile does
    return list(out)
