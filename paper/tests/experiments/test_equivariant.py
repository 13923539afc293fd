"""The ``equivariant`` experiment (paper Fig. 5) at a tiny size: output shape and invariants,
shot accounting against Bowles et al.'s circuit counts, refused settings. The scientific
result is not asserted here (it needs the full run)."""

import json

import numpy as np
import pytest

from qdensity.models.warm_start import warm_start
from qdensity_paper import run
from qdensity_paper._common import circuits_per_row
from qdensity_paper._equivariant_models import LABELS, single_model
from qdensity_paper.equivariant import EXPERIMENT, gradient_circuits

TINY = {"num_qubits": 4, "train_size": 12, "test_size": 8, "batch_size": 4,
        "pretrain_steps": 2, "density_steps": 2, "eval_every": 1, "tail": 1,
        "shots_per_circuit": 10, "layers": 1, "max_weight": 2}


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("equivariant")
    return run("equivariant", seeds=[0, 3], config=TINY, out=out, progress=False), out


def test_files_seeds_and_confidence_intervals(tiny):
    result, out = tiny
    assert result.seeds == [0, 3]
    saved = json.loads((out / "equivariant-quick.json").read_text())
    assert saved["seeds"] == [0, 3] and len(saved["per_seed"]) == 2
    assert [p.rsplit("/", 1)[-1] for p in result.figures] == ["equivariant-quick-epoch.png",
                                                              "equivariant-quick-shots.png"]
    assert all((out / p.rsplit("/", 1)[-1]).stat().st_size > 1000 for p in result.figures)
    for fam in ("xx", "noncommuting", "qcnn"):
        for key in ("base_test_accuracy", "density_test_accuracy", "density_gain"):
            s = result.summary[f"{fam}/{key}"]
            assert s["n"] == 2 and s["low"] <= s["mean"] <= s["high"]
        for seed_metrics in result.per_seed:
            acc = [seed_metrics[f"{fam}/{k}_test_accuracy"] for k in ("base", "density")]
            assert all(0.0 <= a <= 1.0 for a in acc)
            assert np.isclose(seed_metrics[f"{fam}/density_gain"], acc[1] - acc[0])
            assert 0.0 < seed_metrics[f"{fam}/density_alpha_2"] < 1.0


def test_curves_lengths_and_shots(tiny):
    result, _ = tiny
    pre, post, batch, spc = 2, 2, 4, 10
    for fam, (base, dens) in LABELS.items():
        c_base = gradient_circuits(fam, 4, False, max_weight=2, layers=1)
        c_second = gradient_circuits(fam, 4, True, max_weight=2, layers=1)
        for m in result.per_seed:
            curves = m["curves"]
            assert curves[f"{base}/test_vs_epoch"]["x"] == [0, 1, 2, 3, 4]
            assert curves[f"{dens}/test_vs_epoch"]["x"] == [2, 3, 4]
            b_shots = curves[f"{base}/test_vs_shots"]["x"]
            d_shots = curves[f"{dens}/test_vs_shots"]["x"]
            # shots of a step: circuits per row x rows x shots per circuit (Bowles et al.)
            assert b_shots == [s * c_base * batch * spc for s in (1, 2, 3, 4)]
            start = pre * (c_base + c_second) * batch * spc   # the gap of Fig. 5b
            assert d_shots == [start + s * (c_base + c_second) * batch * spc
                               for s in range(post + 1)]
            assert np.all(np.diff(b_shots) > 0) and np.all(np.diff(d_shots) > 0)
            assert m[f"{fam}/density_shots"] == d_shots[-1]
            # the density phase starts from the base model at the switch
            base_acc = curves[f"{base}/test_vs_epoch"]["y"]
            assert m[f"{fam}/base_test_accuracy_at_switch"] == base_acc[pre]
        summary = result.curves[f"{dens}/test_vs_epoch"]
        assert len(summary["mean"]) == post + 1
        assert all(lo <= mu <= hi for lo, mu, hi in zip(summary["low"], summary["mean"],
                                                        summary["high"], strict=True))


