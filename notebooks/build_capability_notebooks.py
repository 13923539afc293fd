"""Write the capability notebooks of notebooks/ (without outputs) from the cells below.

    python notebooks/build_capability_notebooks.py            # all four
    python notebooks/build_capability_notebooks.py tomography # one

tests/test_notebooks.py executes every notebook; edit the cells here, not the .ipynb files.
"""

from __future__ import annotations

import sys
from pathlib import Path

import nbformat
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

HERE = Path(__file__).parent


def _cells(spec: list[tuple[str, str]]) -> list:
    return [new_markdown_cell(text.strip()) if kind == "md" else new_code_cell(text.strip())
            for kind, text in spec]


# ------------------------------------------------------------------------------------------
CIRCUITS = [
    ("md", r"""
# Circuits and transpilation

Every construction of the paper at gate level, then what it costs on hardware:

* the **RBS gate** (eq. 8) and the **FBS gate** (Supp. E.2), Hamming-weight preserving;
* **unary loaders** `|x> = sum_j x_j/||x|| |e_j>` (Fig. 2, Johri et al.), three tree layouts;
* the sub-unitary families: **OrthoQNNs** (pyramid, X, butterfly, round-robin: Fig. 9 a-d),
  the **hardware-efficient** ansatz (Fig. 3), **equivariant** commuting XX and non-commuting
  circuits and the **QCNN** (Methods, bars and dots);
* the three **preparations** of a density state `rho = sum_k alpha_k U_k |x><x| U_k^dagger`
  (eq. 1): randomised (Fig. 1c), deterministic (Fig. 1b) and LCU (Fig. 1a);
* transpilation to an ideal target, a seeded heavy-hex device and a calibrated IBM device
  snapshot, resource reports side by side, and OpenQASM 3 export.

Sizes are small so the notebook runs in seconds; the test suite executes it and its `assert`s.
"""),
    ("code", r"""
import numpy as np
from qiskit import QuantumCircuit
from qiskit.circuit.library import XXPlusYYGate
from qiskit.quantum_info import DensityMatrix, Operator, Statevector, partial_trace

from qdensity import FBSGate, RBSGate, is_hamming_weight_preserving, unary_loader
from qdensity.circuits import rbs_matrix

rng = np.random.default_rng(0)
theta = 0.37
# RBS(theta) is a Givens rotation on the unary states |01>, |10> and the identity elsewhere
c, s = np.cos(theta), np.sin(theta)
m = rbs_matrix(theta)
assert np.allclose(m[np.ix_([1, 2], [1, 2])], [[c, -s], [s, c]])
assert np.allclose(m[0, 0], 1) and np.allclose(m[3, 3], 1)
# ... and it equals Qiskit's XXPlusYYGate(2 theta, pi/2): a native gate on some hardware
assert Operator(RBSGate(theta)).equiv(Operator(XXPlusYYGate(2 * theta, np.pi / 2)))
m.round(3)
"""),
    ("md", r"""
The FBS gate couples the first and last qubit of a block with a sign set by the parity of the
qubits in between (Supp. E.2, eq. 24). On unary inputs (one excitation) it acts as an RBS on
its end qubits, whatever the block's width:
"""),
    ("code", r"""
for j in range(3):                       # the three unary states of 3 qubits
    x = np.zeros(3); x[j] = 1.0
    fbs = QuantumCircuit(3); fbs.initialize(Statevector.from_int(2**j, 8)); fbs.append(FBSGate(theta, 3), [0, 1, 2])
    rbs = QuantumCircuit(3); rbs.initialize(Statevector.from_int(2**j, 8)); rbs.append(RBSGate(theta), [0, 2])
    assert Statevector(fbs).equiv(Statevector(rbs))
print('FBS = RBS on every unary input of 3 qubits')
"""),
    ("md", r"""
## Unary loaders (Fig. 2)

One `X` gate and `d - 1` RBS gates in a binary tree. The amplitude of `|e_j>` (statevector
entry `2**j`) is `x_j / ||x||`, signs and zeros included. The three layouts trade depth for
nearest-neighbour structure:
"""),
    ("code", r"""
x = np.array([0.5, -1.0, 0.0, 2.0, 0.3, -0.7, 1.1, 0.4])
for layout in ('parallel', 'diagonal', 'semi_diagonal'):
    qc = unary_loader(x, layout=layout)
    amps = Statevector(qc).data.real[2 ** np.arange(len(x))]
    assert np.allclose(amps, x / np.linalg.norm(x))
    print(f"{layout:>14}: {qc.count_ops().get('rbs', 0)} RBS gates, depth {qc.depth()}")
print(unary_loader(x[:4]).draw('text'))
"""),
    ("md", r"""
## The sub-unitary families

Every Hamming-weight-preserving family (Fig. 9) acts on the unary subspace as an orthogonal
matrix; the others (hardware-efficient, equivariant, QCNN) do not preserve it. The table
counts trainable parameters and gates before any compilation.
"""),
    ("code", r"""
from qdensity.ansatze import (butterfly, equivariant_commuting, equivariant_noncommuting,
                              hardware_efficient, pyramid, qcnn, round_robin, x_circuit)

n = 4
families = {
    'pyramid (Fig. 9a)': pyramid(n),
    'X (Fig. 9b)': x_circuit(n),
    'butterfly (Fig. 9c)': butterfly(n),
    'round-robin (Fig. 9d)': round_robin(n),
    'hardware-efficient, D=2 (Fig. 3)': hardware_efficient(n, 2),
    'equivariant XX (Methods)': equivariant_commuting(n, 'X'),
    'equivariant non-commuting, 1 layer': equivariant_noncommuting(n, 1),
    'QCNN (Methods)': qcnn(n),
}
print(f"{'family':<36}{'params':>7}{'gates':>7}  HW-preserving")
for name, qc in families.items():
    print(f"{name:<36}{qc.num_parameters:>7}{qc.size():>7}  {is_hamming_weight_preserving(qc)}")
assert families['pyramid (Fig. 9a)'].num_parameters == n * (n - 1) // 2
assert families['round-robin (Fig. 9d)'].num_parameters == n * (n - 1) // 2
assert families['butterfly (Fig. 9c)'].num_parameters == n // 2 * int(np.log2(n))
assert is_hamming_weight_preserving(families['round-robin (Fig. 9d)'])
assert not is_hamming_weight_preserving(families['hardware-efficient, D=2 (Fig. 3)'])
print(families['round-robin (Fig. 9d)'].draw('text'))
"""),
    ("md", r"""
The round-robin circuit (Fig. 6) has `n - 1` layers of disjoint RBS gates, and every pair of
qubits meets once. Cut into its layers it gives the `n - 1` sub-unitaries of the density
OrthoQNN; each layer is one commuting block, which is what makes its gradient cheap (Table 1,
see the gradients notebook).
"""),
    ("code", r"""
from qdensity import by_moments, moments

rr = round_robin(n)
pairs = [tuple(sorted(rr.find_bit(q).index for q in inst.qubits)) for inst in rr.data]
assert sorted(pairs) == [(i, j) for i in range(n) for j in range(i + 1, n)]   # each pair once
dec = by_moments(rr)
print(dec, [c.num_parameters for c in dec.sub_unitaries])
assert dec.num_subunitaries == n - 1 == len(moments(rr))
"""),
    ("md", r"""
## Preparing the density state: randomised, deterministic, LCU (Fig. 1)

* **randomised** (Fig. 1c): `K` circuits `U_k V(x)`; each shot runs circuit `k` with
  probability `alpha_k`, so `rho` holds on average, with no extra qubits;
* **deterministic** (Fig. 1b, Supp. I.2): `Load(sqrt(alpha))` on a `K`-qubit register `mix`,
  then `U_k` controlled by `mix[k]`; tracing `mix` out leaves exactly `rho` on `data`;
* **LCU** (Fig. 1a): the deterministic circuit followed by `Load(sqrt(alpha))^dagger`;
  post-selecting `mix = 0...0` leaves `sum_k alpha_k U_k |x>` normalised, with success
  probability `||sum_k alpha_k U_k |x>||^2`.

We check each against the definition with exact statevectors (7 qubits here).
"""),
    ("code", r"""
from qdensity.preparation import (lcu_postselected_state, lcu_success_probability,
                                  prepare_all)

subs = [c.assign_parameters(rng.uniform(-np.pi, np.pi, c.num_parameters)) for c in dec.sub_unitaries]
alpha = np.array([0.5, 0.3, 0.2])
loader = unary_loader([0.4, -0.9, 0.6, 0.2])
prep = prepare_all(subs, alpha, loader)
K = len(subs)

outputs = [Statevector(loader.compose(u)) for u in subs]                # U_k |x>
rho = DensityMatrix(sum(a * np.outer(psi.data, psi.data.conj()) for a, psi in zip(alpha, outputs)))  # eq. 1
# randomised: one circuit per k, the mixture made by drawing k ~ alpha per shot
assert all(Statevector(c).equiv(psi) for c, psi in zip(prep['randomised'], outputs))
# deterministic: trace out the mix register (qubits 0 .. K-1)
marginal = partial_trace(Statevector(prep['deterministic']), list(range(K)))
assert np.allclose(marginal.data, rho.data, atol=1e-10)
# LCU: the post-selected state and the success probability
lcu = sum(a * psi.data for a, psi in zip(alpha, outputs))
p_success = lcu_success_probability(subs, alpha, loader)
assert np.isclose(p_success, np.linalg.norm(lcu) ** 2)
assert lcu_postselected_state(subs, alpha, loader).equiv(Statevector(lcu / np.linalg.norm(lcu)))
print(f"purity of rho: {rho.purity().real:.3f}; LCU success probability: {p_success:.3f}")
print(prep['randomised'][0].draw('text'))   # V(x) then U_1: the circuit of one shot with k = 1
"""),
    ("md", r"""
## Transpilation and resources

`get_target` names a device: `ideal` (all-to-all), `heavy_hex` (a seeded `GenericBackendV2` on
IBM's heavy-hex lattice with sampled T1/T2, gate and readout errors), `rbs_native` (a device
whose native two-qubit gate is the beam splitter) and, with the `ibm` extra, every calibrated
device snapshot of `qiskit_ibm_runtime.fake_provider` (`fake_nairobi`, `fake_torino`, ...).
`resource_report` compiles once and counts the two-qubit gates and depths; `compare_reports`
prints them side by side with ratios to the first column. Each RBS costs two CZ/CX gates on
IBM-like hardware (the paper's counting), one gate on `rbs_native`, and routing adds SWAPs on
sparse lattices.
"""),
    ("code", r"""
import importlib.util

from qdensity import compare_reports, get_target, resource_report

circuits = {'pyramid': pyramid(n), 'round-robin': rr, 'butterfly': butterfly(n),
            'deterministic (K=3)': prep['deterministic'], 'LCU (K=3)': prep['lcu']}
targets = {'ideal': None, 'heavy_hex': get_target('heavy_hex', 7, seed=3, noise=False),
           'rbs_native': 'rbs_native'}
if importlib.util.find_spec('qiskit_ibm_runtime') is not None:
    targets['fake_nairobi'] = get_target('fake_nairobi', seed=3, noise=False)   # 7-qubit IBM snapshot
else:
    print("device snapshots need the ibm extra: pip install 'qdensity[ibm]' (qiskit-ibm-runtime)")
reports = {}
for cname, circ in circuits.items():
    reports[cname] = {t: resource_report(circ, tgt, seed=0) for t, tgt in targets.items()}
    print(cname)
    print(compare_reports(reports[cname]))
    print()
# each RBS is two two-qubit gates on a CZ/CX device with all-to-all connectivity ...
n_rbs = pyramid(n).count_ops()['rbs']
assert reports['pyramid']['ideal'].two_qubit_count == 2 * n_rbs
# ... and exactly one native gate on the beam-splitter device
assert reports['pyramid']['rbs_native'].two_qubit_count == n_rbs
# a sparse lattice never needs fewer two-qubit gates than all-to-all connectivity
assert all(r['heavy_hex'].two_qubit_count >= r['ideal'].two_qubit_count for r in reports.values())
"""),
    ("code", r"""
import matplotlib.pyplot as plt

fig, ax = plt.subplots(figsize=(7, 3))
width = 0.8 / len(targets)
for i, t in enumerate(targets):
    ax.bar(np.arange(len(circuits)) + i * width, [reports[c][t].two_qubit_count for c in circuits],
           width, label=t)
ax.set_xticks(np.arange(len(circuits)) + 0.4 - width / 2, list(circuits), rotation=15)
ax.set_ylabel('two-qubit gates'); ax.legend(); ax.set_title(f'n = {n} data qubits')
plt.show()
"""),
    ("md", r"""
The ancilla preparations (deterministic, LCU) pay for their controlled sub-unitaries: each
controlled RBS is far more than two CZs, which is why the paper trains with the randomised
preparation (Fig. 1c, no extra qubits, no controlled gates) and keeps the deterministic one for
inference.

## OpenQASM 3 export

Any circuit, compiled or not, exports with `qiskit.qasm3.dumps`. The reference catalogue
(`qdensity export`, directory `circuits/`) writes every builder unrolled into `stdgates.inc`
with its trainable and data angles as `input float[64]`, so a provider binds them; the text
reloads with `qiskit.qasm3.loads` (needs `qiskit-qasm3-import`).
"""),
    ("code", r"""
from qiskit import qasm3

from qdensity.export import reference_qasm3, symbolic_circuit

compiled = targets['heavy_hex'].transpile(pyramid(n).assign_parameters(rng.uniform(-1, 1, 6)))
text = qasm3.dumps(compiled)
print(text[:400], '...')
assert text.startswith('OPENQASM 3.0;')

ref = reference_qasm3('round_robin_4')
print('\n'.join(ref.splitlines()[:12]), '\n...')
assert ref.count('input float[64]') == symbolic_circuit('round_robin_4').num_parameters == 6
if importlib.util.find_spec('qiskit_qasm3_import') is not None:
    loaded = qasm3.loads(ref)
    values = rng.uniform(-np.pi, np.pi, loaded.num_parameters)
    # the inputs come back as _θ_0_ .. _θ_5_ (OpenQASM identifiers), in that order
    a = loaded.assign_parameters(dict(zip(sorted(loaded.parameters, key=lambda p: p.name), values)))
    b = symbolic_circuit('round_robin_4').assign_parameters(values)
    assert Operator(a).equiv(Operator(b))
    print('reloaded OpenQASM 3 equals the builder up to a global phase')
"""),
]

