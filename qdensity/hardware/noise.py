"""Noise models for noisy execution on qiskit-aer: from parameters or from a backend.

The paper motivates density QNNs by what they cost on depth-limited hardware (Introduction;
Fig. 1c: the randomised preparation runs one sub-unitary per shot) but states its results for
ideal circuits. To ask how a model fares on a device we run it under a
``qiskit_aer.noise.NoiseModel``. Two sources:

* :func:`noise_model` builds one from a handful of physical parameters: depolarizing errors on
  one- and two-qubit gates, thermal relaxation from ``T1``, ``T2`` and the gate times (composed
  after the depolarizing error, as ``NoiseModel.from_backend`` does), and a symmetric readout
  error. The same model applies to every qubit.
* :func:`noise_from_backend` reads the per-qubit, per-gate errors of a ``BackendV2`` (for
  example a seeded ``GenericBackendV2``) through ``NoiseModel.from_backend``.

Conventions
-----------
Z rotations (``rz``, ``p``, ``u1``, ``z``, ``s``, ``sdg``, ``t``, ``tdg``) are frame changes on
superconducting and trapped-ion hardware: zero duration and no error. Every other one-qubit gate
of the basis gets the one-qubit error (``id`` included, so a chain of ``id`` gates is an idle of
that many one-qubit gate times), every two-qubit gate the two-qubit error. The depolarizing
channel with parameter ``lambda`` on ``n`` qubits is ``rho -> (1 - lambda) rho + lambda I / 2^n``.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence

from qiskit.circuit.library import get_standard_gate_name_mapping
from qiskit.providers import BackendV2
from qiskit_aer.noise import (
    NoiseModel,
    QuantumError,
    ReadoutError,
    depolarizing_error,
    thermal_relaxation_error,
)

__all__ = ["noise_model", "noise_from_backend", "VIRTUAL_GATES", "DEFAULT_BASIS_GATES"]

#: Gates treated as frame changes (zero duration, no error) by :func:`noise_model`.
VIRTUAL_GATES = frozenset({"rz", "p", "u1", "z", "s", "sdg", "t", "tdg"})

#: Basis used by :func:`noise_model` when none is given (IBM Heron-like).
DEFAULT_BASIS_GATES = ("cz", "rz", "sx", "x")

#: Instructions that are not gates; allowed in a basis, they carry no gate error.
_NON_GATES = frozenset({"measure", "reset", "delay", "barrier"})


def noise_model(
    *,
    depolarizing_1q: float = 0.0,
    depolarizing_2q: float = 0.0,
    t1: float | None = None,
    t2: float | None = None,
    gate_time_1q: float | None = None,
    gate_time_2q: float | None = None,
    readout_error: float = 0.0,
    basis_gates: Sequence[str] | None = None,
) -> NoiseModel:
    r"""A uniform noise model from physical parameters.

    Every non-virtual one-qubit gate of ``basis_gates`` gets the channel
    ``R_1 o D_1`` (depolarizing ``D_1`` with parameter ``depolarizing_1q``, then thermal
    relaxation ``R_1`` over ``gate_time_1q``); every two-qubit gate gets ``R_2 o D_2`` with
    ``R_2 = R(gate_time_2q) (x) R(gate_time_2q)``; every measurement flips its outcome with
    probability ``readout_error``. Thermal relaxation over time ``t`` (ground-state
    equilibrium) maps a one-qubit state to

    .. math::

        \begin{pmatrix} \rho_{00} + (1 - e^{-t/T_1}) \rho_{11} & e^{-t/T_2} \rho_{01} \\
        e^{-t/T_2} \rho_{10} & e^{-t/T_1} \rho_{11} \end{pmatrix}.

    Parameters
    ----------
    depolarizing_1q, depolarizing_2q : float, optional
        Depolarizing parameters ``lambda`` in ``[0, 1]`` (``rho -> (1-lambda) rho +
        lambda I/2^n``) for one- and two-qubit gates. Default 0.
    t1 : float or None, optional
        Energy relaxation time ``T1 > 0`` (``math.inf`` allowed). ``None`` with ``t2`` given
        means ``T1 = inf`` (pure dephasing).
    t2 : float or None, optional
        Coherence time ``0 < T2 <= 2 T1``. ``None`` with ``t1`` given means ``T2 = 2 T1``
        (relaxation-limited, no pure dephasing).
    gate_time_1q, gate_time_2q : float or None, optional
        Gate durations ``> 0`` in the same unit as ``t1``/``t2``. Required when relaxation is
        on and the basis has (non-virtual) gates of that size; refused without ``t1``/``t2``.
    readout_error : float, optional
        Symmetric bit-flip probability of every measurement, in ``[0, 1]``. Default 0.
    basis_gates : sequence of str or None, optional
        Standard gate names of the device, plus optionally ``measure``/``reset``/``delay``.
        Default ``("cz", "rz", "sx", "x")``. Gates on three or more qubits are refused (no
        error model for them).

    Returns
    -------
    qiskit_aer.noise.NoiseModel
        With ``basis_gates`` as its basis; ideal (no errors) when every parameter is off.

    Raises
    ------
    ValueError
        Probabilities outside ``[0, 1]``, non-positive times, ``T2 > 2 T1``, a missing or
        unused gate time, an unknown gate name or a gate on more than two qubits.

    Examples
    --------
    >>> nm = noise_model(depolarizing_2q=0.01, t1=100e-6, t2=80e-6,
    ...                  gate_time_1q=50e-9, gate_time_2q=300e-9, readout_error=0.02)
    >>> sorted(nm.noise_instructions)
    ['cz', 'measure', 'sx', 'x']
    """
    p1 = _check_probability(depolarizing_1q, "depolarizing_1q")
    p2 = _check_probability(depolarizing_2q, "depolarizing_2q")
    pr = _check_probability(readout_error, "readout_error")
    basis, gates_1q, gates_2q = _split_basis(basis_gates)

    relax = t1 is not None or t2 is not None
    if relax:
        t1_val = math.inf if t1 is None else _check_time(t1, "t1", allow_inf=True)
        t2_val = 2.0 * t1_val if t2 is None else _check_time(t2, "t2", allow_inf=True)
        if t2_val > 2.0 * t1_val:
            raise ValueError(
                f"t2 must satisfy t2 <= 2 * t1 (a physical qubit), got t1={t1_val!r}, t2={t2_val!r}"
            )
        if math.isinf(t1_val) and math.isinf(t2_val):
            raise ValueError("t1 and t2 cannot both be infinite when given (no relaxation at all)")
    else:
        t1_val = t2_val = math.inf
        for value, name in ((gate_time_1q, "gate_time_1q"), (gate_time_2q, "gate_time_2q")):
            if value is not None:
                raise ValueError(
                    f"{name}={value!r} has no effect without t1 or t2; give t1/t2 or drop it"
                )

    model = NoiseModel(basis_gates=list(basis))

    error_1q = _gate_error(
        p1, 1, relax, t1_val, t2_val, gate_time_1q, "gate_time_1q", bool(gates_1q)
    )
    error_2q = _gate_error(
        p2, 2, relax, t1_val, t2_val, gate_time_2q, "gate_time_2q", bool(gates_2q)
    )
    if error_1q is not None and gates_1q:
        model.add_all_qubit_quantum_error(error_1q, list(gates_1q))
    if error_2q is not None and gates_2q:
        model.add_all_qubit_quantum_error(error_2q, list(gates_2q))
    if pr > 0.0:
        model.add_all_qubit_readout_error(ReadoutError([[1.0 - pr, pr], [pr, 1.0 - pr]]))
    return model


def noise_from_backend(backend: BackendV2) -> NoiseModel:
    """The noise model of a ``BackendV2`` (per-qubit T1/T2, gate and readout errors).

    A thin, checked wrapper of ``NoiseModel.from_backend``. For a ``GenericBackendV2`` built
    with a fixed ``seed`` the sampled errors, and hence this model, are reproducible.

    Parameters
    ----------
    backend : qiskit.providers.BackendV2

    Returns
    -------
    qiskit_aer.noise.NoiseModel

    Examples
    --------
    >>> from qiskit.providers.fake_provider import GenericBackendV2
    >>> nm = noise_from_backend(GenericBackendV2(3, seed=1))
    >>> "cx" in nm.noise_instructions
    True
    """
    if not isinstance(backend, BackendV2):
        raise TypeError(
            f"backend must be a qiskit BackendV2 (e.g. GenericBackendV2), "
            f"got {type(backend).__name__}"
        )
    return NoiseModel.from_backend(backend)


# ----------------------------------------------------------------------------------------------
# helpers


def _gate_error(
    p: float,
    num_qubits: int,
    relax: bool,
    t1: float,
    t2: float,
    gate_time: float | None,
    time_name: str,
    needed: bool,
) -> QuantumError | None:
    """``R o D`` on ``num_qubits`` qubits, or None when both parts are off."""
    error = depolarizing_error(p, num_qubits) if p > 0.0 else None
    if relax:
        if gate_time is None:
            if needed:
                raise ValueError(
                    f"{time_name} is required with t1/t2: the basis has "
                    f"{num_qubits}-qubit gates that relax during their duration"
                )
            return error
        tg = _check_time(gate_time, time_name, allow_inf=False)
        relax_error = thermal_relaxation_error(t1, t2, tg)
        if num_qubits == 2:
            relax_error = relax_error.expand(thermal_relaxation_error(t1, t2, tg))
        error = relax_error if error is None else error.compose(relax_error)
    return error


def _split_basis(basis_gates) -> tuple[tuple[str, ...], tuple[str, ...], tuple[str, ...]]:
    """(basis, noisy 1q gates, 2q gates) from a basis, checked against the standard gates."""
    if basis_gates is None:
        basis = DEFAULT_BASIS_GATES
    else:
        if isinstance(basis_gates, str) or not isinstance(basis_gates, Sequence):
            raise TypeError(
                f"basis_gates must be a sequence of gate names, got {basis_gates!r}"
            )
        basis = tuple(basis_gates)
    mapping = get_standard_gate_name_mapping()
    gates_1q: list[str] = []
    gates_2q: list[str] = []
    for name in basis:
        if not isinstance(name, str):
            raise TypeError(f"basis_gates entries must be str, got {name!r}")
        if name in _NON_GATES:
            continue
        if name not in mapping:
            raise ValueError(
                f"basis_gates entry {name!r} is not a standard gate name; allowed: "
                f"{sorted(set(mapping) - {'global_phase'})} and {sorted(_NON_GATES)}"
            )
        width = mapping[name].num_qubits
        if width == 1:
            if name not in VIRTUAL_GATES:
                gates_1q.append(name)
        elif width == 2:
            gates_2q.append(name)
        else:
            raise ValueError(
                f"basis_gates entry {name!r} acts on {width} qubits; noise_model only models "
                "one- and two-qubit gates (transpile to a 1q/2q basis first)"
            )
    return basis, tuple(gates_1q), tuple(gates_2q)


def _check_probability(value, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number in [0, 1], got {value!r}")
    value = float(value)
    if not 0.0 <= value <= 1.0:  # also refuses NaN
        raise ValueError(f"{name} must be a probability in [0, 1], got {value!r}")
    return value


def _check_time(value, name: str, *, allow_inf: bool) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a positive real number, got {value!r}")
    value = float(value)
    if math.isnan(value) or value <= 0.0 or (math.isinf(value) and not allow_inf):
        allowed = "> 0 (math.inf allowed)" if allow_inf else "> 0 and finite"
        raise ValueError(f"{name} must be {allowed}, got {value!r}")
    return value