def test_reproducible(tiny):
    result, _ = tiny
    again = run("equivariant", seeds=[3], config=TINY, progress=False)
    assert again.per_seed[0]["curves"] == result.per_seed[1]["curves"]


@pytest.mark.parametrize("n", [4, 6])
def test_gradient_circuits_match_bowles_counts(n):
    # commuting XX model: one circuit per Z_i of the observable sum (Bowles et al.'s
    # num_circuits_commuting = qubits), plus one forward circuit
    assert gradient_circuits("xx", n, False) == n + 1
    assert gradient_circuits("xx", n, True) == n + 1
    # non-commuting: two shifted circuits per generator, layers * n/2 * (n + 3) generators
    for layers in (1, 2):
        gens = layers * n // 2 * (n + 3)
        assert gradient_circuits("noncommuting", n, False, layers=layers) == 2 * gens + 1
    # QCNN: two-term rule per rx / rz, four-term rule per controlled rotation, plus forward
    circ = single_model("qcnn", n, False, None).sub_unitaries[0]
    ops = circ.count_ops()
    expected = 2 * (ops["rx"] + ops["rz"]) + 4 * (ops["crz"] + ops["crx"]) + 1
    assert gradient_circuits("qcnn", n, False) == expected


def test_density_circuits_are_the_sum_over_sub_unitaries():
    a = single_model("xx", 4, False, 0, max_weight=2)
    b = single_model("xx", 4, True, 1, max_weight=2)
    dens = warm_start([a, b], [0.99, 0.01])
    total = circuits_per_row(dens, np.zeros((1, 4)), "commuting")
    assert total == (gradient_circuits("xx", 4, False, max_weight=2)
                     + gradient_circuits("xx", 4, True, max_weight=2))


def test_second_sub_unitary_is_yy_and_independent():
    a = single_model("xx", 4, False, 0).sub_unitaries[0]
    b = single_model("xx", 4, True, 0).sub_unitaries[0]
    assert {g.operation.operator.paulis[0].to_label().replace("I", "")[0] for g in a.data} == {"X"}
    assert {g.operation.operator.paulis[0].to_label().replace("I", "")[0] for g in b.data} == {"Y"}
    assert not set(a.parameters) & set(b.parameters)


@pytest.mark.parametrize("key, value", [
    ("num_qubits", 3), ("train_size", 0), ("learning_rate", 0.0), ("noise_std", -1.0),
    ("angle_scale", 0.0), ("families", ["xx", "mlp"]), ("families", []), ("alpha_init", [0.5, 0.6]),
    ("alpha_init", [1.0, 0.0]), ("batch_size", 100), ("max_weight", 9), ("eval_every", 0),
    ("tail", 50),
])
def test_bad_settings_are_refused(key, value):
    with pytest.raises(ValueError, match=key):
        run("equivariant", seeds=1, config={**TINY, key: value}, progress=False)


def test_full_settings_follow_the_paper():
    full = EXPERIMENT.full
    assert (full["num_qubits"], full["noise_std"], full["train_size"], full["test_size"],
            full["batch_size"]) == (10, 1.8, 1000, 100, 20)
    assert full["alpha_init"] == [0.99, 0.01] and EXPERIMENT.seeds["full"] == 5
    assert "learning rate" in EXPERIMENT.reductions


def test_angle_scale_sets_the_encoding_angle():
    from qdensity.datasets.bars_and_dots import bars_and_dots
    from qdensity_paper.equivariant import _data

    cfg = {**EXPERIMENT.quick, "angle_scale": np.pi / 2}
    X, y, Xt, yt = _data(cfg, np.random.default_rng(5))
    rng = np.random.default_rng(5)
    X0, y0 = bars_and_dots(cfg["train_size"], cfg["num_qubits"], cfg["noise_std"], seed=rng)
    assert np.allclose(X, X0) and np.array_equal(y, y0)   # pi/2: the data go in unchanged
    X2, *_ = _data({**cfg, "angle_scale": 0.5}, np.random.default_rng(5))
    assert np.allclose(np.pi / 2 * X2, 0.5 * X0)          # R_y(pi x'/2) = R_y(0.5 x)