# ------------------------------------------------------------------------------------------
NOISY = [
    ("md", r"""
# Noisy runs and shot schedulers

The randomised density QNN (Fig. 1c) prepares `rho = sum_k alpha_k U_k rho(x) U_k^dagger`
(eq. 1) only on average: each shot runs one sub-unitary `U_k`. Its output (eq. 3)
`f(x) = sum_k alpha_k f_k(x)` is estimated from a shot budget, and *how* the budget is split
over the `K` sub-unitaries matters (Supp. I):

* `per_shot`: the physical protocol of Fig. 1c, each shot draws `k ~ alpha`;
* `proportional`: `n_k ~ alpha_k S` fixed in advance (stratified sampling), which removes the
  between-sub-unitary variance `sum_k alpha_k (f_k - f)^2 / S`;
* `neyman`: a pilot run estimates each sub-unitary's spread `sigma_k`, the rest of the budget
  goes `n_k ~ alpha_k sigma_k` (the variance-optimal split).

Here a density OrthoQNN (round-robin, cut into its `n - 1` layers, Fig. 6) is sampled on a noisy
simulated device under a fixed budget with each scheduler; every estimate comes with a standard
error that never collapses to zero (Wilson's extra term, `qdensity.execution.intervals`), and we
compare with the exact value. Then the shot ledger, and readout mitigation with Hamming-weight
post-selection on a calibrated IBM device snapshot.
"""),
    ("code", r"""
import numpy as np
from qiskit.quantum_info import SparsePauliOp

from qdensity import DensityQNN, Encoding, SamplerEngine, by_moments, get_target
from qdensity.ansatze import round_robin

n = 4
dec = by_moments(round_robin(n))                      # K = n - 1 = 3 sub-unitaries
alpha = np.array([0.6, 0.3, 0.1])
model = DensityQNN(dec.sub_unitaries, alpha, encoding=Encoding.unary(n), seed=4)   # <Z_0>
x = np.array([0.3, -0.8, 0.5, 0.2])
f_k = model.expert_outputs(x[None])[0]                # exact, noiseless f_k(x)
exact = float(model.predict(x[None])[0])
assert np.isclose(exact, alpha @ f_k)
# per-shot value of sub-unitary k: +1 / -1 (the Z_0 eigenvalue) with P(-1) = p_k(e_0)
probs = DensityQNN(dec.sub_unitaries, alpha, encoding=Encoding.unary(n),
                   readout='unary_probabilities', seed=4).expert_outputs(x[None])[0]
var_k = 1 - f_k**2                                    # variance of a +-1 value with mean f_k
assert np.allclose(f_k, 1 - 2 * probs[:, 0])
print('f_k =', f_k.round(3), ' f = sum_k alpha_k f_k =', round(exact, 4))
"""),
    ("md", r"""
## The noisy target

`rbs_native` is a trapped-ion-like all-to-all device whose native two-qubit gate is the beam
splitter itself (one gate per RBS), with depolarising and thermal-relaxation errors after every
gate and 0.4% readout error, uniform across the chain, so the compiled layout does not change
the noise. Each `model.sample` call compiles for it and samples its noisy Aer simulator with a
fresh seed drawn from `seed` (pilot and main phase independent).
"""),
    ("code", r"""
target = get_target('rbs_native', n, seed=1)
assert target.is_noisy
budget, repeats = 2000, 4
runs = {s: [model.sample(x, budget, scheduler=s, target=target, seed=100 * r + i)
            for r in range(repeats)]
        for i, s in enumerate(('per_shot', 'proportional', 'neyman'))}
print(f"exact (noiseless) f = {exact:.4f}")
for s, results in runs.items():
    for res in results:
        assert res.shots_used == budget                      # never more than the budget
        assert abs(res.estimate - exact) < 5 * res.standard_error
    est = np.array([r.estimate for r in results])
    print(f"{s:>13}: estimates {np.round(est, 3)}, mean reported standard error "
          f"{np.mean([r.standard_error for r in results]):.4f}")
"""),
    ("md", r"""
The noise of this device pulls `f` towards 0 by about 0.01 here (depolarising shrinks
`<Z_0>`), less than the standard error of 2000 shots, so each estimate lies within a few
standard errors of the exact noiseless value (the calibrated snapshot below is much noisier).
The standard errors match the theory: with the exact `f_k` and per-shot variances
`1 - f_k^2`, the three schedulers' standard deviations are below. Here the two heaviest
sub-unitaries have close `f_k`, so stratification gains little; the gain is
`sum_k alpha_k (f_k - f)^2 / S`, largest when the `f_k` differ.
"""),
    ("code", r"""
from qdensity.schedulers import (allocate_neyman, allocate_proportional, per_shot_variance,
                                 stratified_variance)

theory = {
    'per_shot': per_shot_variance(alpha, f_k, var_k, budget),
    'proportional': stratified_variance(alpha, var_k, allocate_proportional(alpha, budget)),
    'neyman (true sigma, no pilot)': stratified_variance(
        alpha, var_k, allocate_neyman(alpha, np.sqrt(var_k), budget)),
}
for name, v in theory.items():
    print(f"{name:>30}: standard deviation {np.sqrt(v):.4f}")
assert theory['proportional'] <= theory['per_shot'] and theory['neyman (true sigma, no pilot)'] <= theory['proportional']
for s in ('per_shot', 'proportional'):
    reported = np.mean([r.standard_error for r in runs[s]])
    assert abs(reported - np.sqrt(theory[s])) < 0.25 * np.sqrt(theory[s])
"""),
    ("code", r"""
import matplotlib.pyplot as plt

fig, ax = plt.subplots(figsize=(7, 3))
for i, (s, results) in enumerate(runs.items()):
    xs = i + np.linspace(-0.2, 0.2, len(results))
    ax.errorbar(xs, [r.estimate for r in results], yerr=[r.standard_error for r in results],
                fmt='o', capsize=3, label=s)
ax.axhline(exact, color='k', ls='--', label='exact (noiseless)')
ax.set_xticks(range(len(runs)), list(runs)); ax.set_ylabel('estimate of f(x)')
ax.set_title(f'{budget} shots per estimate on rbs_native, error bars: 1 standard error')
ax.legend(fontsize=8); plt.show()
"""),
    ("md", r"""
## The shot ledger: pilot shots versus the allocation

A `ScheduleResult` reports the main phase's `allocation` and, for Neyman, the pilot's
`pilot_allocation`; `shots_used` is their sum and never exceeds the budget. An engine's
`ShotLedger` records every job: the randomised shots are labelled `randomised_k{k}`, a Neyman
pilot's `pilot_k{k}`.
"""),
    ("code", r"""
ney = runs['neyman'][0]
print('pilot     ', ney.pilot_allocation, '  (proportional to alpha)')
print('allocation', ney.allocation, '  (~ alpha_k sigma_k, sigma_k from the pilot)')
print('spreads from the pilot:', np.round(ney.info['pilot_sigma'], 3), ' exact:', np.sqrt(var_k).round(3))
assert ney.pilot_allocation.sum() + ney.allocation.sum() == ney.shots_used == budget

engine = SamplerEngine(target=target, seed=7)          # one engine, its ledger kept
res = model.sample(x, budget, scheduler='proportional', engine=engine)
print(engine.ledger.summary())
by_label = engine.ledger.by_label()
assert [by_label[f'randomised_k{k}'][1] for k in range(3)] == res.allocation.tolist()
"""),
    ("md", r"""
`engine=` uses one engine for every call, and an Aer sampler with a fixed seed repeats its shots
from one call to the next: fine for the single call of `per_shot` and `proportional`, but a
Neyman pilot and main phase would then share shots. For Neyman pass `target=` (fresh seeds per
call, as above) or a hardware sampler.

## Readout mitigation and Hamming-weight post-selection (the `ibm` extra)

On a calibrated device snapshot (`fake_manila`: the coupling map, gates, T1/T2 and readout
errors of an IBM device) noise biases the estimate by many standard errors. Two corrections
(`qdensity.execution.sampler.mitigated.mitigated_expectation`): mthree's readout mitigation (calibrated
on the same device, its shots in the ledger) and post-selection on Hamming weight 1 (a unary
model never leaves that subspace; gate noise does). Each `f_k` is estimated with a fixed
number of shots, then `f = sum_k alpha_k f_k`.
"""),
    ("code", r"""
import importlib.util

if importlib.util.find_spec('qiskit_ibm_runtime') and importlib.util.find_spec('mthree'):
    from qdensity.execution.sampler.mitigated import mitigated_expectation
    from qdensity.hardware.mitigation import ReadoutMitigator

    device = get_target('fake_manila', n, seed=0)
    eng = SamplerEngine(target=device, seed=3)
    mitigator = ReadoutMitigator(device, shots=4000, seed=4, ledger=eng.ledger)
    settings = {'raw': dict(postselect=None), 'post-selected': dict(postselect=1),
                'mitigated + post-selected': dict(mitigator=mitigator, postselect=1)}
    out = {}
    for name, kw in settings.items():
        parts = [mitigated_expectation(model.circuit(k), model.observable, model.rows(k, x[None]),
                                       engine=eng, shots=4000, label=name, **kw)
                 for k in range(model.num_subunitaries)]
        value = sum(a * p.value[0] for a, p in zip(alpha, parts))
        se = np.sqrt(sum((a * p.standard_error[0]) ** 2 for a, p in zip(alpha, parts)))
        kept = [round(float(p.kept_fraction[0]), 3) for p in parts]
        out[name] = (value, se)
        print(f"{name:>26}: {value:.4f} +- {se:.4f}  (error {value - exact:+.4f}; kept {kept})")
    print(eng.ledger.summary())
    raw, both = out['raw'], out['mitigated + post-selected']
    assert abs(both[0] - exact) < 5 * both[1] + 0.03
    assert abs(both[0] - exact) < abs(raw[0] - exact)
else:
    print("readout mitigation needs the ibm extra: pip install 'qdensity[ibm]' "
          "(qiskit-ibm-runtime and mthree)")
"""),
]

