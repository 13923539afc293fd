"""Readout errors as the classical channel they are: each measured bit flips with the
probability of its qubit and its value (``p(1|0)``, ``p(0|1)``), independently per shot and
clbit, as qiskit-aer applies a single-qubit ``ReadoutError`` to every ``measure`` (the flips
themselves: :func:`~qdensity.execution.samplers._hamming_bits.flip_readout`).

:func:`readout_channel` reads the probabilities from numbers, a qiskit-aer ``NoiseModel``
(whose every other error is gate noise, refused by name), a qdensity ``HardwareTarget``, a
``BackendV2`` or a ``qiskit.transpiler.Target`` (the ``measure`` instruction's
``InstructionProperties.error``, symmetric, as qiskit-aer's ``basic_device_readout_errors``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from qiskit.providers import BackendV2
from qiskit.transpiler import Target
from qiskit_aer.noise import NoiseModel

_ALTERNATIVE = ("sample with qiskit-aer instead (SamplerEngine(hamming_weight='never') or the "
                "target's sampler)")


@dataclass(frozen=True)
class ReadoutChannel:
    """Per-qubit flip probabilities: ``p01[q] = p(1|0)``, ``p10[q] = p(0|1)``; qubits beyond
    the arrays take ``default`` (None: refused)."""

    p01: np.ndarray
    p10: np.ndarray
    default: tuple | None
    source: str

    def for_qubits(self, qubits: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(p01, p10)`` of each qubit in ``qubits``."""
        qubits = np.asarray(qubits, dtype=np.int64)
        size = self.p01.size
        if qubits.size and qubits.max() >= size and self.default is None:
            raise ValueError(
                f"readout_error ({self.source}) gives errors for {size} qubits but the circuit "
                f"measures qubit {int(qubits.max())}; give one (p(1|0), p(0|1)) pair per qubit")
        d01, d10 = self.default if self.default is not None else (0.0, 0.0)
        inside = qubits < size
        p01 = np.where(inside, self.p01[np.minimum(qubits, max(size - 1, 0))] if size else d01,
                       d01)
        p10 = np.where(inside, self.p10[np.minimum(qubits, max(size - 1, 0))] if size else d10,
                       d10)
        return p01.astype(float), p10.astype(float)


def _prob(value, name: str) -> float:
    p = float(value)
    if not 0.0 <= p <= 1.0:
        raise ValueError(f"{name} must be a probability in [0, 1], got {value!r}")
    return p


def _from_noise_model(model: NoiseModel, source: str) -> ReadoutChannel | None:
    per: dict[int, tuple] = {}
    default = None
    for err in model.to_dict().get("errors", []):
        if err.get("type") != "roerror":
            ops = err.get("operations") or ["?"]
            raise ValueError(
                f"HammingWeightSampler cannot sample with {source}: it holds gate noise on "
                f"{ops[0]!r}; only readout errors are a classical channel on the drawn bits; "
                f"{_ALTERNATIVE}")
        probs = np.asarray(err["probabilities"], dtype=float)
        if probs.shape != (2, 2):
            raise ValueError(f"{source} holds a correlated readout error of shape "
                             f"{probs.shape}; only single-qubit readout errors are supported; "
                             f"{_ALTERNATIVE}")
        pair = (float(probs[0, 1]), float(probs[1, 0]))
        if err.get("gate_qubits"):
            for qs in err["gate_qubits"]:
                per[int(qs[0])] = pair
        else:
            default = pair
    if default is None and not per:
        return None
    size = max(per) + 1 if per else 0
    d = default if default is not None else (0.0, 0.0)
    pairs = np.array([per.get(q, d) for q in range(size)], dtype=float).reshape(size, 2)
    return ReadoutChannel(pairs[:, 0].copy(), pairs[:, 1].copy(), d, source)


def _from_target(target: Target, source: str) -> ReadoutChannel | None:
    for name in target.operation_names:
        if name in ("measure", "delay", "reset", "barrier"):
            continue
        props = target[name]
        for qargs, prop in (props or {}).items():
            if prop is not None and prop.error:
                raise ValueError(
                    f"HammingWeightSampler cannot sample with {source}: its {name!r} on qubits "
                    f"{list(qargs or ())} has error {prop.error:g} (gate noise); only readout "
                    f"errors are a classical channel on the drawn bits; {_ALTERNATIVE}")
    if "measure" not in target.operation_names:
        return None
    errs = np.zeros(target.num_qubits)
    for qargs, prop in (target["measure"] or {}).items():
        if qargs and prop is not None and prop.error:
            errs[qargs[0]] = _prob(prop.error, f"{source} measure error on qubit {qargs[0]}")
    if not np.any(errs):
        return None
    return ReadoutChannel(errs, errs.copy(), None, source)


def readout_channel(spec) -> ReadoutChannel | None:
    """The readout channel of ``spec`` (see :class:`~qdensity.HammingWeightSampler`).

    Parameters
    ----------
    spec : None, float, array_like of shape (2,) or (n, 2), NoiseModel, HardwareTarget,
        BackendV2 or qiskit.transpiler.Target
        A float is ``p(1|0) = p(0|1)`` on every qubit; a pair ``(p(1|0), p(0|1))`` the same on
        every qubit; shape ``(n, 2)`` one pair per qubit.

    Returns
    -------
    ReadoutChannel or None
        None when no bit ever flips.

    Raises
    ------
    ValueError
        Probabilities outside [0, 1], a wrong shape, or gate noise (naming the instruction).
    TypeError
        Any other type.
    """
    from qdensity.hardware.targets import HardwareTarget

    if spec is None or isinstance(spec, ReadoutChannel):
        return spec
    if isinstance(spec, HardwareTarget):
        if not spec.is_noisy:
            return None
        return _from_noise_model(spec.noise_model, f"target {spec.name!r}'s noise model")
    if isinstance(spec, NoiseModel):
        return _from_noise_model(spec, "the noise model")
    if isinstance(spec, BackendV2):
        return _from_target(spec.target, f"backend {spec.name!r}")
    if isinstance(spec, Target):
        return _from_target(spec, "the target")
    if isinstance(spec, (bool, np.bool_)) or not isinstance(spec, (int, float, np.number, list,
                                                                     tuple, np.ndarray)):
        raise TypeError(f"readout_error must be None, a probability, an array of (p(1|0), "
                        f"p(0|1)) pairs, a NoiseModel, a HardwareTarget, a BackendV2 or a "
                        f"Target, got {type(spec).__name__}")
    try:
        arr = np.asarray(spec, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"readout_error must hold real numbers, got {spec!r}") from exc
    if arr.ndim == 0:
        p = _prob(arr, "readout_error")
        return None if p == 0 else ReadoutChannel(np.zeros(0), np.zeros(0), (p, p), "a float")
    if arr.shape == (2,) or (arr.ndim == 2 and arr.shape[1] == 2):
        if not np.all(np.isfinite(arr)) or np.any(arr < 0) or np.any(arr > 1):
            raise ValueError(f"readout_error must hold probabilities in [0, 1], got {spec!r}")
        if arr.ndim == 1:
            pair = (float(arr[0]), float(arr[1]))
            return None if not any(pair) else ReadoutChannel(np.zeros(0), np.zeros(0), pair,
                                                             "one pair")
        return ReadoutChannel(arr[:, 0].copy(), arr[:, 1].copy(), None,
                              f"{arr.shape[0]} per-qubit pairs")
    raise ValueError(f"readout_error must be a probability, a pair (p(1|0), p(0|1)) or an array "
                     f"of shape (num_qubits, 2), got shape {arr.shape}")
