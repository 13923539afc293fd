"""The paper's numerical claims, each with its kind, its quantity and the paper's line.

One table, :data:`CLAIMS`, of every claim the paper makes from its numerics that an experiment
of this package can answer. Each :class:`Claim` declares the kind of statement it is, so the
verdict rule (:mod:`qdensity_paper.verdicts`) judges it with the test that fits:

``superiority``
    "A is better than B": the paired difference ``a - b`` over seeds, on the paper's side.
``non-inferiority``
    "A loses little or nothing against B": ``a - b`` above ``-margin`` (one-sided t-test).
``equivalence``
    "A is level with B" (or with a number the paper reports): ``|a - b| < margin`` (TOST).
``trend``
    "the quantity grows (falls) along a grid": the per-seed slope over ``series``.
``bound``
    a theorem: ``a - b >= 0`` in every seed (the smallest margin is reported).
``exact``
    a count the paper states: ``a == reference`` in every seed.

The margins of the non-inferiority and equivalence claims come from the paper's wording; each
claim gives two (``margins[0]`` decides, ``margins[1]`` is reported beside it) and
``margin_reason`` says why.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Claim", "CLAIMS", "KINDS", "claims_of"]

#: The kinds of claim, each judged by its own test.
KINDS = ("superiority", "non-inferiority", "equivalence", "trend", "bound", "exact")

# Accuracy margins: "minimal or no performance loss" / "reaches the accuracy of". 0.05 reads
# "minimal" as under 5 accuracy points; 0.02 reads "no loss" strictly: two standard errors of
# a test accuracy near 0.85 on 1,000 test images (sqrt(0.85 * 0.15 / 1000) = 0.011), the
# smallest difference such a test set resolves.
_ACCURACY = (0.05, 0.02)
_ACCURACY_WHY = ("0.05: 'minimal' loss read as under 5 accuracy points; 0.02: 'no' loss, two "
                 "standard errors of an accuracy near 0.85 on 1,000 test images")


@dataclass(frozen=True)
class Claim:
    """One numerical claim of the paper.

    Attributes
    ----------
    key : str
        ``"<experiment>/<name>"``, unique; departures name the claims they touch by it.
    text : str
        The claim in a few words.
    line : str
        Where the paper makes it, with its words.
    kind : str
        One of :data:`KINDS`.
    a, b : str
        Metric names of one seed (``b`` None: ``a`` against ``reference``, or alone).
    sign : {+1, -1}
        +1: the paper says ``a - b`` is positive (``a`` better, larger); -1: negative.
    margins : tuple of float
        Non-inferiority and equivalence: the decisive margin and a second one.
    margin_reason : str
        Why those margins, from the paper's wording.
    reference : float, optional
        A number the paper reports (equivalence to it, or an exact count).
    series : tuple of (float, str)
        Trend: grid value and metric name, in grid order.
    caveat : str
        What a reader must know beside the verdict.
    """

    key: str
    text: str
    line: str
    kind: str
    a: str = ""
    b: str | None = None
    sign: int = 1
    margins: tuple[float, ...] = ()
    margin_reason: str = ""
    reference: float | None = None
    series: tuple[tuple[float, str], ...] = ()
    caveat: str = ""

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {self.kind!r}")
        if self.sign not in (1, -1):
            raise ValueError(f"sign must be +1 or -1, got {self.sign!r}")
        if self.kind in ("non-inferiority", "equivalence") and (
                len(self.margins) != 2 or min(self.margins) <= 0):
            raise ValueError(f"claim {self.key!r}: a {self.kind} claim needs two positive "
                             f"margins, got {self.margins!r}")
        if self.kind == "trend" and len(self.series) < 2:
            raise ValueError(f"claim {self.key!r}: a trend needs >= 2 grid points")
        if self.kind == "exact" and self.reference is None:
            raise ValueError(f"claim {self.key!r}: an exact claim needs a reference")

    @property
    def experiment(self) -> str:
        return self.key.split("/", 1)[0]

    @property
    def metrics(self) -> list[str]:
        if self.kind == "trend":
            return [m for _, m in self.series]
        return [m for m in (self.a, self.b) if m]

    @property
    def quantity(self) -> str:
        if self.kind == "trend":
            return f"slope of {self.series[0][1].split('/')[-1]} over " + ", ".join(
                f"{x:g}" for x, _ in self.series)
        if self.b:
            return f"{self.a} - {self.b}"
        return self.a if self.reference is None else f"{self.a} - {self.reference:g}"


_FIG5 = ("Fig. 5 caption: 'In all cases, after base model performance saturation, the density "
         "QNN improves the final result'")
_FIG7 = ("Fig. 7 caption: 'Performance of density QNN increases monotonically with sub-unitary "
         "depth, D'")
_FIG7_CIRC = ("Fig. 7 caption: 'For D=1 the density QNN ... requires only n-1 circuit evaluations "
              "for each iteration whereas the OrthoQNN requires 4n(n-1)/2 circuits'")
_TAKEAWAY = ("Results, takeaways (OrthoQNNs): 'Non-backpropagation scaling models can be made "
             "trainable with minimal or no performance loss'")
_FIG11 = ("Fig. 11b and the hyperparameters appendix: the density OrthoQNNs reach the pure "
          "pyramid's test accuracy at fewer shots")
_COUNTS = ("Hyperparameters appendix: 'the best x/32 hyperparameter runs, those which achieve "
           "at least 80% accuracy ... OrthoQNN: 30/32, Density OrthoQNN: 28/32, Density OrthoQNN "
           "(compressed): 30/32'")
_FIG6 = ("Mitigating overfitting: 'as the vanilla reuploading model becomes more expressive (with "
         "increasing L), it overfits and test error grows. In contrast, the density model ... does "
         "not overfit and the test error remains small'")
_SUPPJ = ("Supp. J, Fig. 17: 'For a fixed parameter budget, the density QNN is less prone to "
          "overfitting ... and generalisation improves (test MSE decreases) as the number of "
          "sub-unitaries increases'")
_MOE = "Supp. H.2 (MoE observations)"
_L = (5, 10, 20, 30, 40, 50)


def _equivariant() -> list[Claim]:
    names = {"xx": "XX+YY", "noncommuting": "non-commuting", "qcnn": "QCNN"}
    return [Claim(f"equivariant/{f}", f"the {n} density model ends above its base model",
                  _FIG5, "superiority", f"{f}/density_test_accuracy", f"{f}/base_test_accuracy")
            for f, n in names.items()]


def _orthoqnn() -> list[Claim]:
    return [
        Claim("orthoqnn-depth/shallow", "the shallow (D = 1) density OrthoQNN loses little or "
              "nothing against the pure round-robin OrthoQNN", _TAKEAWAY, "non-inferiority",
              "D1/test_accuracy", "pure/test_accuracy", margins=_ACCURACY,
              margin_reason=_ACCURACY_WHY),
        Claim("orthoqnn-depth/depth-trend", "test accuracy rises with sub-unitary depth D",
              _FIG7, "trend", series=tuple((d, f"D{d}/test_accuracy") for d in (1, 2, 3, 4, 9))),
        Claim("orthoqnn-depth/circuits-pure", "the OrthoQNN's parameter-shift gradient takes "
              "4n(n-1)/2 = 180 circuits per row", _FIG7_CIRC, "exact",
              "pure/circuits/parameter_gradients", reference=180.0),
        Claim("orthoqnn-depth/circuits-shallow", "the D = 1 density model's gradient takes "
              "n - 1 = 9 circuits per row", _FIG7_CIRC, "exact",
              "D1/circuits/parameter_gradients", reference=9.0),
    ]


def _pyramid() -> list[Claim]:
    out = [Claim(f"pyramid-shots/{m.replace('_', '-')}", f"the {label} density model reaches "
                 "the pure pyramid's accuracy (the trial each study selects)", _FIG11,
                 "non-inferiority", f"{m}/test_accuracy", "pure/test_accuracy",
                 margins=_ACCURACY, margin_reason=_ACCURACY_WHY)
           for m, label in (("odd_even", "odd-even"), ("compressed", "compressed"))]
    out.append(Claim("pyramid-shots/budget", "at the odd-even model's whole training budget of "
                     "shots it is ahead of the pure model (both the mean over the runs above "
                     "80%)", _FIG11, "superiority", "odd_even/runs_above_mean",
                     "pure/test_accuracy_at_density_budget"))
    for m, paper in (("pure", 30), ("odd_even", 28), ("compressed", 30)):
        out.append(Claim(f"pyramid-shots/count-{m.replace('_', '-')}", f"{paper}/32 of the "
                         f"{m.replace('_', '-')} runs reach 80%", _COUNTS, "equivalence",
                         f"{m}/runs_above", reference=float(paper), margins=(3.0, 1.5),
                         margin_reason="3 runs of 32 (about 10%, the spread between the paper's "
                                       "three models); 1.5: half that"))
    return out


def _reuploading() -> list[Claim]:
    out = []
    for s, where in (("methods", "Methods (T_4)"), ("supp_j", "Supp. J (T_2)")):
        tag = s.replace("_", "-")
        out += [
            Claim(f"reuploading/{tag}-gap", f"{where}: at L = 50 the density model's "
                  "generalisation gap is below the vanilla model's", _FIG6, "superiority",
                  f"{s}/vanilla/L50/gap", f"{s}/density/L50/gap"),
            Claim(f"reuploading/{tag}-test", f"{where}: at L = 50 the density model's test MSE "
                  "is below the vanilla model's", _FIG6, "superiority",
                  f"{s}/vanilla/L50/test_mse", f"{s}/density/L50/test_mse"),
            Claim(f"reuploading/{tag}-vanilla-trend", f"{where}: the vanilla model's test MSE "
                  "grows with L", _FIG6, "trend",
                  series=tuple((L, f"{s}/vanilla/L{L}/test_mse") for L in _L)),
        ]
    out.append(Claim("reuploading/supp-j-experts-trend", "Supp. J (T_2): at L = 50 the density "
                     "model's test MSE falls as K grows (2, 5, 7)", _SUPPJ, "trend", sign=-1,
                     series=((2, "supp_j/density_K2/L50/test_mse"),
                             (5, "supp_j/density/L50/test_mse"),
                             (7, "supp_j/density_K7/L50/test_mse"))))
    out.append(Claim("reuploading/t3-test", "Supp. J (T_3): at L = 50 the density model's test "
                     "MSE is below the vanilla model's", "Supp. J: 'we test on higher degree "
                     "Chebyshev polynomials, T_3(x) and T_4(x) ... Again the density model is "
                     "able to fit the test data well and again each combats overfitting'",
                     "superiority", "t3/vanilla/L50/test_mse", "t3/density/L50/test_mse"))
    return out


def _moe() -> list[Claim]:
    out = [Claim("moe/odd-even-gate-helps", "the MoE gate raises the odd-even density model's "
                 "mean accuracy over the sweep", f"{_MOE}: 'for models with larger parameter "
                 "counts per sub-unitary, e.g. the uncompressed odd-even decomposition, the "
                 "data-dependent attention does appear to help'", "superiority",
                 "odd_even/moe/mean_accuracy", "odd_even/density/mean_accuracy"),
           Claim("moe/odd-even-gate-level", "with the MoE gate the odd-even density model "
                 "reaches the pure pyramid's mean accuracy", f"{_MOE}: '... and can boost "
                 "performance to the level of the original model'", "non-inferiority",
                 "odd_even/moe/mean_accuracy", "pyramid/pure/mean_accuracy",
                 margins=_ACCURACY, margin_reason=_ACCURACY_WHY),
           Claim("moe/butterfly-density-best", "the butterfly density model's best accuracy is "
                 "above the pure butterfly's", f"{_MOE}: 'the vanilla density model can "
                 "outperform it's pure version, e.g. comparing best accuracy achieved by the "
                 "density QNN-butterfly versus the OrthoQNN-butterfly'", "superiority",
                 "butterfly/density/best_accuracy", "butterfly/pure/best_accuracy")]
    for d in ("butterfly", "odd_even", "compressed"):
        out.append(Claim(f"moe/spread-{d.replace('_', '-')}", f"the MoE gate narrows the spread "
                         f"over hyperparameters ({d.replace('_', '-')}, std over trials)",
                         f"{_MOE}: 'making alpha(x) data dependent ... reduces the variance of "
                         "the training over hyperparameter runs, which can be observed in all "
                         "scenarios'", "superiority", f"{d}/moe/std_accuracy",
                         f"{d}/density/std_accuracy", sign=-1))
    return out


#: Every claim, in the order of the paper's experiments.
CLAIMS: tuple[Claim, ...] = (
    *_equivariant(), *_orthoqnn(), *_pyramid(), *_reuploading(),
    Claim("lcu-vs-single/lcu-beats-single", "the LCU QNN beats the single-circuit QNN",
          "Supp. C: 'the final LCU QNN can outperform any single circuit QNN in terms of MNIST "
          "test accuracy'", "superiority", "lcu/minus_single"),
    Claim("mixing-lemma/hastings-campbell", "the channel distance stays below eps_1^2 + 2 eps_2 "
          "in every seed", "Supp. B.2, Hastings-Campbell mixing lemma (eq. mixing_lemma_result): "
          "||Lambda - V||_diamond <= eps_1^2 + 2 eps_2", "bound", "lemma/bound",
          "lemma/distance_max"),
    Claim("mixing-lemma/lemma-1", "the density model's prediction error stays below "
          "delta_1^2 / (4 ||O||) + 2 delta_2 in every seed", "Lemma 1 (eq. "
          "supervised_mixing_corollary): E|h - f| <= delta_1^2 / (4 ||O||_inf) + 2 delta_2",
          "bound", "lemma1/lemma1_bound", "lemma1/density_error"),
    *_moe(),
    Claim("dropout/mitigates", "trained by the randomised preparation and predicting with the "
          "deterministic one, the density model overfits less than the vanilla model "
          "(generalisation gap)", "Quantum dropout: 'we propose the randomised implementation "
          "... as the state preparation method for the training phase ... the deterministic "
          "density QNN as the inference mode'; 'the density QNN still can, in some capacity, "
          "mitigate overfitting, and perform the effective action of dropout'", "superiority",
          "vanilla/gap", "dropout/gap"),
    Claim("dropout/level-with-exact", "dropout training loses little or nothing in test MSE "
          "against exact training of the same density model", "Quantum dropout: 'Due to the "
          "linearity of the model, this has the effect of weighting the contributions of each "
          "sub-unitary QNN by the corresponding coefficients, exactly as in classical dropout'",
          "non-inferiority", "dropout/test_mse", "exact/test_mse", sign=-1,
          margins=(0.01, 0.005), margin_reason="a quarter and an eighth of the variance of "
          "Supp. J's label noise (0.04): test-MSE differences small beside what the noise "
          "alone adds"),
)


def claims_of(experiment: str) -> list[Claim]:
    """The claims of one experiment, in table order."""
    return [c for c in CLAIMS if c.experiment == experiment]


def _check_unique() -> None:
    keys = [c.key for c in CLAIMS]
    if len(set(keys)) != len(keys):  # pragma: no cover - a table edit
        raise RuntimeError(f"claim keys repeat: {sorted(k for k in keys if keys.count(k) > 1)}")


_check_unique()
