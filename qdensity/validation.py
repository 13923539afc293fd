"""Input checks shared by every module: one place for the error messages users see.

Every check raises ``ValueError`` or ``TypeError`` naming the argument, the value it got and
what is allowed. Nothing is renormalised or clipped silently.
"""

from __future__ import annotations

import numbers
import os

import numpy as np
from qiskit.circuit import QuantumCircuit

from qdensity import _constraints
from qdensity._constraints import *  # noqa: F403 - the declared vocabulary, re-exported

__all__ = [
    "as_rng", "check_seed", "seed_int", "seed_u32", "check_real_vector", "check_nonzero_vector",
    "check_distribution", "check_rows_sum_to_one", "check_parameter_values",
    "as_parameter_rows", "check_positive_int", "check_circuit", "check_entries",
    "check_real_scalar", "check_finite_array", "check_callable", "check_type",
    "check_sequence_of", "check_engine", "check_target", "check_magnitude", "check_width",
    "MAX_DENSE_QUBITS", "MAX_DENSE_ENTRIES", "check_num_qubits", "check_layers", "SeedLike",
]
__all__ += _constraints.__all__  # the declared vocabulary (qdensity._constraints)

#: Widest register an exact/dense path accepts: a ``2**n`` statevector or probability row of
#: float64/complex128 is 256 MiB at n = 24. Wider circuits go to the unary engine, sampling or MPS.
MAX_DENSE_QUBITS = 24
#: Most entries of a dense ``(rows, 2**n)`` array (2 GiB of float64).
MAX_DENSE_ENTRIES = 2**28

SeedLike = int | np.random.Generator | None


def check_seed(seed, name: str = "seed") -> SeedLike:
    """A seed as every stochastic function takes it: an int ``>= 0``, a Generator or None.

    The one place seeds are checked, so ``seed=-1`` anywhere is refused with a message that
    names the argument (numpy's own says only "expected non-negative integer").

    Parameters
    ----------
    seed : int, numpy.random.Generator or None
    name : str
        Argument name for the error message.

    Returns
    -------
    int, numpy.random.Generator or None
        ``seed`` itself (a numpy integer becomes an int).
    """
    if seed is None or isinstance(seed, np.random.Generator):
        return seed
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, numbers.Integral):
        raise TypeError(f"{name} must be an int >= 0, a numpy.random.Generator or None, got "
                        f"{type(seed).__name__} {seed!r}")
    if seed < 0:
        raise ValueError(f"{name} must be an int >= 0, a numpy.random.Generator or None, got "
                         f"{seed!r}")
    return int(seed)


def as_rng(seed: SeedLike, name: str = "seed") -> np.random.Generator:
    """A ``numpy.random.Generator`` from an int ``>= 0``, a Generator (returned as is) or None.

    Parameters
    ----------
    seed : int, numpy.random.Generator or None
    name : str
        Argument name for the error message (see :func:`check_seed`).

    Returns
    -------
    numpy.random.Generator
    """
    seed = check_seed(seed, name)
    if isinstance(seed, np.random.Generator):
        return seed
    return np.random.default_rng(seed)


def seed_int(seed: SeedLike, name: str = "seed") -> int | None:
    """An integer seed for libraries that need one (Aer's ``seed_simulator``, transpiler).

    Draws from the generator when given one, so a Generator still yields reproducible runs.

    Parameters
    ----------
    seed : int, numpy.random.Generator or None
    name : str
        Argument name for the error message (see :func:`check_seed`).

    Returns
    -------
    int or None
    """
    seed = check_seed(seed, name)
    if isinstance(seed, np.random.Generator):
        return int(seed.integers(0, 2**31 - 1))
    return seed


def seed_u32(seed: SeedLike, name: str = "seed") -> int | None:
    """:func:`seed_int` within ``[0, 2**32 - 1]``, scikit-learn's ``random_state`` range (a
    larger int is refused naming ``name``, not passed on to fail inside scikit-learn)."""
    out = seed_int(seed, name)
    if out is not None and out > 2**32 - 1:
        raise ValueError(f"{name} must be at most 2**32 - 1 = {2**32 - 1} (scikit-learn's "
                         f"random_state range), got {out}")
    return out


