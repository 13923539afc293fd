"""Fuzzing ``qdensity.circuits``: gates, loaders, ansätze, preparations, tomography.

Random valid input meets an independent oracle (the paper's matrix, the loaded unit vector,
Hamming-weight preservation read off the statevector); random invalid input (NaN, inf,
strings, empty, wrong shapes, bad sizes, unknown names, huge widths) raises ``ValueError`` or
``TypeError`` and nothing else.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from _fuzz import BAD_SIZES, HUGE, NON_FINITE, NOT_A_NUMBER, accepted, poison, refused
from hypothesis import given, settings
from hypothesis import strategies as st
from qiskit.quantum_info import Operator, Statevector

from qdensity.circuits import ansatze
from qdensity.circuits.gates import FBSGate, RBSGate, fbs_matrix, rbs_matrix
from qdensity.circuits.loaders import (
    distribution_loader,
    loader_angles,
    matrix_loader,
    unary_loader,
    unary_loader_template,
)
from qdensity.circuits.preparation import deterministic_circuit, lcu_circuit
from qdensity.circuits.tomography import shots_for_error, tomography_circuits

ANGLES = st.floats(-10.0, 10.0, allow_nan=False)
BAD_ANGLES = st.one_of(NON_FINITE, NOT_A_NUMBER, st.booleans())
LAYOUTS = ["parallel", "diagonal", "semi_diagonal"]


# ----------------------------------------------------------------------------- found cases
@pytest.mark.parametrize("theta", [math.inf, -math.inf, math.nan])
def test_found_rbs_fbs_non_finite_angles_refused(theta):
    for make in (RBSGate, lambda t: FBSGate(t, 2), rbs_matrix, lambda t: fbs_matrix(t, 3)):
        with pytest.raises(ValueError, match="theta must be a finite real number"):
            make(theta)


def test_found_rbs_string_angle_is_a_type_error():
    with pytest.raises(TypeError, match="theta must be a finite real number"):
        RBSGate("a")


# ----------------------------------------------------------------------------- gates
@settings(max_examples=25)
@given(theta=ANGLES)
def test_rbs_valid_angles_match_the_paper_matrix(theta):
    accepted("RBSGate")
    c, s = math.cos(theta), math.sin(theta)
    paper = np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]])
    np.testing.assert_allclose(Operator(RBSGate(theta)).data, paper, atol=1e-12)


@settings(max_examples=40)
@given(theta=BAD_ANGLES)
def test_rbs_fbs_bad_angles_refused(theta):
    refused("RBSGate", RBSGate, theta)
    refused("FBSGate", FBSGate, theta, 3)
    refused("rbs_matrix", rbs_matrix, theta)


@settings(max_examples=30)
@given(m=st.one_of(BAD_SIZES, HUGE))
def test_fbs_bad_widths_refused(m):
    refused("FBSGate", FBSGate, 0.1, m)
    refused("fbs_matrix", fbs_matrix, 0.1, m)


# ----------------------------------------------------------------------------- loaders
@settings(max_examples=25)
@given(x=st.lists(st.floats(-5, 5, allow_nan=False), min_size=2, max_size=7)
       .filter(lambda v: np.linalg.norm(v) > 1e-3),
       layout=st.sampled_from(LAYOUTS))
def test_unary_loader_valid_loads_the_unit_vector(x, layout):
    accepted("unary_loader")
    x = np.array(x)
    sv = Statevector(unary_loader(x, layout=layout)).data
    np.testing.assert_allclose(sv[1 << np.arange(x.size)].real, x / np.linalg.norm(x),
                               atol=1e-9)


@settings(max_examples=60)
@given(data=st.data(), layout=st.sampled_from(LAYOUTS))
def test_loaders_bad_input_refused(data, layout):
    kind = data.draw(st.sampled_from(["nonfinite", "zero", "short", "2d", "text", "layout"]))
    x = np.array([0.3, -0.4, 0.5, 0.1])
    if kind == "nonfinite":
        x = poison(x, data)
    elif kind == "zero":
        x = np.zeros(data.draw(st.integers(0, 5)))
    elif kind == "short":
        x = x[: data.draw(st.integers(0, 1))]
    elif kind == "2d":
        x = np.ones((2, 2, 2))
    elif kind == "text":
        x = data.draw(NOT_A_NUMBER)
    if kind == "layout":
        layout = data.draw(st.text(max_size=6).filter(lambda s: s not in LAYOUTS))
    refused("unary_loader", unary_loader, x, layout=layout)
    refused("loader_angles", loader_angles, x if kind != "short" else np.zeros((1, 1)),
            layout=layout)
    refused("distribution_loader", distribution_loader, x if kind != "2d" else [0.5, 0.6],
            layout=layout)


@settings(max_examples=30)
@given(d=st.one_of(BAD_SIZES, HUGE), layout=st.sampled_from(LAYOUTS))
def test_loader_template_bad_sizes_refused(d, layout):
    refused("unary_loader_template", unary_loader_template, d, layout=layout)


@settings(max_examples=20)
@given(data=st.data())
def test_matrix_loader_bad_input_refused(data):
    X = poison(np.ones((2, 3)), data)
    refused("matrix_loader", matrix_loader, X)
    refused("matrix_loader", matrix_loader, np.zeros((2, 3)))
    refused("matrix_loader", matrix_loader, data.draw(NOT_A_NUMBER))


# ----------------------------------------------------------------------------- ansätze
BUILDERS = {
    "pyramid": ansatze.pyramid,
    "x_circuit": ansatze.x_circuit,
    "butterfly": ansatze.butterfly,
    "round_robin": ansatze.round_robin,
    "hardware_efficient": lambda n: ansatze.hardware_efficient(n, 2),
    "qcnn": ansatze.qcnn,
    "equivariant_commuting": lambda n: ansatze.equivariant_commuting(n, "X"),
}


@settings(max_examples=25)
@given(name=st.sampled_from(["pyramid", "x_circuit", "round_robin"]), n=st.integers(2, 5),
       seed=st.integers(0, 2**16))
def test_hamming_ansatze_valid_preserve_weight(name, n, seed):
    accepted(name)
    qc = BUILDERS[name](n)
    vals = np.random.default_rng(seed).uniform(-np.pi, np.pi, qc.num_parameters)
    state = Statevector.from_label("0" * (n - 1) + "1").evolve(qc.assign_parameters(vals))
    weights = np.array([bin(b).count("1") for b in range(2**n)])
    assert np.abs(state.data[weights != 1]).max() < 1e-9


@settings(max_examples=60)
@given(name=st.sampled_from(sorted(BUILDERS)), n=st.one_of(BAD_SIZES, HUGE))
def test_ansatze_bad_sizes_refused(name, n):
    refused(name, BUILDERS[name], n)


# ----------------------------------------------------------------------------- preparations
@settings(max_examples=30)
@given(data=st.data(), build=st.sampled_from([deterministic_circuit, lcu_circuit]))
def test_preparations_bad_alpha_refused(data, build):
    subs = [ansatze.pyramid(3).assign_parameters(np.full(3, 0.1)) for _ in range(2)]
    kind = data.draw(st.sampled_from(["nonfinite", "negative", "sum", "length", "empty"]))
    alpha = np.array([0.5, 0.5])
    if kind == "nonfinite":
        alpha = poison(alpha, data)
    elif kind == "negative":
        alpha = np.array([1.5, -0.5])
    elif kind == "sum":
        alpha = np.array([0.5, data.draw(st.floats(0.6, 10))])
    elif kind == "length":
        alpha = np.array([0.2, 0.3, 0.5])
    else:
        subs = []
    refused(build.__name__, build, subs, alpha)


# ----------------------------------------------------------------------------- tomography
@settings(max_examples=30)
@given(delta=st.one_of(NON_FINITE, st.floats(-5, 0), NOT_A_NUMBER), n=BAD_SIZES)
def test_tomography_bad_input_refused(delta, n):
    refused("shots_for_error", shots_for_error, delta, 4)
    refused("shots_for_error", shots_for_error, 0.1, n)
    refused("tomography_circuits", tomography_circuits, delta)
