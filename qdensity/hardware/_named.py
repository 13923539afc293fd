"""The fields of the named hardware targets of :func:`qdensity.hardware.targets.get_target`:
``ideal``, ``all_to_all``, ``line``, ``ring``, ``heavy_hex`` (seeded ``GenericBackendV2``
devices) and ``rbs_native``."""

from __future__ import annotations

from collections.abc import Sequence

from qiskit.providers.fake_provider import GenericBackendV2
from qiskit.transpiler import CouplingMap

from qdensity.hardware._basis import _NON_GATES, _check_basis, _ideal_basis
from qdensity.hardware._lazy_noise import LazyNoise
from qdensity.hardware._native import RBS_NATIVE_BASIS, RBS_NATIVE_NOISE, _rbs_native_target
from qdensity.hardware.noise import noise_model
from qdensity.validation import check_positive_int

__all__ = ["heavy_hex_distance", "MAX_FULLY_CONNECTED_QUBITS"]

#: Widest all-to-all target (``all_to_all``, ``rbs_native``): a full coupling map holds
#: ``n (n - 1)`` edges, each with gate properties; 256 qubits build in about a second, the time
#: grows as ``n**2`` (4,096 qubits ran past a minute).
MAX_FULLY_CONNECTED_QUBITS = 256


def heavy_hex_distance(num_qubits: int) -> int:
    """Smallest odd code distance ``d >= 3`` whose heavy-hex lattice has ``>= num_qubits`` qubits.

    A distance-``d`` heavy-hex lattice (``CouplingMap.from_heavy_hex(d)``) has
    ``(5 d^2 - 2 d - 1) / 2`` qubits.

    Parameters
    ----------
    num_qubits : int
        Requested size, ``>= 1``.

    Returns
    -------
    int
        ``3`` for up to 19 qubits, ``5`` up to 57, ``7`` up to 115, ...

    Examples
    --------
    A distance-``d`` heavy-hex lattice has ``(5 d**2 - 2 d - 1) / 2`` qubits (19 at ``d = 3``):

    >>> heavy_hex_distance(19), heavy_hex_distance(20)
    (3, 5)
    """
    n = check_positive_int(num_qubits, "num_qubits")
    d = 3
    while (5 * d * d - 2 * d - 1) // 2 < n:
        d += 2
    return d


def named_fields(name: str, n: int, *, noise: bool, basis_gates: Sequence[str] | None,
                 seed: int | None) -> dict:
    """``HardwareTarget`` fields (all but ``seed``) of the named target ``name`` of ``n``
    requested qubits (already checked against the upper bound)."""
    seed_value = seed
    basis = _check_basis(basis_gates)

    if name == "ideal":
        gates = basis if basis is not None else _ideal_basis()
        return dict(
            name=name, num_qubits=n, backend=None, coupling_map=None, basis_gates=gates,
            noise_model=None, target=None,
        )

    if name in ("all_to_all", "rbs_native") and n > MAX_FULLY_CONNECTED_QUBITS:
        raise ValueError(
            f"get_target: num_qubits must be <= {MAX_FULLY_CONNECTED_QUBITS} for target "
            f"{name!r} (a full coupling map holds n (n - 1) edges and takes minutes to build "
            f"above that), got {n}; use 'line', 'ring' or 'heavy_hex' for wider devices"
        )
    minimum = 3 if name == "ring" else 2
    if n < minimum:
        raise ValueError(
            f"num_qubits must be >= {minimum} for target {name!r} (it has two-qubit gates"
            f"{' on a cycle' if name == 'ring' else ''}), got {n}"
        )

    if name == "rbs_native":
        if basis is not None:
            raise ValueError(
                f"basis_gates cannot be changed for target 'rbs_native' (its native gates are "
                f"{list(RBS_NATIVE_BASIS)}), got {list(basis)}"
            )
        model = noise_model(basis_gates=list(RBS_NATIVE_BASIS), **RBS_NATIVE_NOISE)
        return dict(
            name=name, num_qubits=n, backend=None, coupling_map=CouplingMap.from_full(n),
            basis_gates=RBS_NATIVE_BASIS, noise_model=model if noise else None,
            target=_rbs_native_target(n),
        )

    if name == "all_to_all":
        cmap = CouplingMap.from_full(n)
    elif name == "line":
        cmap = CouplingMap.from_line(n)
    elif name == "ring":
        cmap = CouplingMap.from_ring(n)
    else:
        cmap = CouplingMap.from_heavy_hex(heavy_hex_distance(n))
    width = cmap.size()
    try:
        backend = GenericBackendV2(
            width,
            basis_gates=None if basis is None else list(basis),
            coupling_map=cmap,
            seed=seed_value,
        )
    except Exception as exc:  # GenericBackendV2 raises QiskitError on a basis it cannot use
        raise ValueError(
            f"basis_gates {list(basis) if basis else None} cannot build target {name!r}: {exc}"
        ) from exc
    gates = tuple(g for g in backend.operation_names if g not in _NON_GATES)
    return dict(
        name=name, num_qubits=width, backend=backend, coupling_map=backend.coupling_map,
        basis_gates=gates, noise_model=LazyNoise(backend) if noise else None,
        target=backend.target,
    )