def _as_real(values, name: str, what: str) -> np.ndarray:
    """``values`` as a float64 array; complex values (even with zero imaginary parts: the
    math is real), strings and bytes are refused rather than cut or parsed."""
    if isinstance(values, (str, bytes)):
        raise TypeError(f"{name} must be {what}, got {values!r:.80}")
    try:
        raw = values if isinstance(values, np.ndarray) else np.asarray(values)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be {what}, got {values!r:.80}") from exc
    if raw.dtype.kind not in "biufO":
        raise TypeError(f"{name} must be {what}, got an array of dtype {raw.dtype} (complex "
                        f"values are not cut to their real part)")
    try:
        return np.asarray(raw, dtype=float)
    except (TypeError, ValueError) as exc:  # an object array of complex or non-numbers
        raise TypeError(f"{name} must be {what}, got {values!r:.80}") from exc


def check_real_vector(x, name: str, *, min_length: int = 1) -> np.ndarray:
    """A finite real 1-d float array, or a ``ValueError`` naming ``name``.

    Parameters
    ----------
    x : array_like, shape (d,)
    name : str
        Argument name for the error message.
    min_length : int
        Smallest allowed ``d``.

    Returns
    -------
    numpy.ndarray, shape (d,), float64
    """
    arr = _as_real(x, name, "a real vector")
    if arr.ndim != 1:
        raise ValueError(f"{name} must be 1-dimensional, got shape {arr.shape}")
    if arr.size < min_length:
        raise ValueError(f"{name} must have length >= {min_length}, got length {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN or inf), got {arr}")
    return arr


def check_nonzero_vector(x, name: str, *, min_length: int = 2) -> np.ndarray:
    """Like :func:`check_real_vector` and also refuses the zero vector (it has no direction)."""
    arr = check_real_vector(x, name, min_length=min_length)
    if not np.any(arr):
        raise ValueError(f"{name} must not be the zero vector (it cannot be normalised)")
    return arr


def check_distribution(alpha, name: str = "alpha", *, atol: float = 1e-9) -> np.ndarray:
    """A probability vector: finite, non-negative, summing to 1 within ``atol``.

    Parameters
    ----------
    alpha : array_like, shape (K,)
    name : str
    atol : float
        Tolerance on ``|sum(alpha) - 1|``, raised to the rounding of the given precision
        (``K`` times the machine epsilon of a float32 or float16 ``alpha``, which cannot sum
        to 1 within 1e-9). The vector is never renormalised.

    Returns
    -------
    numpy.ndarray, shape (K,)
    """
    arr = check_real_vector(alpha, name, min_length=1)
    if np.any(arr < 0):
        raise ValueError(f"{name} must be non-negative, got {arr}")
    given = getattr(alpha, "dtype", None)
    if given is None and isinstance(alpha, (list, tuple)) and alpha:
        given = np.result_type(*[getattr(a, "dtype", float) for a in alpha])
    if given is not None and np.dtype(given).kind == "f":
        atol = max(atol, arr.size * float(np.finfo(given).eps))
    total = float(arr.sum())
    if abs(total - 1.0) > atol:
        raise ValueError(
            f"{name} must sum to 1 within {atol:g} (it is not renormalised), got sum {total!r}"
        )
    return arr


def check_rows_sum_to_one(probs: np.ndarray, name: str = "probs", *, atol: float = 1e-6) -> None:
    """Refuse probability rows (last axis) that are negative or do not sum to 1 within ``atol``.

    Parameters
    ----------
    probs : numpy.ndarray, shape (..., D)
        Finite floats. Never renormalised.
    name : str
    atol : float
    """
    if np.any(probs < 0):
        raise ValueError(f"{name} must be non-negative, got minimum {probs.min()!r}")
    sums = np.atleast_1d(probs.sum(axis=-1)).ravel()
    off = np.flatnonzero(np.abs(sums - 1.0) > atol)
    if off.size:
        raise ValueError(
            f"{name} rows must sum to 1 within {atol:g} (they are not renormalised); rows "
            f"{off[:10].tolist()} sum to {sums[off[:10]].tolist()}"
        )


def check_parameter_values(values, num_parameters: int, name: str = "values") -> np.ndarray:
    """Parameter rows for a circuit with ``num_parameters`` parameters.

    Parameters
    ----------
    values : array_like, shape (P,) or (B, P)
    num_parameters : int
    name : str

    Returns
    -------
    numpy.ndarray, shape (P,) or (B, P)
        Same number of dimensions as given.
    """
    arr = _as_real(values, name, "real numbers")
    if arr.ndim not in (1, 2) or arr.shape[-1] != num_parameters:
        raise ValueError(
            f"{name} must have shape ({num_parameters},) or (rows, {num_parameters}) "
            f"(one value per circuit parameter, in circuit.parameters order), got {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got non-finite entries")
    return arr


