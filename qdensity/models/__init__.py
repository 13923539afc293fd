"""Density QNNs (paper eq. 1-2): the model (:mod:`~qdensity.models.density`), its encodings
(:mod:`~.encoding`), distributions over sub-unitaries, fixed, softmax or mixture-of-experts
(:mod:`~.mixtures`, Supp. H), and the paper's decompositions of one circuit into
sub-unitaries (:mod:`~.decompositions`, Fig. 6, Supp. H.1), the LCU model that mixes
amplitudes instead of outputs (:mod:`~.lcu`, Fig. 1a, Supp. C), exact evaluation on the
engines a model keeps (:mod:`~.exact`), the warm start from trained sub-unitaries
(:mod:`~.warm_start`), and the registries of decompositions and mixtures by name
(:mod:`~.registry`)."""

from __future__ import annotations

import sys
import types
from typing import TYPE_CHECKING

from qdensity._lazy import lazy_exports

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
    "DecompositionKind",
    "MixtureKind",
    "DECOMPOSITIONS",
    "MIXTURES",
    "exact_outputs",
    "exact_gradients",
    "ExactGradients",
]

#: public name -> the module that defines it, imported on first use (PEP 562)
_EXPORTS: dict[str, str] = {
    "Decomposition": "qdensity.models.decompositions",
    "by_moments": "qdensity.models.decompositions",
    "copies": "qdensity.models.decompositions",
    "cyclic_moments": "qdensity.models.decompositions",
    "independent": "qdensity.models.decompositions",
    "odd_even": "qdensity.models.decompositions",
    "trainable_parameters": "qdensity.models.decompositions",
    "READOUTS": "qdensity.models.density",
    "DensityQNN": "qdensity.models.density",
    "bind_rows": "qdensity.models.density",
    "Encoding": "qdensity.models.encoding",
    "ExactGradients": "qdensity.models.exact",
    "exact_gradients": "qdensity.models.exact",
    "exact_outputs": "qdensity.models.exact",
    "LCUQNN": "qdensity.models.lcu",
    "FixedMixture": "qdensity.models.mixtures",
    "GatedMixture": "qdensity.models.mixtures",
    "Mixture": "qdensity.models.mixtures",
    "SoftmaxMixture": "qdensity.models.mixtures",
    "as_mixture": "qdensity.models.mixtures",
    "softmax": "qdensity.models.mixtures",
    "warm_start": "qdensity.models.warm_start",
    "DecompositionKind": "qdensity.models.registry",
    "MixtureKind": "qdensity.models.registry",
    "DECOMPOSITIONS": "qdensity.models.registry",
    "MIXTURES": "qdensity.models.registry",
}

if TYPE_CHECKING:  # static analysers and IDEs see the eager imports
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
    from qdensity.models.registry import DECOMPOSITIONS, MIXTURES, DecompositionKind, MixtureKind
    from qdensity.models.warm_start import warm_start


if not TYPE_CHECKING:  # type checkers see the imports above, not a catch-all lookup
    __getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, __all__)


class _Package(types.ModuleType):
    """``warm_start`` names both a submodule and its function: importing the submodule must
    not replace the package's function (as the eager import of the function did)."""

    def __setattr__(self, name: str, value) -> None:
        if name == "warm_start" and isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
