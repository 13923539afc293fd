"""Density QNN models (paper eq. 1, eq. 2, eq. 3).

``rho(theta, alpha, x) = sum_k alpha_k(x) U_k(theta_k) rho(x) U_k(theta_k)^dagger``, ``rho(x) =
V(x)|0><0|V(x)^dagger`` (:class:`Encoding`, re-exported here); the output ``f(x) = sum_k alpha_k(x)
f_k(x)``: ``f_k = Tr(O U_k rho(x) U_k^dagger)`` (observable readout) or the mixture of the
sub-unitaries' unary probability (or amplitude) vectors.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from qiskit.circuit import QuantumCircuit
from qiskit.quantum_info import SparsePauliOp

from qdensity.circuits._copying import concatenate
from qdensity.execution.observables import check_observable
from qdensity.execution.plans import Plan, expectation_plan
from qdensity.models._derived import DerivedStore, structure_key
from qdensity.models._rows import bind_rows, model_rows
from qdensity.models.decompositions import DATA_PREFIX, trainable_parameters
from qdensity.models.dropout import randomised_loss_and_grad as _randomised_loss_and_grad
from qdensity.models.encoding import Encoding
from qdensity.models.mixtures import Mixture, as_mixture
from qdensity.validation import (
    MAX_SUBUNITARIES,
    Array,
    Circuit,
    Instance,
    Interval,
    Observable,
    Options,
    Seed,
    SequenceOf,
    as_rng,
    check_circuit,
    check_finite_array,
    check_sequence_of,
    check_width,
    refuse,
    validates,
)

__all__ = ["Encoding", "DensityQNN", "READOUTS", "bind_rows"]

READOUTS = ("observable", "unary_probabilities", "unary_amplitudes")


@validates(
    sub_unitaries=[Circuit(min_qubits=1),
                   SequenceOf(Circuit(min_qubits=1), max_len=MAX_SUBUNITARIES)],
    mixture=[Instance(Mixture), Array(ndim=1, max_size=MAX_SUBUNITARIES), None],
    encoding=[Instance(Encoding), None], observable=[Observable(), None],
    readout=Options(READOUTS), seed=Seed(),
)
class DensityQNN:
    r"""A density QNN, :math:`\rho = \sum_k \alpha_k U_k \rho(x) U_k^\dagger` (paper eq. 1 and 2).

    Parameters
    ----------
    sub_unitaries : sequence of QuantumCircuit
        ``U_1 .. U_K`` on the same ``n`` qubits. Parameters may be shared between them
        (Prop. 1) or independent (Cor. 1). Parameters in a vector named ``"x"`` are data
        (re-uploading): ``x[i]`` is set to feature ``i``.
    mixture : Mixture or array_like, optional
        :class:`~qdensity.models.mixtures.FixedMixture` (or an alpha vector),
        :class:`~qdensity.models.mixtures.SoftmaxMixture` or
        :class:`~qdensity.models.mixtures.GatedMixture`. Default: uniform, fixed.
    encoding : Encoding, optional
        ``V(x)``. Default: none (sub-unitaries act on ``|0...0>`` or upload data themselves).
    observable : SparsePauliOp, optional
        ``O`` for ``readout="observable"`` (default ``Z`` on qubit 0).
    readout : {"observable", "unary_probabilities", "unary_amplitudes"}
        Unary readouts need a unary encoding and Hamming-weight-preserving sub-unitaries;
        probabilities :math:`\operatorname{Tr}(|e_j\rangle\langle e_j| \rho)`; amplitudes mix
        the sub-unitaries' outputs :math:`\sum_k \alpha_k O_k x` (mixture of experts, Supp. H).
    seed : int or Generator, optional
        Initial angles uniform in :math:`[-\pi, \pi)` (zeros when None).

    Attributes
    ----------
    theta : numpy.ndarray, shape (P,)
        Trainable angles in :attr:`parameters` order.
    parameters : list of Parameter
        Union of the sub-unitaries' trainable parameters, in order of first appearance.

    Examples
    --------
    >>> from qdensity.circuits.ansatze import round_robin
    >>> from qdensity.models.decompositions import by_moments
    >>> dec = by_moments(round_robin(4))
    >>> model = DensityQNN(dec.sub_unitaries, encoding=Encoding.unary(4),
    ...                    readout="unary_probabilities", seed=0)
    >>> model.predict([[1.0, 2.0, 3.0, 4.0]]).shape
    (1, 4)
    """

    def __init__(
        self,
        sub_unitaries: Sequence[QuantumCircuit],
        mixture: Mixture | Sequence[float] | np.ndarray | None = None,
        *,
        encoding: Encoding | None = None,
        observable: SparsePauliOp | str | None = None,
        readout: str = "observable",
        seed=None,
    ):
        subs = [sub_unitaries] if isinstance(sub_unitaries, QuantumCircuit) else list(
            sub_unitaries)
        widths = {c.num_qubits for c in subs}
        if len(widths) > 1:
            raise ValueError(f"sub_unitaries must all have the same width, got widths "
                             f"{[c.num_qubits for c in subs]}")
        self.num_qubits = subs[0].num_qubits
        if encoding is not None and encoding.circuit.num_qubits != self.num_qubits:
            raise ValueError(f"encoding acts on {encoding.circuit.num_qubits} qubits but the "
                             f"sub-unitaries on {self.num_qubits}")
        if readout != "observable":
            from qdensity.analysis.structure import is_hamming_weight_preserving

            if encoding is None or encoding.kind != "unary":
                raise ValueError(f"readout={readout!r} needs a unary encoding (Encoding.unary)")
            bad = [i for i, c in enumerate(subs) if not is_hamming_weight_preserving(c)]
            if bad:
                raise ValueError(f"readout={readout!r} needs Hamming-weight-preserving "
                                 f"sub-unitaries; sub_unitaries{bad} are not")
        self._derived = DerivedStore()
        self._subs = subs
        self._reindex()
        self.encoding = encoding
        self.readout = readout
        if observable is None:
            observable = SparsePauliOp.from_sparse_list([("Z", [0], 1.0)], self.num_qubits)
        self.observable = observable
        self.mixture = as_mixture(mixture, len(subs))
        gate_features = getattr(self.mixture, "num_features", None)
        if gate_features is not None and encoding is not None and (
                gate_features != encoding.num_features):
            raise refuse("DensityQNN", "mixture", self.mixture,
                         f"a gate on the encoding's {encoding.num_features} features",
                         f"the gate reads {gate_features} features")
        self.theta = (as_rng(seed).uniform(-np.pi, np.pi, len(self.parameters))
                      if seed is not None else np.zeros(len(self.parameters)))
        self.training = True

    def _reindex(self) -> None:
        self.parameters = list(dict.fromkeys(p for c in self._subs
                                             for p in trainable_parameters(c)))
        self._index = {p: i for i, p in enumerate(self.parameters)}

    # ------------------------------------------------------------------ structure
    @property
    def sub_unitaries(self) -> list[QuantumCircuit]:
        """``U_1 .. U_K``. Setting a new list re-reads :attr:`parameters`; :attr:`theta` is
        kept when the parameter count stays, else reset to zeros (as a model without seed)."""
        return self._subs

    @sub_unitaries.setter
    def sub_unitaries(self, value) -> None:
        subs = [value] if isinstance(value, QuantumCircuit) else list(
            check_sequence_of(value, "sub_unitaries", QuantumCircuit, "QuantumCircuit"))
        if not subs or any(c.num_qubits != self.num_qubits for c in subs):
            raise ValueError(f"sub_unitaries must be at least one circuit on {self.num_qubits} "
                             f"qubits (the model's width), got widths "
                             f"{[c.num_qubits for c in subs]}")
        self._subs = [check_circuit(c, f"sub_unitaries[{i}]") for i, c in enumerate(subs)]
        old = len(getattr(self, "parameters", ()))
        self._reindex()
        if "_theta" in self.__dict__ and len(self.parameters) != old:
            self.theta = np.zeros(len(self.parameters))

    @property
    def observable(self) -> SparsePauliOp:
        """``O`` of the observable readout (checked on set, on :attr:`num_qubits` qubits)."""
        return self._observable

    @observable.setter
    def observable(self, value) -> None:
        self._observable = check_observable(value, self.num_qubits)

    def derived(self, name: str) -> dict:
        """The dict ``name`` (``"exact"``, ``"commuting"``, ...) for values derived from the
        sub-unitaries, encoding, readout and observable; emptied when any of them changes
        (:mod:`qdensity.models._derived`), so what is kept there stays right."""
        store = self.__dict__.get("_derived")
        if store is None:  # a model pickled before the store existed
            store = self._derived = DerivedStore()
        return store.store(structure_key(self), name)

    # ------------------------------------------------------------------ basic facts
    @property
    def theta(self) -> np.ndarray:
        """Trainable angles, shape (P,), in :attr:`parameters` order (finite; checked on set)."""
        return self._theta

    @theta.setter
    def theta(self, value) -> None:
        self._theta = self._check_theta(value, batch=False).copy()

    def _check_theta(self, theta, *, batch: bool = True) -> np.ndarray:
        """``theta`` as a finite float array of shape (P,) (or (B, P) when ``batch``)."""
        arr = check_finite_array(theta, "theta")
        P = len(self.parameters)
        ok = arr.shape == (P,) or (batch and arr.ndim == 2 and arr.shape[1] == P)
        if not ok:
            allowed = f"({P},)" + (f" or (rows, {P})" if batch else "")
            raise ValueError(f"theta must have shape {allowed} (one angle per model parameter, "
                             f"in model.parameters order), got {arr.shape}")
        return arr

    def _check_X(self, X, name: str = "X") -> np.ndarray:
        """Data as a finite 2-d float array (B, d)."""
        arr = np.atleast_2d(check_finite_array(X, name))
        d = self.num_features
        if self.encoding is None and d == 0:  # the circuits take no data: only a gate may
            d = getattr(self.mixture, "num_features", None) or 0  # read columns, never ignored
        if arr.ndim != 2 or arr.shape[0] == 0 or arr.shape[1] != d:
            why = "; 0: it has no encoding nor uploaded x[i], so pass X=None" if d == 0 else ""
            raise ValueError(f"{name} must have shape (rows >= 1, {d}) (d = the model's "
                             f"num_features{why}), got {arr.shape}")
        return arr

    @property
    def num_features(self) -> int:
        """Features ``d``: the encoding's, else one more than the largest uploaded ``x[i]``
        (re-uploading, Methods eq. 10-11; 0 for a model that takes no data)."""
        if self.encoding is not None:
            return self.encoding.num_features
        known = self.derived("features")
        if "uploaded" not in known:
            idx = [p.index for c in self.sub_unitaries for p in c.parameters
                   if getattr(getattr(p, "vector", None), "name", None) == DATA_PREFIX]
            known["uploaded"] = max(idx) + 1 if idx else 0
        return known["uploaded"]

    @property
    def num_subunitaries(self) -> int:
        """K."""
        return len(self.sub_unitaries)

    @property
    def num_parameters(self) -> int:
        """Trainable circuit angles P (the mixture's own parameters are separate)."""
        return len(self.parameters)

    @property
    def shares_parameters(self) -> bool:
        """True when some parameter appears in more than one sub-unitary (Prop. 1 case)."""
        counts: dict = {}
        for c in self.sub_unitaries:
            for p in trainable_parameters(c):
                counts[p] = counts.get(p, 0) + 1
        return any(v > 1 for v in counts.values())

    def subunitary_parameter_indices(self, k: int) -> np.ndarray:
        """Indices into :attr:`theta` of sub-unitary ``k``'s parameters, in its order (derived
        once per structure; each call returns its own copy)."""
        known = self.derived("parameter_indices")
        if k not in known:
            idx = np.array([self._index[p] for p in trainable_parameters(self.sub_unitaries[k])],
                           dtype=int)
            known[k] = idx
        return known[k].copy()

    def train(self) -> DensityQNN:
        """Training mode: randomised preparation (sample sub-unitaries, Fig. 1c, Supp. I)."""
        self.training = True
        return self

    def eval(self) -> DensityQNN:
        """Evaluation mode: the deterministic state (Fig. 1b) or its exact value."""
        self.training = False
        return self

    def alpha(self, X=None) -> np.ndarray:
        """Mixture weights, shape (B, K)."""
        return self.mixture.alpha(None if X is None else np.atleast_2d(X))

    # ------------------------------------------------------------------ circuits
    @validates(k=Interval(int, 0, MAX_SUBUNITARIES), with_encoding=Instance(bool))
    def circuit(self, k: int, *, with_encoding: bool = True) -> QuantumCircuit:
        """``V(x)`` followed by ``U_k`` (parameterised); ``0 <= k < K``.

        A new circuit each call, sharing no parameterised gate with the model's (``U_k``'s
        gates appended to a copy of the encoding circuit, as ``compose`` would, at about a
        third of its cost: :func:`qdensity.circuits._copying.concatenate`).
        """
        if k >= len(self.sub_unitaries):
            raise refuse("DensityQNN.circuit", "k", k,
                         f"an int >= 0 and < K = {len(self.sub_unitaries)}")
        sub = self.sub_unitaries[k]
        if with_encoding and self.encoding is not None:
            return concatenate(self.encoding.circuit, sub)
        return sub.copy()

    def rows(self, k: int, X, theta=None, circuit: QuantumCircuit | None = None) -> np.ndarray:
        """Parameter rows of :meth:`circuit` ``(k)`` (or of ``circuit`` built on it) for data X.

        Parameters
        ----------
        k : int
        X : array_like, shape (B, d) or None
        theta : array_like, shape (P,) or (B, P), optional
            Defaults to :attr:`theta`.
        circuit : QuantumCircuit, optional
            A circuit whose parameters are a subset of encoding, data and model parameters
            (e.g. a gradient circuit built from :meth:`circuit`).

        Returns
        -------
        numpy.ndarray, shape (B, P_circuit)
        """
        return model_rows(self, k, X, theta, circuit)

    # ------------------------------------------------------------------ exact evaluation
    def _sub_theta(self, k: int, theta) -> np.ndarray:
        theta = self.theta if theta is None else self._check_theta(theta)
        return theta[..., self.subunitary_parameter_indices(k)]

    def expert_outputs(self, X=None, theta=None, *, method: str = "auto") -> np.ndarray:
        """Exact per-sub-unitary outputs ``f_k(x)``.

        Parameters
        ----------
        X : array_like, shape (B, d), optional
        theta : array_like, shape (P,), optional
        method : {"auto", "unary", "statevector", "aer"}
            ``auto`` uses the unary engine when the model allows it (RBS/FBS sub-unitaries on a
            unary encoding, diagonal observable), else the adjoint statevector engine the model
            keeps (``"statevector"``); ``"aer"`` asks Aer (an ExactEngine kept on the model).

        Returns
        -------
        numpy.ndarray
            (B, K) for an observable readout; (B, K, n) for unary readouts.
        """
        if method not in ("auto", "unary", "statevector", "aer"):
            raise ValueError(f"method must be 'auto', 'unary', 'statevector' or 'aer', got "
                             f"{method!r}")
        theta = None if theta is None else self._check_theta(theta)
        X = None if X is None else self._check_X(X)
        from qdensity.models.exact import unary_amplitudes, uses_unary_engine, z_readout_diagonal

        use_unary = uses_unary_engine(self) if method == "auto" else method == "unary"
        if use_unary:
            if not uses_unary_engine(self):
                raise ValueError("the unary engine needs RBS/FBS sub-unitaries on a unary "
                                 "encoding (and a diagonal observable)")
            Y = unary_amplitudes(self, X, theta)
            if self.readout == "unary_amplitudes":
                return Y
            if self.readout == "unary_probabilities":
                return Y**2
            return (Y**2) @ z_readout_diagonal(self.observable)
        check_width(self.num_qubits, engine=f"DensityQNN method={method!r} prediction",
                    alternative="method='unary' (RBS/FBS sub-unitaries on a unary encoding) or "
                    "sample() with shots")
        from qdensity.models.exact import aer_outputs, exact_outputs

        return (aer_outputs if method == "aer" else exact_outputs)(self, X, theta)

    def expectation_plan(self, k: int, X=None, theta=None, *, shots: int | None = None) -> Plan:
        """Plan for ``f_k(x) = Tr(O U_k rho(x) U_k^dagger)`` over the rows of X.

        Serves ``readout="observable"`` only (its answer is an
        :class:`~qdensity.execution.plans.Estimate` of shape (B,)).

        Raises
        ------
        ValueError
            For a unary readout, whose output is a vector per row: sample it with
            :func:`~qdensity.execution.plans.probabilities_plan` of ``circuit(k)`` and
            ``rows(k, X)`` read by :func:`~qdensity.execution.plans.unary_frequencies`,
            with :meth:`sample` (one point), or with an estimator's ``estimate``.
        """
        if self.readout != "observable":
            raise ValueError(
                f"expectation_plan serves readout='observable'; this model's readout is "
                f"{self.readout!r}, whose output has shape (B, {self.num_qubits}): use "
                "probabilities_plan(model.circuit(k), model.rows(k, X)) with "
                "unary_frequencies, model.sample(x, budget) (unary_probabilities), or "
                "QNNClassifier.estimate / QNNRegressor.estimate")
        circ = self.circuit(k)
        return expectation_plan(circ, self.observable, self.rows(k, X, theta), shots=shots,
                                label=f"forward_k{k}")

    def predict(self, X=None, theta=None, *, method: str = "auto") -> np.ndarray:
        """Exact model output ``f(x) = sum_k alpha_k(x) f_k(x)`` (eq. 3).

        Returns
        -------
        numpy.ndarray
            (B,) for an observable readout, (B, n) for unary readouts.
        """
        outs = self.expert_outputs(X, theta, method=method)
        alpha = self.alpha(X)
        if outs.ndim == 2:
            return (alpha * outs).sum(axis=1)
        return np.einsum("bk,bkn->bn", alpha, outs)

    # ------------------------------------------------------------------ sampling (Fig. 1, Supp. I)
    def sample(self, x, budget: int, *, scheduler: str = "per_shot", engine=None, target=None,
               seed=None, mitigation: str | None = None, postselect: str | None = None,
               ledger=None):
        """Estimate ``f(x)`` from shots, as the current mode prescribes (Supp. I).

        ``train()`` mode: the randomised density QNN (Fig. 1c): the shot budget is split over the
        sub-unitaries by ``scheduler`` and each shot runs one ``V(x)`` + ``U_k`` circuit.
        ``eval()`` mode: the deterministic state (Fig. 1b) measured with all ``budget`` shots
        (the observable is read on the ``data`` register; the ``mix`` register is ignored, which
        traces it out).

        Parameters
        ----------
        x : array_like, shape (d,)
            One data point.
        budget : int
            Total shots.
        scheduler : {"per_shot", "proportional", "neyman"}
            Used in train mode.
        engine : SamplerEngine, optional
            Used as is for every call (note: a fixed-seed Aer sampler repeats its shots).
        target : HardwareTarget, str, path, BackendV2 or qiskit.transpiler.Target, optional
            Without ``engine``: sample on this target's (noisy) simulator, a fresh sampler per
            call seeded from ``seed`` so a pilot and a main phase are independent. A name,
            file or backend becomes one target for the whole call (a named target's device
            seed is ``seed`` when it is an int, else 0). Default: noiseless Aer.
        seed : int or Generator, optional
        mitigation, postselect : str or None, optional
            Without ``engine``: the fresh engines' readout corrections
            (:class:`~qdensity.execution.engines.SamplerEngine`). One call calibrates once:
            the fresh engines of its phases share one calibration. With ``engine``, set them
            on the engine. With mitigation the standard error is the delta method's: the
            shots' share through the scheduler, plus the calibration's.
        ledger : ShotLedger, optional
            Without ``engine``: every fresh engine of the call records its shots (readout
            calibration included) here; a new one if None. With ``engine``: must be None
            (read ``engine.ledger``).

        Returns
        -------
        qdensity.execution.schedulers.ScheduleResult
            Estimate, standard error, allocation and shots used (``allocation`` is ``[budget]``
            in eval mode). For ``readout="unary_probabilities"`` ``estimate`` and
            ``standard_error`` are arrays of shape (n,) (the unary probabilities ``p_j`` of
            eq. 3 and their errors) and ``per_subunitary`` has shape (K, n) (train mode) or
            (1, n) (eval mode): one allocation, drawn once, serves every ``j``.

        Raises
        ------
        ValueError
            ``readout="unary_amplitudes"`` (shots do not see signs), a non-diagonal
            observable, or ``scheduler="neyman"`` with unary probabilities (Neyman allocates
            for one scalar output).

        Notes
        -----
        The engine's ledger (``engine.ledger``) labels train-mode shots ``randomised_k{k}``;
        with ``scheduler="neyman"`` the pilot's shots are labelled ``pilot_k{k}``, so the
        ``randomised_k{k}`` shots equal ``allocation[k]`` and the ``pilot_k{k}`` shots
        ``pilot_allocation[k]``; ``shots_used`` is their sum.
        """
        from qdensity.models._sampling import sample

        return sample(self, x, budget, scheduler=scheduler, engine=engine, target=target,
                      seed=seed, mitigation=mitigation, postselect=postselect, ledger=ledger)

    randomised_loss_and_grad = _randomised_loss_and_grad  # dropout's train phase (a method)
    # ------------------------------------------------------------------ parameters I/O
    def get_params(self) -> dict[str, np.ndarray]:
        """``{"theta": ..., "mixture": ...}`` as plain arrays."""
        return {"theta": self.theta.copy(), "mixture": self.mixture.params}

    def set_params(self, theta=None, mixture=None) -> DensityQNN:
        """Set angles and/or mixture parameters (shapes checked)."""
        if theta is not None:
            self.theta = self._check_theta(theta, batch=False)
        if mixture is not None:
            self.mixture.params = check_finite_array(mixture, "mixture")
        return self

    def __setstate__(self, state: dict) -> None:
        """Unpickle, also a model pickled before its structure became properties."""
        for old, new in (("sub_unitaries", "_subs"), ("observable", "_observable")):
            if old in state:
                state[new] = state.pop(old)
        stale = ("_unary_ok", "_num_uploaded", "_engines", "_commuting_cache")
        self.__dict__.update({k: v for k, v in state.items() if k not in stale})

    def __sklearn_clone__(self) -> DensityQNN:
        """``sklearn.base.clone`` of an estimator holding this model as a template: a copy."""
        import copy

        return copy.deepcopy(self)

    def __repr__(self) -> str:
        return (f"DensityQNN(K={self.num_subunitaries}, n={self.num_qubits}, "
                f"params={self.num_parameters}, mixture={type(self.mixture).__name__}, "
                f"readout={self.readout!r})")