def as_parameter_rows(values, num_parameters: int, name: str = "values") -> np.ndarray:
    """Parameter rows as a 2-d array ``(rows, P)``; ``(P,)`` becomes one row.

    For a circuit without parameters, ``None`` or an empty array gives one empty row.

    Parameters
    ----------
    values : array_like, shape (P,) or (rows, P), or None when P == 0
    num_parameters : int
    name : str

    Returns
    -------
    numpy.ndarray, shape (rows, P)
    """
    if num_parameters == 0 and (values is None or np.size(values) == 0):
        rows = 1 if values is None or np.ndim(values) < 2 else max(np.shape(values)[0], 1)
        return np.zeros((rows, 0))
    arr = check_parameter_values(values, num_parameters, name)
    return arr[None, :] if arr.ndim == 1 else arr


def check_nonnegative_float(value, name: str) -> float:
    """A finite real number ``>= 0`` (e.g. a noise standard deviation)."""
    if isinstance(value, (bool, np.bool_, str, bytes)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {value!r:.80}")
    out = float(value)
    if not np.isfinite(out) or out < 0:
        raise ValueError(f"{name} must be finite and >= 0, got {value!r}")
    return out


def check_positive_int(value, name: str, *, minimum: int = 1, maximum: int | None = None,
                       why: str = "") -> int:
    """An int ``>= minimum`` (and ``<= maximum`` when given; bools refused).

    ``why`` explains the maximum in the message.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an int, got {value!r}")
    if int(value) < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    if maximum is not None and int(value) > maximum:
        raise ValueError(f"{name} must be <= {maximum}{' (' + why + ')' if why else ''}, "
                         f"got {value}")
    return int(value)


def check_num_qubits(value, name: str = "num_qubits", *, minimum: int = 1) -> int:
    """A circuit width for a builder: an int in ``[minimum, MAX_CIRCUIT_QUBITS]``."""
    return check_positive_int(value, name, minimum=minimum, maximum=_constraints.MAX_CIRCUIT_QUBITS,
                              why="wider circuits are beyond any device and take minutes "
                              "to build")


def check_layers(value, name: str = "layers", *, minimum: int = 1) -> int:
    """A repetition count for a builder: an int in ``[minimum, MAX_LAYERS]``."""
    return check_positive_int(value, name, minimum=minimum, maximum=_constraints.MAX_LAYERS,
                              why="deeper circuits take minutes to build")


def check_entries(shape: tuple[int, ...], name: str) -> None:
    """Refuse a parameter array of ``shape`` with more than :data:`MAX_DENSE_ENTRIES` entries
    (2 GiB of float64) before it is allocated; ``name`` says what the array is."""
    total = 1
    for s in shape:
        total *= int(s)
    if total > MAX_DENSE_ENTRIES:
        raise ValueError(f"{name} would hold {total} numbers (shape {tuple(shape)}), more than "
                         f"{MAX_DENSE_ENTRIES} (2 GiB of float64); use smaller sizes")


def check_circuit(circuit, name: str = "circuit") -> QuantumCircuit:
    """A ``QuantumCircuit`` or a ``TypeError`` naming ``name``."""
    if not isinstance(circuit, QuantumCircuit):
        raise TypeError(f"{name} must be a qiskit QuantumCircuit, got {type(circuit).__name__}")
    return circuit


def check_real_scalar(value, name: str) -> float:
    """A finite real number (bools and strings refused), e.g. a gate angle.

    Parameters
    ----------
    value : real number
    name : str

    Returns
    -------
    float
    """
    if isinstance(value, (bool, np.bool_, str, bytes)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {value!r}")
    out = float(value)
    if not np.isfinite(out):
        raise ValueError(f"{name} must be finite (no NaN or inf), got {value!r}")
    return out


def check_finite_array(values, name: str, shape: tuple[int, ...] | None = None) -> np.ndarray:
    """A finite real float array, optionally of a given shape.

    Parameters
    ----------
    values : array_like
    name : str
    shape : tuple of int, optional
        Required shape.

    Returns
    -------
    numpy.ndarray, float64
    """
    arr = _as_real(values, name, "real numbers")
    if shape is not None and arr.shape != tuple(shape):
        raise ValueError(f"{name} must have shape {tuple(shape)}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    return arr


def check_callable(value, name: str, what: str = "a callable"):
    """``value`` if it is callable, else a ``TypeError`` naming ``name`` and ``what``."""
    if not callable(value):
        raise TypeError(f"{name} must be {what}, got {type(value).__name__} {value!r}")
    return value


def check_type(value, name: str, types, expected: str, *, allow_none: bool = False):
    """``value`` if it is an instance of ``types`` (or None with ``allow_none``), else a
    ``TypeError`` naming ``name``, what is ``expected`` in words, and what came."""
    if value is None and allow_none:
        return value
    if not isinstance(value, types):
        extra = " or None" if allow_none else ""
        raise TypeError(f"{name} must be {expected}{extra}, got {type(value).__name__} "
                        f"{value!r:.80}")
    return value


def check_sequence_of(values, name: str, types, expected: str) -> list:
    """``values`` as a list whose every item is an instance of ``types`` (``TypeError`` naming
    ``name`` or ``name[i]`` otherwise; a lone item, a string or a non-iterable is refused)."""
    if isinstance(values, (str, bytes, types)) or not hasattr(values, "__iter__"):
        raise TypeError(f"{name} must be a sequence of {expected}, got "
                        f"{type(values).__name__} {values!r:.80}")
    out = list(values)
    for i, v in enumerate(out):
        if not isinstance(v, types):
            raise TypeError(f"{name}[{i}] must be a {expected}, got {type(v).__name__} "
                            f"{v!r:.80}")
    return out


def check_engine(engine, name: str = "engine"):
    """An engine (anything with ``run(jobs)``: ExactEngine, SamplerEngine, AdjointEngine)."""
    if not callable(getattr(engine, "run", None)):
        raise TypeError(f"{name} must be an engine with run(jobs) (ExactEngine, SamplerEngine, "
                        f"AdjointEngine), got {type(engine).__name__} {engine!r:.80}")
    return engine


def check_target(target, name: str = "target"):
    """Anything a target may be given as, or None: a ``HardwareTarget``, a target name or
    snapshot path, a ``BackendV2`` or a ``qiskit.transpiler.Target`` (``as_target`` in
    ``qdensity.hardware.targets`` builds each; this only refuses the wrong types, by name)."""
    if target is None or isinstance(target, (str, os.PathLike)):
        return target
    if all(callable(getattr(target, a, None)) for a in ("simulator", "transpile")):
        return target
    from qiskit.providers import BackendV2
    from qiskit.transpiler import Target

    if isinstance(target, (BackendV2, Target)):
        return target
    raise TypeError(f"{name} must be a HardwareTarget, a target name or snapshot path, a "
                    f"BackendV2 or a qiskit.transpiler.Target "
                    f"(qdensity.hardware.targets.get_target), "
                    f"or None; got {type(target).__name__} {target!r:.80}")


def check_magnitude(values: np.ndarray, name: str, hint: str) -> None:
    """Refuse finite data whose squares overflow float64 (losses and norms would be inf/NaN).

    Parameters
    ----------
    values : numpy.ndarray
    name : str
    hint : str
        How to scale the data (for the message).
    """
    with np.errstate(over="ignore"):
        total = float(np.sum(np.square(values)))
    if not np.isfinite(total):
        raise ValueError(f"{name} is too large: its squares overflow float64 (largest |{name}| "
                         f"= {float(np.max(np.abs(values))):.3g}); {hint}")


def check_width(
    num_qubits: int,
    *,
    limit: int = MAX_DENSE_QUBITS,
    engine: str = "this exact path",
    alternative: str = "the unary engine (RBS/FBS circuits), sampling (SamplerEngine) or an "
    "MPS simulator",
    rows: int = 1,
) -> int:
    """Refuse a register too wide for a dense ``2**num_qubits`` array, before allocating it.

    Every exact and dense path (the exact engine, statevector prediction, probability rows,
    commuting-gradient diagonals, tomography) calls this with its own ``limit``; the message
    names the limit and what to use instead.

    Parameters
    ----------
    num_qubits : int
        Width ``n`` of the dense register (qubits or measured bits).
    limit : int
        Largest ``n`` accepted.
    engine : str
        What refuses (for the message).
    alternative : str
        What handles wider circuits.
    rows : int
        Rows of a dense ``(rows, 2**n)`` array; refused if ``rows * 2**n`` exceeds
        :data:`MAX_DENSE_ENTRIES`.

    Returns
    -------
    int
        ``num_qubits``.

    Examples
    --------
    >>> check_width(4, engine="ExactEngine")
    4
    """
    n = check_positive_int(num_qubits, "num_qubits", minimum=0)
    if n > limit:
        raise ValueError(
            f"{engine} accepts at most {limit} qubits (it holds 2**n numbers), got {n}; "
            f"for wider circuits use {alternative}"
        )
    if rows > 1 and rows * 2**n > MAX_DENSE_ENTRIES:
        raise ValueError(
            f"{engine} would hold {rows} rows of 2**{n} numbers ({rows * 2**n} > "
            f"{MAX_DENSE_ENTRIES}); split the rows into smaller batches or use {alternative}"
        )
    return n
