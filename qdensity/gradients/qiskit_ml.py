"""A qiskit-machine-learning sampler gradient that keeps every circuit weight-preserving.

qiskit-machine-learning's ``ParamShiftSamplerGradient`` re-expresses gates it has no rule for
in its own shift-rule gates (RBS becomes ``rxx``, ``ryy``, ``h``, ...): its shifted circuits
leave the Hamming-weight subspace, so
:class:`~qdensity.execution.samplers.hamming.HammingWeightSampler` refuses them and
``SamplerQNN.backward`` fails. :class:`HammingShiftSamplerGradient` implements qiskit-ml's
:class:`~qiskit_machine_learning.gradients.BaseSamplerGradient` (its ``_run`` hook) with
qdensity's shift rules instead: the four-term rule of the paper (Supp. E, eq. 23) for every
RBS/FBS occurrence, the two-term rule for Pauli rotations, the rule a gate's spectrum gives
otherwise (:func:`~qdensity.gradients.shift.shift_rules`). Every shifted circuit is the circuit
itself at other angles, so a weight-preserving circuit stays weight-preserving; all shifted
rows of all samples of one circuit go to the sampler as one PUB.

Optional extra: ``pip install "qdensity[interop]"`` (qiskit-machine-learning). Nothing in
:mod:`qdensity` imports this module, so ``import qdensity`` never needs it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from qiskit.circuit import Parameter, QuantumCircuit
from qiskit.primitives import BaseSamplerV2
from qiskit.providers import Options

from qdensity.gradients.shift import expand_occurrences, shift_rules
from qdensity.validation import Instance, validates

try:
    from qiskit_machine_learning.gradients import BaseSamplerGradient, SamplerGradientResult
except ImportError as exc:  # pragma: no cover - the interop extra is installed in CI
    raise ImportError("qdensity.gradients.qiskit_ml needs qiskit-machine-learning: "
                      "pip install \"qdensity[interop]\"") from exc

__all__ = ["HammingShiftSamplerGradient"]


class _Template:
    """One circuit's shifted template: the circuit with a fresh parameter per occurrence of the
    differentiated parameters, and per (occurrence, term) the column, move and weight."""

    def __init__(self, circuit: QuantumCircuit, parameters: Sequence[Parameter]):
        params = list(parameters)
        self.expanded, occurrences = expand_occurrences(circuit, params)
        rules = shift_rules(circuit, params)
        col = {p: i for i, p in enumerate(params)}
        src = {p: i for i, p in enumerate(circuit.parameters)}
        fresh_of = {q: p for p, q, _, _ in occurrences}
        exp_params = list(self.expanded.parameters)
        #: expanded parameter -> column of the circuit's parameter row it copies
        self.source = np.array([src[fresh_of.get(p, p)] for p in exp_params], dtype=int)
        exp_index = {p: i for i, p in enumerate(exp_params)}
        cols, moves, weights, outs = [], [], [], []
        for (p, q, a, _), (_, _, rule) in zip(occurrences, rules, strict=True):
            if a == 0:
                raise ValueError(f"parameter {p.name} enters a gate with coefficient 0")
            for s, c in zip(rule.shifts, rule.coeffs, strict=True):
                cols.append(exp_index[q])
                moves.append(s / a)  # the gate angle a * p + b moves by s
                weights.append(a * c)  # d/dp = a * d/d(angle)
                outs.append(col[p])
        self.cols = np.asarray(cols, dtype=int)
        self.moves = np.asarray(moves, dtype=float)
        self.weights = np.asarray(weights, dtype=float)
        self.outs = np.asarray(outs, dtype=int)
        self.num_parameters = len(params)

    @property
    def num_terms(self) -> int:
        """Shifted circuits per parameter row."""
        return len(self.weights)

    def rows(self, values: np.ndarray) -> np.ndarray:
        """Shifted rows ``(B * num_terms, P_expanded)`` for parameter rows ``(B, P)``."""
        base = values[:, self.source]  # (B, P_expanded)
        rows = np.broadcast_to(base[:, None, :], (base.shape[0], self.num_terms,
                                                  base.shape[1])).copy()
        if self.num_terms:
            rows[:, np.arange(self.num_terms), self.cols] += self.moves
        return rows.reshape(-1, base.shape[1])


def _outcomes(pub_result, rows: int) -> tuple[np.ndarray, int]:
    """The measured outcomes as integers (clbit 0 least significant), shape (rows, shots)."""
    bits = pub_result.join_data()
    packed = np.asarray(bits.array).reshape(rows, bits.num_shots, -1)
    if bits.num_bits > 63:
        raise ValueError(f"a circuit with {bits.num_bits} classical bits has outcomes wider "
                         "than 63 bits; HammingShiftSamplerGradient reads up to 63")
    weights = np.left_shift(np.uint64(1), np.arange(packed.shape[-1] - 1, -1, -1,
                                                    dtype=np.uint64) * np.uint64(8))
    ints = (packed.astype(np.uint64) * weights).sum(axis=-1, dtype=np.uint64)
    return ints, bits.num_shots


def _example_sampler() -> BaseSamplerV2:
    from qdensity.execution.samplers.hamming import HammingWeightSampler

    return HammingWeightSampler(seed=0)


@validates(sampler=Instance(BaseSamplerV2, "a qiskit BaseSamplerV2", example=_example_sampler),
           options=[Instance(dict), None])
class HammingShiftSamplerGradient(BaseSamplerGradient):
    """Gradients of a sampler's outcome probabilities by qdensity's shift rules (Supp. E).

    For a circuit with free parameters ``theta`` and outcome probabilities ``p_k(theta)`` it
    returns ``d p_k / d theta_j`` estimated from the sampler's shots: every occurrence of
    ``theta_j`` in a gate of angle ``a theta_j + b`` contributes
    ``a * sum_i c_i p_k(angle + s_i)`` (eq. 23 for RBS/FBS:
    ``s = (pi/4, -pi/4, pi/2, -pi/2)``, ``c = (1, -1, -(sqrt 2 - 1)/2, (sqrt 2 - 1)/2)``).
    The shifted circuits are the circuit's own template at shifted angles: a
    Hamming-weight-preserving circuit stays one, and
    :class:`~qdensity.execution.samplers.hamming.HammingWeightSampler` samples them exactly in
    their subspace. All rows of all samples of one circuit go out as one PUB.

    Parameters
    ----------
    sampler : BaseSamplerV2
        Runs the shifted circuits (e.g. ``HammingWeightSampler(seed=...)``).
    options : dict, optional
        Default run options; ``shots`` (per shifted circuit) is passed to ``sampler.run``
        (None: the sampler's default).

    Notes
    -----
    Circuits must measure (``SamplerQNN`` adds ``measure_all``); outcome keys are the
    integers of the joined classical registers, clbit 0 least significant, as qiskit-ml's own
    gradients give them. Circuits per sample: the sum of the rule terms over the occurrences
    of the differentiated parameters (4 per RBS/FBS, 2 per Pauli rotation), in one PUB with
    every sample, against qiskit-ml's parameter shift that submits one PUB per shifted row of
    its gate-level re-expression.

    Examples
    --------
    >>> from qiskit import QuantumCircuit
    >>> from qiskit.circuit import Parameter
    >>> from qdensity import RBSGate
    >>> from qdensity.execution.samplers.hamming import HammingWeightSampler
    >>> from qdensity.gradients.qiskit_ml import HammingShiftSamplerGradient
    >>> qc = QuantumCircuit(2)
    >>> _ = qc.x(0)
    >>> _ = qc.append(RBSGate(Parameter("t")), [0, 1])
    >>> qc.measure_all()
    >>> grad = HammingShiftSamplerGradient(HammingWeightSampler(seed=1), {"shots": 20000})
    >>> g = grad.run([qc], [[0.3]]).result().gradients[0][0]  # d p_k / d t at t = 0.3
    >>> sorted(g)  # outcomes 1 (|q0=1>, p = cos^2 t) and 2 (|q1=1>, p = sin^2 t)
    [1, 2]
    >>> bool(abs(g[2] - 0.565) < 0.05)  # sin(2 t) = 0.565
    True
    """

    def __init__(self, sampler: BaseSamplerV2, options: dict | None = None):
        super().__init__(sampler, options=options)
        self._templates: dict[tuple, tuple[QuantumCircuit, _Template]] = {}

    def _template(self, circuit: QuantumCircuit, parameters: Sequence[Parameter]) -> _Template:
        key = (id(circuit), tuple(parameters))
        hit = self._templates.get(key)
        # the circuit is kept with its template, so its id is not reused while cached
        if hit is not None and hit[0] is circuit:
            return hit[1]
        if not any(inst.operation.name == "measure" for inst in circuit.data):
            raise ValueError(f"circuit {circuit.name!r} measures nothing; give the circuit "
                             "with its measurements (SamplerQNN adds measure_all)")
        template = _Template(circuit, parameters)
        if len(self._templates) > 64:
            self._templates.clear()
        self._templates[key] = (circuit, template)
        return template

    def _run(self, circuits: Sequence[QuantumCircuit],
             parameter_values: Sequence[Sequence[float]],
             parameters: Sequence[Sequence[Parameter]], **options) -> SamplerGradientResult:
        """Gradients for each ``(circuit, values, parameters)``; one PUB per distinct
        circuit and parameter set, carrying every shifted row of every sample. ``options``
        are the gradient's defaults updated by ``run``'s (``BaseSamplerGradient.run``)."""
        groups: dict[tuple, list[int]] = {}
        for i, (circuit, params) in enumerate(zip(circuits, parameters, strict=True)):
            groups.setdefault((id(circuit), tuple(params)), []).append(i)
        plans, pubs = [], []
        for members in groups.values():
            circuit, params = circuits[members[0]], parameters[members[0]]
            template = self._template(circuit, params)
            values = np.asarray([parameter_values[i] for i in members], dtype=float)
            values = values.reshape(len(members), circuit.num_parameters)
            plans.append((members, template))
            pubs.append((template.expanded, template.rows(values)))
        shots = options.get("shots")
        job = self._sampler.run(pubs, shots=shots) if shots is not None else \
            self._sampler.run(pubs)
        results = job.result()
        gradients: list = [None] * len(circuits)
        for (members, template), pub_result in zip(plans, results, strict=True):
            B, T = len(members), template.num_terms
            per_sample = _combine(pub_result, B, T, template)
            for b, i in enumerate(members):
                gradients[i] = per_sample[b]
        metadata = [{"parameters": list(p)} for p in parameters]
        return SamplerGradientResult(gradients=gradients, metadata=metadata,
                                     options=Options(**options))


def _combine(pub_result, B: int, T: int, template: _Template) -> list[list[dict[int, float]]]:
    """Per sample and parameter, ``{outcome: d p / d theta}`` from the shifted rows' counts."""
    P = template.num_parameters
    if T == 0:
        return [[{} for _ in range(P)] for _ in range(B)]
    ints, shots = _outcomes(pub_result, B * T)
    keys, inverse = np.unique(ints, return_inverse=True)
    inverse = inverse.reshape(B * T, shots)
    K = len(keys)
    flat = (np.arange(B * T)[:, None] * K + inverse).ravel()
    counts = np.bincount(flat, minlength=B * T * K).reshape(B * T, K)
    freqs = counts.reshape(B, T, K) / shots
    # (B, T, K) -> (B, P, K): each term's weight onto its parameter's column
    mix = np.zeros((T, P))
    mix[np.arange(T), template.outs] = template.weights
    grad = np.einsum("btk,tp->bpk", freqs, mix)
    return [[{int(keys[k]): float(grad[b, j, k]) for k in np.flatnonzero(grad[b, j])}
             for j in range(P)] for b in range(B)]
