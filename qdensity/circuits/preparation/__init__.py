"""Circuits that prepare the density-QNN state (paper Fig. 1a/b/c, Fig. 13, Supp. I.2-I.3).

A density QNN (paper eq. 1) prepares::

    rho(theta, alpha, x) = sum_k alpha_k U_k(theta_k) |x><x| U_k(theta_k)^dagger

from ``K`` sub-unitaries ``U_k`` on ``n`` data qubits and a distribution ``alpha``. This
package builds every way the paper gives to prepare it, at gate level:

=============================  ===========  ==========================================
builder                        figure       what one shot does
=============================  ===========  ==========================================
:func:`randomised_circuits`    Fig. 1c      ``V(x)`` then ``U_k``; ``k ~ alpha`` per shot
:func:`deterministic_circuit`  Fig. 1b/13a  ``Load(sqrt(alpha))`` on ``mix``, controlled
                                            ``U_k``; the ``data`` marginal is ``rho``
:func:`lcu_circuit`            Fig. 1a      Fig. 1b then ``Load(sqrt(alpha))^dagger``;
                                            post-select ``mix = 0...0``
:func:`hw_generative_circuit`  Fig. 13b     ``V = 1``, HW-preserving ``U_k``:
                                            ``U_k^dagger . CNOT . U_k`` per ``k``
=============================  ===========  ==========================================

Register layout of the ancilla circuits: register ``"mix"`` (``K`` qubits, circuit qubits
``0 .. K-1``, the register A of the figures, drawn on top) then register ``"data"``
(``n`` qubits, circuit qubits ``K .. K+n-1``, register B). Qubit ``k`` of ``mix`` controls
``U_k``; data qubit ``q`` of a sub-unitary is ``data[q]``.

Controlled sub-unitaries are built gate by gate by :func:`controlled_subunitary`, which
controls only what needs controlling: a gate ``V R(theta) V^dagger`` gets a controlled
rotation between uncontrolled ``V`` and ``V^dagger`` (they cancel when the control is off).
Free parameters stay parameters, so one template serves every parameter row.

Modules: :mod:`.randomised` (Fig. 1c), :mod:`.deterministic` (Fig. 1b), :mod:`.lcu` (Fig. 1a,
with the exact success probability and post-selected state), :mod:`.generative` (Fig. 13b),
:mod:`.bundle` (:class:`PreparationCircuits`, :func:`prepare_all`); ``_controlled`` holds the
controlled sub-unitary construction and ``_common`` the register names and input checks.
"""

from qdensity.circuits.preparation._common import DATA_REGISTER, MIX_REGISTER
from qdensity.circuits.preparation._controlled import controlled_subunitary
from qdensity.circuits.preparation.bundle import PreparationCircuits, prepare_all
from qdensity.circuits.preparation.deterministic import deterministic_circuit
from qdensity.circuits.preparation.generative import hw_generative_circuit
from qdensity.circuits.preparation.lcu import (
    lcu_circuit,
    lcu_postselected_state,
    lcu_success_probability,
    lcu_template,
)
from qdensity.circuits.preparation.randomised import randomised_circuits

__all__ = [
    "controlled_subunitary",
    "randomised_circuits",
    "deterministic_circuit",
    "lcu_circuit",
    "lcu_template",
    "lcu_success_probability",
    "lcu_postselected_state",
    "hw_generative_circuit",
    "PreparationCircuits",
    "prepare_all",
    "MIX_REGISTER",
    "DATA_REGISTER",
]