# ------------------------------------------------------------------------------------------
GRADIENTS = [
    ("md", r"""
# Gradients and Table 1

The gradient of a density QNN `f(x) = sum_k alpha_k f_k(x)` (eq. 3) splits over its
sub-unitaries (Prop. 1, Cor. 1): `df/dtheta_p = sum_k alpha_k df_k/dtheta_p`, and
`df/dalpha_k = f_k`. So each sub-unitary is differentiated alone, and a sub-unitary made of one
commuting block (one layer of a round-robin OrthoQNN, Fig. 6) needs a single circuit with a
diagonalising layer for *all* its parameters (Bowles et al.'s Thm. 1; Methods eq. 9,
Supp. F.3), where the parameter-shift rule needs four circuits per RBS gate (eq. 23, Supp. E).

This notebook checks both methods against finite differences of the exact output, samples them
with shots, and rebuilds Table 1 (gradient-circuit counts of five ansätze and their density
versions) from real gradient plans.
"""),
    ("code", r"""
import numpy as np

from qdensity import DensityQNN, Encoding, ExactEngine, SamplerEngine, by_moments
from qdensity.ansatze import round_robin
from qdensity.gradients import chain_rule, density_gradient_plan
from qdensity.mixtures import SoftmaxMixture

n = 4
dec = by_moments(round_robin(n))                     # K = 3 layers, 2 RBS gates each
model = DensityQNN(dec.sub_unitaries, SoftmaxMixture(logits=[0.3, -0.2, 0.5]),
                   encoding=Encoding.unary(n), seed=1)   # output <Z_0>
X = np.random.default_rng(2).normal(size=(2, n))
plans = {m: density_gradient_plan(model, X, method=m) for m in ('shift', 'commuting')}
for m, plan in plans.items():
    print(f"{m:>9}: {plan.meta['gradient_circuits']} gradient circuits per data point")
assert plans['shift'].meta['gradient_circuits'] == 4 * model.num_parameters     # 4 per RBS
assert plans['commuting'].meta['gradient_circuits'] == n - 1                    # 1 per layer
"""),
    ("md", r"""
## Exact gradients against finite differences

Both plans run on the exact engine; `chain_rule` turns the sub-unitary Jacobians and outputs
into the gradient of `sum_x f(x)` with respect to the angles and the mixture's logits.
Central finite differences of `model.predict` are the independent oracle.
"""),
    ("code", r"""
def total(theta=None, logits=None):
    saved = model.mixture.params
    if logits is not None:
        model.set_params(mixture=logits)
    try:
        return float(model.predict(X, theta=theta).sum())
    finally:
        model.set_params(mixture=saved)

h = 1e-5
fd_theta = np.array([(total(theta=model.theta + h * e) - total(theta=model.theta - h * e)) / (2 * h)
                     for e in np.eye(model.num_parameters)])
logits = model.mixture.params
fd_logits = np.array([(total(logits=logits + h * e) - total(logits=logits - h * e)) / (2 * h)
                      for e in np.eye(logits.size)])
upstream = np.ones((X.shape[0], 1))                   # d(sum_x f)/df
exact = {}
for m, plan in plans.items():
    exact[m] = plan.run(ExactEngine())              # a DensityGradient: outputs and Jacobians
    g_theta, g_logits = chain_rule(model, X, exact[m], upstream)
    assert np.allclose(g_theta, fd_theta, atol=1e-6), m
    assert np.allclose(g_logits, fd_logits, atol=1e-6), m
print('d f / d theta  :', fd_theta.round(4))
print('d f / d logits :', fd_logits.round(4))
print('shift and commuting gradients both equal finite differences to 1e-6')
"""),
    ("md", r"""
## Sampled gradients: same accuracy per circuit, 8 times fewer circuits

With shots every plan returns its standard errors; each entry of the sampled Jacobians lies
within a few standard errors of the exact one. At the same shots per circuit the commuting
method spends `(n - 1) / (4 n (n - 1) / 2) = 1/(2n)` of the shift method's gradient shots.
"""),
    ("code", r"""
shots = 1000
ledgers = {}
for m in plans:
    engine = SamplerEngine(seed=11, progress=False)
    sampled = density_gradient_plan(model, X, method=m, shots=shots).run(engine)
    worst = 0.0
    for s, e, err in zip(sampled.jacobians, exact[m].jacobians, sampled.jacobian_errors):
        # a gate after which nothing reaches qubit 0 has a structurally zero gradient: the
        # commuting estimator knows it exactly (value 0, error 0)
        assert np.all((err > 0) | (s == e))
        worst = max(worst, float(np.max(np.abs(s - e)[err > 0] / err[err > 0])))
    ledgers[m] = engine.ledger
    print(f"{m:>9}: {engine.ledger.total_circuits:3d} circuit rows, {engine.ledger.total_shots:7d} shots, "
          f"largest |sampled - exact| / standard error = {worst:.2f}")
    assert worst < 5
assert ledgers['shift'].total_shots > 4 * ledgers['commuting'].total_shots
"""),
    ("md", r"""
## Table 1, rebuilt

`qdensity.experiments.table1` builds each ansatz and its density version (hardware-efficient
cut into its `D` layers, `K` copies of the equivariant XX circuit, the odd-even pyramid of
Supp. H.1, butterfly and round-robin cut into layers), makes their gradient plans without running
them, and reads the circuit count off each plan. The paper's Table 1 gives the orders; the
exact constants behind them are checked here:

| ansatz | original `N_grad` | density `N_grad` |
|---|---|---|
| hardware-efficient, `D` layers | `2 n D` (two-term shift per rotation): O(nD) | `D`: O(D) |
| equivariant XX | 1 (one commuting block): O(1) | `K`: O(K) |
| pyramid | `4 n(n-1)/2`: O(n^2) | 2 (odd-even): O(1) |
| butterfly | `4 (n/2) log2 n`: O(n log n) | `log2 n`: O(log n) |
| round-robin | `4 n(n-1)/2`: O(n^2) | `n - 1`: O(n) |
"""),
    ("code", r"""
from qdensity.table1 import format_table1, table1

D, K = 3, 2
rows = table1((4, 8), layers=D, copies_k=K, verbose=False)
print(format_table1(rows))
formula = {   # (original, density) gradient circuits
    'hardware_efficient': lambda n: (2 * n * D, D),
    'equivariant_xx': lambda n: (1, K),
    'pyramid': lambda n: (4 * n * (n - 1) // 2, 2),
    'butterfly': lambda n: (4 * (n // 2) * int(np.log2(n)), int(np.log2(n))),
    'round_robin': lambda n: (4 * n * (n - 1) // 2, n - 1),
}
for r in rows:
    got = (r['original']['gradient_circuits'], r['density']['gradient_circuits'])
    assert got == formula[r['ansatz']](r['n']), (r['ansatz'], r['n'], got)
print('every count equals its formula')
"""),
    ("code", r"""
import matplotlib.pyplot as plt

fig, ax = plt.subplots(figsize=(8, 3))
labels = [f"{r['ansatz']}\nn={r['n']}" for r in rows]
pos = np.arange(len(rows))
ax.bar(pos - 0.2, [r['original']['gradient_circuits'] for r in rows], 0.4, label='original')
ax.bar(pos + 0.2, [r['density']['gradient_circuits'] for r in rows], 0.4, label='density')
ax.set_yscale('log'); ax.set_xticks(pos, labels, fontsize=7); ax.set_ylabel('gradient circuits')
ax.legend(); ax.set_title('Table 1: circuits for one full gradient, one data point'); plt.show()
"""),
    ("md", r"""
Two readings against the paper. The parameter counts of the density versions (the `params`
columns) are those of the original circuit for every row built from layers, so the speed-up is
in circuits, not in expressivity lost. The pyramid row uses the uncompressed odd-even split,
which keeps all `n(n-1)/2` angles; the paper's `O(n)` parameters for the density pyramid is the
*compressed* version (Supp. H.1, one gate per qubit pair), whose gradient also takes 2 circuits.
The equivariant row is the one where the density version costs more circuits (`K` instead of
1): the original is already a single commuting block.
"""),
]

