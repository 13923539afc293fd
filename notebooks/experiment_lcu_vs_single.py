# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#       jupytext_version: 1.19.6
# ---

# %% [markdown]
# # LCU QNN vs a single circuit (paper Supp. C)
#
# **The paper's claim** (Supp. C, figure "LCU QNN versus single unitary QNN"): train $n-1 = 9$
# fully parameterised round-robin sub-unitaries for 20 epochs (their accuracy is the mixing
# lemma's $\delta_1$), freeze them, combine them into an LCU QNN
# $\sum_k \alpha_k(x) U_k |x\rangle$ (post-selected) with coefficients from a small network, and
# train only that network: the LCU QNN reaches a higher MNIST test accuracy than any single
# round-robin circuit. The paper does not count the post-selection overhead; qdensity reports the
# success probability $\|\sum_k \alpha_k(x) U_k |x\rangle\|^2$ and checks the model through the
# gate-level LCU circuit sampled with post-selection.

# %%
import tempfile
from pathlib import Path

from IPython.display import Image, display

from qdensity_paper import run

out = tempfile.mkdtemp()
try:
    result = run('lcu-vs-single', mode="quick", out=out, progress=False)
except ImportError as exc:  # an optional extra is missing: say what to install
    result = None
    print(f"skipped: {exc}")
if result is not None:
    for key, s in result.summary.items():
        print(f"{key:<36} {s['mean']:.4f}  [{s['low']:.4f}, {s['high']:.4f}]")
    display(Image(filename=str(Path(out) / 'lcu-vs-single-quick.png')))

# %% [markdown]
# **How to read it.** Left: test accuracy against epochs. The single circuit trains for all
# epochs; the sub-unitaries pretrain (best one chosen on training accuracy, and their mean), and the
# LCU curve starts at the end of pretraining with a uniform $\alpha$ and then trains only the gate.
# Middle: the same against the shots the training would cost on hardware (four-term parameter
# shift per RBS angle; the LCU phase divides by the success probability, since only post-selected
# shots count) -- the LCU's pretraining of $n-1$ circuits makes it far more expensive. Right: the
# success probability, which the paper leaves out: it multiplies every LCU shot count by
# $1/p$. The `sampled/*` rows compare estimates from the sampled 2n-1-qubit LCU circuit with the
# exact model. At quick size (4 qubits, 2 epochs per phase) nothing here is the scientific
# result; the full-size numbers (10 qubits, 20 + 20 epochs, 5 seeds) are in EXPERIMENTS.md.
