"""Density QNNs (paper eq. 1-2): the model (:mod:`~qdensity.models.density`), its encodings
(:mod:`~.encoding`), distributions over sub-unitaries, fixed, softmax or mixture-of-experts
(:mod:`~.mixtures`, Supp. H), and the paper's decompositions of one circuit into
sub-unitaries (:mod:`~.decompositions`, Fig. 6, Supp. H.1), the LCU model that mixes
amplitudes instead of outputs (:mod:`~.lcu`, Fig. 1a, Supp. C), exact evaluation on the
engines a model keeps (:mod:`~.exact`) and the warm start from trained sub-unitaries
(:mod:`~.warm_start`)."""

from qdensity.models.decompositions import (
    Decomposition,
    by_moments,
    copies,
    cyclic_moments,
    independent,
    odd_even,
    trainable_parameters,
)
from qdensity.models.density import READOUTS, DensityQNN, bind_rows
from qdensity.models.encoding import Encoding
from qdensity.models.exact import ExactGradients, exact_gradients, exact_outputs
from qdensity.models.lcu import LCUQNN
from qdensity.models.mixtures import (
    FixedMixture,
    GatedMixture,
    Mixture,
    SoftmaxMixture,
    as_mixture,
    softmax,
)
from qdensity.models.warm_start import warm_start

__all__ = [
    "LCUQNN",
    "Encoding",
    "DensityQNN",
    "READOUTS",
    "bind_rows",
    "Mixture",
    "FixedMixture",
    "SoftmaxMixture",
    "GatedMixture",
    "as_mixture",
    "softmax",
    "Decomposition",
    "by_moments",
    "cyclic_moments",
    "odd_even",
    "copies",
    "independent",
    "trainable_parameters",
    "warm_start",
    "exact_outputs",
    "exact_gradients",
    "ExactGradients",
]