# ------------------------------------------------------------------------------------------
TOMOGRAPHY = [
    ("md", r"""
# Tomography of unary states and of the density state

An orthogonal QNN (RBS circuits on a unary loader, Fig. 2, Fig. 9) leaves its output in the
unary subspace: `|y> = sum_j y_j |e_j>` with `y` real and of unit norm. Its *signed* amplitudes
are what a classical read-out layer needs (the MoE reading of Supp. H), and Supp. F reads them
with l-infinity tomography (Kerenidis-Prakash; Landman et al. Fig. 18) from three circuits:

0. the circuit measured as is: `p_j = y_j^2` gives the magnitudes;
1. then `RBS(pi/4)` on the pairs `(0,1), (2,3), ...`, and
2. on the pairs `(1,2), (3,4), ...`: the differences of the outcome probabilities give the
   relative sign of neighbouring amplitudes.

`O(log(n) / delta^2)` shots per circuit give `||y_hat - y||_inf <= delta` (up to the global
sign). `qdensity.tomography` builds the circuits, reconstructs from counts with an error bound,
and says how many shots a target error needs. Below: a pure unary state, the error against
shots, Hamming-weight post-selection on a noisy device, and the density state
`rho = sum_k alpha_k |y_k><y_k|` of a density QNN (eq. 1) rebuilt from its sub-unitaries.
"""),
    ("code", r"""
import numpy as np
from qiskit.quantum_info import Statevector

from qdensity import get_target, unary_loader
from qdensity.ansatze import round_robin
from qdensity.tomography import (bridge_circuit, bridge_pairs, reconstruct, shots_for_error,
                                 tomography_circuits)

n = 5
rng = np.random.default_rng(0)
x = np.array([0.6, -0.3, 0.9, 0.2, -0.5])
layer = round_robin(n)
circuit = unary_loader(x).compose(layer.assign_parameters(rng.uniform(-np.pi, np.pi, layer.num_parameters)))
y = Statevector(circuit).data.real[2 ** np.arange(n)]          # the exact unary amplitudes
assert np.isclose(np.linalg.norm(y), 1.0)
circuits = tomography_circuits(circuit)
print([c.name for c in circuits]); print(circuits[1].draw('text', fold=120))  # the even-pair circuit

ideal = get_target('ideal', n, seed=0)
compiled = ideal.transpile(circuits)

def sample(target, compiled, shots, seed):
    result = target.sampler(seed=seed, shots=shots).run(compiled).result()
    return [r.data.meas.get_counts() for r in result]

def linf(estimate, exact):                                      # up to the global sign
    return min(np.abs(estimate - exact).max(), np.abs(estimate + exact).max())
"""),
    ("code", r"""
res = reconstruct(sample(ideal, compiled, 4000, seed=1), n)
err = linf(res.amplitudes, y)
fidelity = float(res.amplitudes @ y) ** 2 / float(res.amplitudes @ res.amplitudes)
print('exact   ', y.round(3))
print('estimate', res.amplitudes.round(3), ' signs resolved:', res.signs_resolved)
print(f"l-inf error {err:.4f} <= bound {res.error_estimate:.4f}; fidelity {fidelity:.5f}, "
      f"trace distance {np.sqrt(1 - fidelity):.4f}")
assert res.signs_resolved and err <= res.error_estimate
assert fidelity > 0.99
print('shots per circuit for delta = 0.1 with probability 0.99:', shots_for_error(0.1, n, 0.01))
"""),
    ("md", r"""
## Error against shots

The l-infinity error falls like `1/sqrt(N)`; the bound `error_estimate` (which holds with
probability `1 - p_fail`, here 0.99) sits above it by the constant of `shots_for_error`
(`(1 + 4 sqrt 2) sqrt(ln(6 n / p_fail))` is the worst case over signs and outcomes).
"""),
    ("code", r"""
import matplotlib.pyplot as plt

budgets = [100, 300, 1000, 3000, 10000]
errors, bounds = [], []
for shots in budgets:
    runs = [reconstruct(sample(ideal, compiled, shots, seed=10 * shots + s), n) for s in range(3)]
    errors.append([linf(r.amplitudes, y) for r in runs])
    bounds.append(np.mean([r.error_estimate for r in runs]))
    assert all(linf(r.amplitudes, y) <= r.error_estimate for r in runs)
mean_err = np.mean(errors, axis=1)
slope = np.polyfit(np.log(budgets), np.log(mean_err), 1)[0]
print('mean l-inf error', mean_err.round(4), ' log-log slope', round(slope, 2))
assert -0.8 < slope < -0.3                      # 1/sqrt(N), within the noise of 3 runs

fig, ax = plt.subplots(figsize=(6, 3))
ax.loglog(budgets, mean_err, 'o-', label='l-inf error (mean of 3 runs)')
ax.loglog(budgets, bounds, 's--', label='error_estimate (p_fail = 0.01)')
ax.loglog(budgets, mean_err[0] * np.sqrt(budgets[0] / np.array(budgets)), ':', label='1/sqrt(N)')
ax.set_xlabel('shots per tomography circuit'); ax.set_ylabel('error'); ax.legend(fontsize=8)
plt.show()
"""),
    ("md", r"""
## On a noisy device: Hamming-weight post-selection

Gate and readout noise move weight out of the unary subspace. Keeping only Hamming-weight-1
outcomes (`postselect=True`, the default) and renormalising removes that part of the noise;
`kept_fraction` says how much was kept. Without post-selection the estimate is of the
un-renormalised amplitudes, shrunk by the leak.
"""),
    ("code", r"""
noisy = get_target('heavy_hex', n, seed=2)
counts = sample(noisy, noisy.transpile(circuits), 4000, seed=5)
kept = reconstruct(counts, n, postselect=True)
raw = reconstruct(counts, n, postselect=False)
print('kept fractions:', np.round(kept.kept_fraction, 3))
print(f"l-inf error, post-selected: {linf(kept.amplitudes, y):.4f}; all shots: {linf(raw.amplitudes, y):.4f}")
assert linf(kept.amplitudes, y) < linf(raw.amplitudes, y)
"""),
    ("md", r"""
## The density state of a density QNN

The density QNN's state (eq. 1) on a unary input with Hamming-weight-preserving sub-unitaries
is `rho = sum_k alpha_k |y_k><y_k|`, an `n x n` real matrix on the unary subspace, with
`y_k = U_k |x>`. Tomography of each sub-unitary's randomised circuit (Fig. 1c) gives
`y_hat_k`, and `rho_hat = sum_k alpha_k |y_hat_k><y_hat_k|` (the global sign of each `y_hat_k`
cancels). Where an amplitude is (near) zero between two others the three circuits cannot fix the
relative sign across it; `bridge_pairs` names the pairs of an extra `bridge_circuit` that does.
We compare with the exact `rho` by the trace distance
(`qdensity.analysis.mixing.trace_distance` returns the trace norm `||rho - sigma||_1`, twice
the trace distance) and the fidelity.
"""),
    ("code", r"""
from scipy.linalg import sqrtm

from qdensity import by_moments
from qdensity.analysis.mixing import trace_distance
from qdensity.preparation import randomised_circuits

dec = by_moments(round_robin(n))                              # K = n = 5 layers (n odd)
subs = [c.assign_parameters(rng.uniform(-np.pi, np.pi, c.num_parameters)) for c in dec.sub_unitaries]
alpha = rng.dirichlet(np.ones(len(subs)))
prepared = randomised_circuits(subs, unary_loader(x))          # U_k V(x), one per k
ys = [Statevector(c).data.real[2 ** np.arange(n)] for c in prepared]
rho = sum(a * np.outer(v, v) for a, v in zip(alpha, ys))

def fidelity(a, b):
    root = sqrtm(a)
    return float(np.real(np.trace(sqrtm(root @ b @ root))) ** 2)

def tomograph(circ, shots, seed):
    # the three circuits, then bridge circuits across any gap the signs could not cross
    counts = sample(ideal, ideal.transpile(tomography_circuits(circ)), shots, seed)
    res = reconstruct(counts, n)
    pairs = bridge_pairs(res)
    if pairs:
        bridges = ideal.transpile([bridge_circuit(circ, p) for p in pairs])
        res = reconstruct(counts, n, extra=list(zip(pairs, sample(ideal, bridges, shots, seed + 1))))
    return res, len(pairs)

distances = []
for shots in (500, 5000):
    results = [tomograph(c, shots, seed=10 * k) for k, c in enumerate(prepared)]
    assert all(r.signs_resolved for r, _ in results)
    y_hat = [r.amplitudes for r, _ in results]
    rho_hat = sum(a * np.outer(v, v) for a, v in zip(alpha, y_hat))
    td = trace_distance(rho_hat, rho) / 2
    # convexity, then D(a, b) = sqrt(1 - (a.b)^2) <= ||a - b||_2 <= sqrt(n) ||a - b||_inf for unit
    # vectors: a bound from the per-circuit l-inf bounds (each holds with probability 0.99)
    bound = sum(a * np.sqrt(n) * r.error_estimate for a, (r, _) in zip(alpha, results))
    print(f"{shots:>5} shots per circuit: trace distance {td:.4f} <= bound {bound:.4f}, "
          f"fidelity {fidelity(rho_hat, rho):.5f}, bridge circuits {[b for _, b in results]}")
    assert td <= bound
    distances.append(td)
assert distances[1] < distances[0]
print(f"purity of rho: {np.trace(rho @ rho):.3f} (a mixed state: the density QNN is not a pure QNN)")
"""),
]


NOTEBOOKS = {
    "circuits_and_transpilation": CIRCUITS,
    "noisy_runs_and_schedulers": NOISY,
    "gradients_and_table1": GRADIENTS,
    "tomography": TOMOGRAPHY,
}


def write(name: str) -> Path:
    """Write ``notebooks/<name>.ipynb`` from its cells (no outputs)."""
    nb = new_notebook(cells=_cells(NOTEBOOKS[name]))
    for i, cell in enumerate(nb.cells):     # stable ids: regenerating gives no diff
        cell.id = f"{name[:20]}-{i}"
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3",
                                 "language": "python"}
    path = HERE / f"{name}.ipynb"
    nbformat.write(nb, path)
    return path


if __name__ == "__main__":
    for name in sys.argv[1:] or list(NOTEBOOKS):
        print(write(name))
