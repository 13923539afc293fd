"""The estimators' classical encoding: feature scales, the warning for unscaled features and
the one-line description of how features become qubits.

The unary loader normalises every row (``|x> = x / ||x||``, eq. 1): a feature whose scale
is orders of magnitude above the others fills the loaded vector, every row loads nearly the
same state, and a classifier stays at the majority-class rate. The estimators standardise by
default (``scale=True``); where the features reach the model unscaled (``scale=False`` or a
model template, which takes the data as given) :func:`warn_if_unscaled` says so.
"""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from sklearn.utils.validation import check_is_fitted, validate_data

__all__ = ["UnscaledFeaturesWarning", "SCALE_RATIO", "scale_ratio", "warn_if_unscaled",
           "describe_encoding", "EncodingMixin"]

#: Ratio of the largest to the smallest feature spread (standard deviation) above which the
#: features count as unscaled: two orders of magnitude.
SCALE_RATIO = 100.0


class UnscaledFeaturesWarning(UserWarning):
    """Features reach the density QNN with spreads that differ by orders of magnitude.

    The unary encoding normalises each row, so the largest-scale features dominate every
    loaded state and the model can stay at the majority-class rate. Standardise them
    (``scale=True``, the estimators' default, or a ``Pipeline`` with ``StandardScaler``).

    Examples
    --------
    A second column a thousand times the first's spread, given unscaled:

    >>> import warnings
    >>> import numpy as np
    >>> from qdensity.learning import QNNClassifier, UnscaledFeaturesWarning
    >>> X, y = np.column_stack([np.arange(8.0), 1000 * np.arange(8.0)]), np.arange(8) % 2
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     _ = QNNClassifier(scale=False, epochs=1, max_steps=1, verbose=False).fit(X, y)
    >>> [w.category is UnscaledFeaturesWarning for w in caught]
    [True]
    """


def scale_ratio(X: np.ndarray) -> float:
    """Largest over smallest non-zero column standard deviation of ``X`` (N, d); 1.0 when
    fewer than two columns vary."""
    std = np.std(np.asarray(X, dtype=float), axis=0)
    std = std[std > 0]
    if std.size < 2:
        return 1.0
    return float(std.max() / std.min())


def warn_if_unscaled(X: np.ndarray, where: str) -> bool:
    """Warn (:class:`UnscaledFeaturesWarning`) when the column spreads of ``X`` differ by more
    than :data:`SCALE_RATIO`; returns whether it warned."""
    ratio = scale_ratio(X)
    if ratio <= SCALE_RATIO:
        return False
    warnings.warn(UnscaledFeaturesWarning(
        f"{where}: the features' standard deviations differ by a factor {ratio:.3g} (> "
        f"{SCALE_RATIO:g}); the unary encoding normalises each row, so the largest features "
        "dominate every state and the model may stay at the majority-class rate. Use "
        "scale=True (the default for a spec model) or a Pipeline with StandardScaler"),
        stacklevel=3)
    return True


def describe_encoding(num_features: int, num_qubits: int, data_columns: int, *,
                      scaled: bool, pca: bool, constant, template: bool) -> str:
    """How ``num_features`` features become ``num_qubits`` qubits, in one line."""
    if template:
        return (f"{num_features} features -> the template model's encoding on {num_qubits} "
                "qubits (no scaling, PCA or constant qubit)")
    steps = [f"{num_features} features"]
    if scaled:
        steps.append("standardised")
    if pca:
        steps.append(f"PCA to {data_columns}")
    elif data_columns > num_features:
        steps.append(f"zero-padded to {data_columns}")
    tail = f" + constant qubit ({constant:g})" if constant is not None else ""
    return " -> ".join(steps) + f"{tail} = {num_qubits} qubits (unary encoding, eq. 1)"


@contextlib.contextmanager
def _naming(names: str):
    """Put the argument names in front of scikit-learn's data errors, which often lack them
    ("could not convert string to float", "Found array with 0 sample(s)"); same type, same
    text after the names."""
    try:
        yield
    except (TypeError, ValueError) as exc:
        raise type(exc)(f"{names}: {exc}") from exc


class EncodingMixin:
    """The estimators' encoding (scaler, PCA, padding, constant qubit): ``transform``.

    scikit-learn reads a ``transform`` method as a transformer's, so the tags say so and
    ``fit_transform`` is there: in a pipeline the fitted estimator could pass its encoded
    features on, though its use is ``transform`` on its own, to see what the qubits load.
    """

    if TYPE_CHECKING:  # what the estimator that mixes this in holds
        model: Any
        constant: float
        scaler_: Any
        pca_: Any
        n_features_in_: int
        num_qubits_: int
        _data_columns_: int

        fit: Callable[..., Any]

    def __sklearn_tags__(self):
        from sklearn.utils import TransformerTags

        # cooperative: the estimator's scikit-learn base class, later in the MRO, defines it
        tags = super().__sklearn_tags__()  # type: ignore[misc]
        tags.transformer_tags = TransformerTags(preserves_dtype=["float64"])
        return tags

    def _encode(self, X: np.ndarray) -> np.ndarray:
        """Features of the quantum layer: PCA / zero padding, then the constant qubit."""
        if self.model is not None:
            return X
        Z = self.scaler_.transform(X) if self.scaler_ is not None else X
        Z = self.pca_.transform(Z) if self.pca_ is not None else Z
        n, cols = self.num_qubits_, self._data_columns_
        if Z.shape[1] < cols:
            Z = np.hstack([Z, np.zeros((Z.shape[0], cols - Z.shape[1]))])
        if cols < n:
            Z = np.hstack([Z, np.full((Z.shape[0], n - cols), float(self.constant))])
        return Z

    def transform(self, X) -> np.ndarray:
        """The features the quantum layer loads: the encoding of ``X`` fitted in ``fit``.

        Standardisation (``scale=True``), PCA to ``num_qubits - 1`` columns or zero padding,
        then the constant qubit; the unary loader normalises each row of the result (eq. 1).
        A model template takes ``X`` as it is.

        Parameters
        ----------
        X : array_like, shape (N, n_features_in_)

        Returns
        -------
        numpy.ndarray, shape (N, num_qubits_)
            (N, n_features_in_) for a model template (its own encoding applies).
        """
        check_is_fitted(self, "model_")
        with _naming("X"):
            X = validate_data(self, X, reset=False, dtype=np.float64)
        return self._encode(X)

    def fit_transform(self, X, y, **fit_params) -> np.ndarray:
        """``fit(X, y)`` then :meth:`transform` ``(X)`` (what scikit-learn expects of an
        estimator with ``transform``): the encoded features, shape (N, num_qubits_)."""
        return self.fit(X, y, **fit_params).transform(X)

    def encoding_description(self) -> str:
        """How the features become qubits, e.g. ``"30 features -> standardised -> PCA to 5 +
        constant qubit (1) = 6 qubits (unary encoding, eq. 1)"`` (what ``fit`` logs)."""
        check_is_fitted(self, "model_")
        return describe_encoding(self.n_features_in_, self.num_qubits_, self._data_columns_,
                                 scaled=self.scaler_ is not None, pca=self.pca_ is not None,
                                 constant=self.constant, template=self.model is not None)