def test_papers_way_sum_z_readout_and_one_initialisation():
    """--paper's way (Fig. 5): every run starts from the same data and initial angles (equal
    step-0 accuracy) and differs in batch order; the read-out is sign(sum_i <Z_i>), whose
    accuracies are multiples of 1 / test_size."""
    from qdensity_paper import run
    from qdensity_paper.registry import get_experiment

    paper = get_experiment("equivariant").protocol.settings
    assert paper["readout"] == "sum_z" and paper["same_initialisation"] is True
    cfg = {"readout": "sum_z", "same_initialisation": True, "families": ["xx"]}
    rows = run("equivariant", seeds=[0, 1], config=cfg, progress=False).per_seed
    first = [row["curves"]["XX/test_vs_epoch"]["y"][0] for row in rows]
    assert first[0] == first[1]
    assert rows[0]["curves"] != rows[1]["curves"]
    n = run("equivariant", seeds=[0], config=cfg, progress=False).config["test_size"]
    for row in rows:
        acc = row["xx/second_test_accuracy"]
        assert abs(acc * n - round(acc * n)) < 1e-9
    with pytest.raises(ValueError, match="readout"):
        run("equivariant", seeds=[0], config={"readout": "softmax"}, progress=False)


def test_shots_figure_shows_the_gap_of_fig_5b(tiny, tmp_path, monkeypatch):
    """Fig. 5b: the density curve starts only after the shots that pretrained the second
    sub-unitary. Its first shot count exceeds the base model's at the switch by
    ``pretrain_steps x circuits(U_2) x batch x shots per circuit``, with the circuits counted
    here from Bowles et al.'s formulas (XX / YY: one circuit per Z_i plus the forward one;
    non-commuting: two shifted circuits per generator, ``layers n/2 (n + 3)`` generators, plus
    the forward one); the figure shades exactly that span, the base model's solid line ends at
    the switch, and no line of the density model reaches into the gap."""
    from matplotlib.axes import Axes

    from qdensity_paper.equivariant import plot

    result, _ = tiny
    n, pre, batch, spc = 4, 2, 4, 10
    second = {"xx": n + 1, "noncommuting": 2 * (1 * n // 2 * (n + 3)) + 1}
    base_circuits = second  # U_1 has U_2's structure in both families
    lines, spans = [], []
    real_plot, real_span = Axes.plot, Axes.axvspan
    monkeypatch.setattr(Axes, "plot", lambda self, *a, **kw: (
        lines.append((id(self.figure), np.asarray(a[0], float), kw.get("label"),
                      kw.get("ls", "-"))),
        real_plot(self, *a, **kw))[1])
    monkeypatch.setattr(Axes, "axvspan", lambda self, lo, hi, **kw: (
        spans.append((lo, hi, kw.get("label"))), real_span(self, lo, hi, **kw))[1])
    paths = plot(result, tmp_path)
    shots_figure = lines[-1][0]  # the shots figure is drawn last
    lines = [line[1:] for line in lines if line[0] == shots_figure]
    assert paths[1].name == "equivariant-quick-shots.png" and paths[1].stat().st_size > 1000
    for fam, c2 in second.items():
        base, dens = LABELS[fam]
        switch = pre * base_circuits[fam] * batch * spc
        start = switch + pre * c2 * batch * spc
        for m in result.per_seed:
            assert m["curves"][f"{dens}/test_vs_shots"]["x"][0] == start
        assert (switch, start) in [(lo, hi) for lo, hi, _ in spans]
        solid = [x for x, label, ls in lines if label == base and ls == "-"]
        assert len(solid) == 1 and solid[0].max() == switch
        dens_x = [x for x, label, _ in lines if label == dens]
        assert len(dens_x) == 1 and dens_x[0].min() == start
        # nothing but the base model's dashed "trained on" line spans the gap
        for x, label, ls in lines:
            crosses = np.any((x[:-1] <= switch) & (x[1:] >= start))
            assert not crosses or (label == f"{base}, trained on" and ls == "--")
