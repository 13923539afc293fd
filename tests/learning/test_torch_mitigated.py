"""The torch layer on a mitigated ``SamplerEngine`` (issue "Hardware as objects", item 2).

Oracle: a device whose only noise is a readout error (P(read 0 | 1) = 0.2, P(read 1 | 0) = 0.1
on every qubit). Then, exactly, the raw estimate of ``<Z0>`` has mean ``0.7 f + 0.1`` and a raw
shift-rule gradient has mean ``0.7 df/dt`` (the offset cancels in the differences), while M3's
correction is unbiased up to its calibration error. ``f`` and ``df/dt`` come from the exact
layer (the adjoint engine), an independent path.

Bounds (no reference to the code's own error bars): one estimate of ``<Z0>`` from ``S`` shots
corrected by M3 has standard error at most ``1 / (0.7 sqrt(S))`` (a Bernoulli variance <= 1,
scaled by the inverse of the readout matrix), and the calibration of P(read 1 | 0) and
P(read 0 | 1) from ``C`` shots each moves it by at most ``2 |dp| / 0.7`` with
``sd(dp) <= 1 / (2 sqrt(C))``. The RBS four-term rule (coefficients 1, -1, -(sqrt 2 - 1)/2,
(sqrt 2 - 1)/2) combines four independent estimates and one shared calibration. Each check
uses z = 4.4 on both terms (a two-sided normal rate of 1.1e-5 each): over the 7 checks
below, a false failure at most about 1e-4 per run.
"""

import math

import numpy as np
import pytest

torch = pytest.importorskip("torch")  # the optional extra; CI installs it (.ci/run)

from qiskit.providers.fake_provider import GenericBackendV2  # noqa: E402
from qiskit_aer.noise import NoiseModel, ReadoutError  # noqa: E402

from qdensity.circuits.ansatze import round_robin  # noqa: E402
from qdensity.execution.sampler.engine import SamplerEngine  # noqa: E402
from qdensity.hardware.targets import get_target  # noqa: E402
from qdensity.learning.torch import DensityQNNLayer  # noqa: E402
from qdensity.models import DensityQNN, Encoding  # noqa: E402

P01, P10 = 0.2, 0.1  # P(read 0 | 1), P(read 1 | 0)
SHRINK = 1 - P01 - P10
SHOTS, CAL, Z = 20_000, 40_000, 4.4
RBS = (1.0, -1.0, -(math.sqrt(2) - 1) / 2, (math.sqrt(2) - 1) / 2)


def _layers():
    pytest.importorskip("mthree")
    noise = NoiseModel()
    noise.add_all_qubit_readout_error(ReadoutError([[1 - P10, P10], [P01, 1 - P01]]))
    target = get_target(GenericBackendV2(3, seed=3).target, noise_model=noise)
    model = DensityQNN([round_robin(3)], encoding=Encoding.unary(3), seed=4)
    exact = DensityQNNLayer(model)
    sampled = {m: DensityQNNLayer(model, engine=SamplerEngine(
        target=target, seed=21, progress=False, mitigation=m, calibration_shots=CAL),
        shots=SHOTS, gradient="shift") for m in (None, "m3")}
    return exact, sampled


def _value_and_grad(layer, x):
    layer.zero_grad()
    out = layer(x)
    out.sum().backward()
    return float(out.detach()[0, 0]), layer.theta.grad.detach().numpy().copy()


def test_mitigated_output_and_gradient_unbiased_raw_ones_shrunk():
    exact, sampled = _layers()
    x = torch.tensor([[1.0, 0.1, 0.1]], dtype=torch.float64)
    f, g = _value_and_grad(exact, x)
    assert f < -0.8  # chosen so that the raw bias -(0.3 f - 0.1) is large
    raw_f, raw_g = _value_and_grad(sampled[None], x)
    m3_f, m3_g = _value_and_grad(sampled["m3"], x)
    se = 1 / (SHRINK * math.sqrt(SHOTS))  # one corrected estimate
    cal = 2 * (1 / (2 * math.sqrt(CAL))) / SHRINK  # the calibration's shift of one estimate
    # the output: mitigated within its bound, raw where its exact mean says, far from f
    assert abs(m3_f - f) <= Z * (se + cal)
    raw_se = 1 / math.sqrt(SHOTS)
    assert abs(raw_f - (SHRINK * f + (P01 - P10))) <= Z * raw_se
    assert abs(raw_f - f) > 3 * Z * (se + cal)
    # the gradient (three RBS angles, four-term rule each)
    g_se = se * math.sqrt(sum(c * c for c in RBS))
    g_cal = cal * sum(abs(c) for c in RBS)
    assert g.shape == m3_g.shape == (3,)
    assert np.all(np.abs(m3_g - g) <= Z * (g_se + g_cal)), (m3_g, g)
    assert np.all(np.abs(raw_g - SHRINK * g) <= Z * raw_se * math.sqrt(sum(c * c for c in RBS)))
    # the ledger holds the calibration under its own label on the mitigated engine only
    by = sampled["m3"].engine.ledger.by_label()
    assert by["readout calibration"][1] > 0
    assert "readout calibration" not in sampled[None].engine.ledger.by_label()
