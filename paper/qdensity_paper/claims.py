"""The paper's numerical claims, each with its kind, its category, its quantity and the paper's
words.

One table, :data:`CLAIMS`, of every claim that an experiment of this package can answer. Each
:class:`Claim` declares the kind of statement it is, so the verdict rule
(:mod:`qdensity_paper.verdicts`) judges it with the test that fits:

``superiority``
    "A is better than B": the paired difference ``a - b`` over seeds, on the paper's side.
``non-inferiority``
    "A loses little or nothing against B": ``a - b`` above ``-margin`` (one-sided t-test).
``equivalence``
    "A is level with B" (or with a number the paper reports): ``|a - b| < margin`` (TOST).
``trend``
    "the quantity grows (falls) along a grid": the per-seed slope over ``series``.
``monotone``
    "increases monotonically along a grid": every step between neighbouring grid points, each
    a superiority claim (reproduced only when every step is).
``composite``
    a sentence with several parts (``parts``, the keys of claims marked ``part_of`` it):
    reproduced only when every part is, not reproduced when any part is not.
``bound``
    a theorem: ``a - b >= 0`` in every seed (the smallest margin is reported).
``exact``
    a count: ``a == reference`` in every seed.

Each claim also has a category (:data:`CATEGORIES`): ``paper``, an experimental statement of
the paper whose ``quote`` holds verbatim clauses of the paper's sentences (LaTeX markup read
as text); ``extension``, our own (the dropout numerics, a reading of a plot no sentence
states); ``structural``, a property of the construction or a theorem, which a test checks
(the experiment only shows it holds in the run). The headline counts ``paper`` claims only,
and neither parts (judged within their sentence) nor readings reported ``beside`` another.

The margins of the non-inferiority and equivalence claims come from the paper's wording; each
claim gives two (``margins[0]`` decides, ``margins[1]`` is reported beside it) and
``margin_reason`` says why.

``max_seeds`` is the sequential design's largest seed count (:mod:`qdensity_paper._rule`,
:func:`~qdensity_paper._rule.look_levels`): declared per claim before any further seed is run.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

__all__ = ["Claim", "CLAIMS", "KINDS", "CATEGORIES", "claims_of", "counted", "parts_of"]

#: The kinds of claim, each judged by its own test.
KINDS = ("superiority", "non-inferiority", "equivalence", "trend", "monotone", "composite",
         "bound", "exact")

#: What a claim is: the paper's experimental statement, our extension, or a structural check.
CATEGORIES = ("paper", "extension", "structural")

# Accuracy margins: "minimal or no performance loss" / "reaches the accuracy of". 0.05 reads
# "minimal" as under 5 accuracy points; 0.02 reads "no loss" strictly: two standard errors of
# a test accuracy near 0.85 on 1,000 test images (sqrt(0.85 * 0.15 / 1000) = 0.011), the
# smallest difference such a test set resolves.
_ACCURACY = (0.05, 0.02)
_ACCURACY_WHY = ("0.05: 'minimal' loss read as under 5 accuracy points; 0.02: 'no' loss, two "
                 "standard errors of an accuracy near 0.85 on 1,000 test images")

#: The sequential design's largest seed count per experiment (a claim may name its own): the
#: seeds each committed paper-protocol run holds. The sequential stage is closed there: a claim
#: still undecided is decided only by a confirmatory run on fresh seeds alone.
MAX_SEEDS = {"equivariant": 5, "orthoqnn-depth": 8, "pyramid-shots": 5, "reuploading": 17,
             "lcu-vs-single": 5, "mixing-lemma": 5, "moe": 3, "dropout": 6}


@dataclass(frozen=True)
class Claim:
    """One numerical claim.

    Attributes
    ----------
    key : str
        ``"<experiment>/<name>"``, unique; departures name the claims they touch by it.
    text : str
        The claim in a few words.
    line : str
        Where the paper makes it (section, figure, paragraph).
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
        Trend and monotone: grid value and metric name, in grid order.
    caveat : str
        What a reader must know beside the verdict.
    category : str
        One of :data:`CATEGORIES`.
    quote : tuple of str
        Verbatim clauses of the paper (``paper`` claims: at least one).
    parts : tuple of str
        A composite's part keys.
    part_of : str
        The composite this claim is a part of ("" for none).
    beside : str
        The key of the claim this one is a second reading of ("" for none): reported, not
        counted.
    max_seeds : int
        The sequential design's largest seed count (0: the experiment's, :data:`MAX_SEEDS`).
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
    category: str = "paper"
    quote: tuple[str, ...] = ()
    parts: tuple[str, ...] = ()
    part_of: str = ""
    beside: str = ""
    max_seeds: int = 0

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {self.kind!r}")
        if self.category not in CATEGORIES:
            raise ValueError(f"category must be one of {CATEGORIES}, got {self.category!r}")
        if self.sign not in (1, -1):
            raise ValueError(f"sign must be +1 or -1, got {self.sign!r}")
        if self.kind in ("non-inferiority", "equivalence") and (
                len(self.margins) != 2 or min(self.margins) <= 0):
            raise ValueError(f"claim {self.key!r}: a {self.kind} claim needs two positive "
                             f"margins, got {self.margins!r}")
        if self.kind in ("trend", "monotone") and len(self.series) < 2:
            raise ValueError(f"claim {self.key!r}: a {self.kind} needs >= 2 grid points")
        if self.kind == "exact" and self.reference is None:
            raise ValueError(f"claim {self.key!r}: an exact claim needs a reference")
        if (self.kind == "composite") != bool(self.parts):
            raise ValueError(f"claim {self.key!r}: a composite claim, and only one, has parts")

    @property
    def experiment(self) -> str:
        return self.key.split("/", 1)[0]

    @property
    def n_max(self) -> int:
        """The sequential design's largest seed count."""
        return self.max_seeds or MAX_SEEDS.get(self.experiment, 0)

    @property
    def metrics(self) -> list[str]:
        if self.kind in ("trend", "monotone"):
            return [m for _, m in self.series]
        return [m for m in (self.a, self.b) if m]

    @property
    def quoted(self) -> str:
        """Where, and the paper's words (``'...'`` between clauses)."""
        words = " ... ".join(self.quote)
        return f"{self.line}: '{words}'" if words else self.line

    @property
    def quantity(self) -> str:
        if self.kind == "composite":
            return "every part: " + ", ".join(p.split("/", 1)[1] for p in self.parts)
        if self.kind == "monotone":
            name = self.series[0][1].split("/")[-1]
            return f"each step of {name} over " + ", ".join(f"{x:g}" for x, _ in self.series)
        if self.kind == "trend":
            return f"slope of {self.series[0][1].split('/')[-1]} over " + ", ".join(
                f"{x:g}" for x, _ in self.series)
        if self.b:
            return f"{self.a} - {self.b}"
        return self.a if self.reference is None else f"{self.a} - {self.reference:g}"


# The paper's words, by place (LaTeX read as text: $L$ -> L, \frac{30}{32} -> 30/32).
_FIG5 = ("Fig. 5 caption", ("In all cases, after base model performance saturation, the "
                            "density QNN improves the final result.",))
_TAKEAWAY = ("Results, takeaways (Hamming-weight preserving QNNs)",
             ("Non-backpropagation scaling models can be made trainable with minimal or no "
              "performance loss.",))
_FIG7 = ("Fig. 7 caption", ("Performance of density QNN increases monotonically with "
                            "sub-unitary depth, D.",))
_FIG7_CIRC = ("Fig. 7 caption", ("requires only n-1 circuit evaluations for each iteration "
                                 "whereas the OrthoQNN requires 4n(n-1)/2 circuits",))
_COUNTS = "Supp., hyperparameters (Fig. 11)"
_COUNTS_RULE = "those which achieve at least 80% accuracy during training"
_FIG6_TEXT = ("Main text, 'Mitigating overfitting with density QNNs' (Fig. 6b)", (
    "We see as the vanilla reuploading model becomes more expressive (with increasing L), it "
    "overfits and test error grows.", "In contrast, the density model (with approximately the "
    "same number of parameters) does not overfit and the test error remains small."))
_FIG6_CAPTION = ("Fig. 6b caption (T_2)", (
    "For a fixed number of parameters, the test error and train/test gap (generalisation "
    "error) for the vanilla data reuploading model diverges, while the density QNN test error "
    "remains small.",))
_FIG17 = ("Supp. J, Fig. 17 caption", (
    "For a fixed parameter budget, the density QNN is less prone to overfitting to training "
    "data than the vanilla counterpart, and generalisation improves (test MSE decreases) as the "
    "number of sub-unitaries increases.",))
_T3 = ("Supp. J, T_3 and T_4 (Fig. 18)", (
    "Again the density model is able to fit the test data well and again each combats "
    "overfitting by reallocating parameters from an overparameterised vanilla reuploading "
    "model.",))
_MOE = "Supp. H.2, observations"
_L = (5, 10, 20, 30, 40, 50)


def _paper(key, text, where, kind, *args, **kw) -> Claim:
    line, quote = where
    return Claim(key, text, line, kind, *args, quote=tuple(quote), **kw)


def _composite(key, text, where, parts: list[Claim], category="paper", caveat="") -> list[Claim]:
    line, quote = where
    whole = Claim(key, text, line, "composite", category=category, quote=tuple(quote),
                  parts=tuple(p.key for p in parts), caveat=caveat)
    return [whole, *(replace(p, part_of=key, category=category) for p in parts)]


def _equivariant() -> list[Claim]:
    names = {"xx": "XX+YY", "noncommuting": "non-commuting", "qcnn": "QCNN"}
    parts = [Claim(f"equivariant/{f}", f"the {n} density model ends above its base model",
                   _FIG5[0], "superiority", f"{f}/density_test_accuracy",
                   f"{f}/base_test_accuracy",
                   caveat=("the gains are 1-3 test points of 100" if f == "qcnn" else ""))
             for f, n in names.items()]
    return _composite("equivariant/all-cases", "in all three families the density model ends "
                      "above its base model", _FIG5, parts)


def _orthoqnn() -> list[Claim]:
    return [
        _paper("orthoqnn-depth/shallow", "the shallow (D = 1) density OrthoQNN loses little or "
               "nothing against the pure round-robin OrthoQNN", _TAKEAWAY, "non-inferiority",
               "D1/test_accuracy", "pure/test_accuracy", margins=_ACCURACY,
               margin_reason=_ACCURACY_WHY),
        _paper("orthoqnn-depth/depth-trend", "test accuracy rises with sub-unitary depth D at "
               "every step", _FIG7, "monotone",
               series=tuple((d, f"D{d}/test_accuracy") for d in (1, 2, 3, 4, 9))),
        _paper("orthoqnn-depth/circuits-pure", "the OrthoQNN's parameter-shift gradient takes "
               "4n(n-1)/2 = 180 circuits per row", _FIG7_CIRC, "exact",
               "pure/circuits/parameter_gradients", reference=180.0, category="structural"),
        _paper("orthoqnn-depth/circuits-shallow", "the D = 1 density model's gradient takes "
               "n - 1 = 9 circuits per row", _FIG7_CIRC, "exact",
               "D1/circuits/parameter_gradients", reference=9.0, category="structural"),
    ]


def _pyramid() -> list[Claim]:
    out = []
    for m, label in (("odd_even", "odd-even"), ("compressed", "compressed")):
        key = f"pyramid-shots/{label}"
        out.append(_paper(key, f"the {label} density model loses little or nothing against "
                          "the pure pyramid (the mean over the runs above 80%, as Fig. 11b "
                          "plots)", _TAKEAWAY, "non-inferiority", f"{m}/runs_above_mean",
                          "pure/runs_above_mean", margins=_ACCURACY,
                          margin_reason=_ACCURACY_WHY))
        out.append(_paper(f"{key}-best-trial", f"the {label} density model loses little or "
                          "nothing against the pure pyramid (the trial each study selects)",
                          _TAKEAWAY, "non-inferiority", f"{m}/test_accuracy",
                          "pure/test_accuracy", margins=_ACCURACY,
                          margin_reason=_ACCURACY_WHY, beside=key))
    out.append(Claim("pyramid-shots/budget", "at the odd-even model's whole training budget of "
                     "shots it is ahead of the pure model (both the mean over the runs above "
                     "80%)", "Fig. 11b, our reading of the plot (no sentence of the paper "
                     "states it)", "superiority", "odd_even/runs_above_mean",
                     "pure/test_accuracy_at_density_budget", category="extension"))
    for m, label, paper in (("pure", "OrthoQNN", 30), ("odd_even", "Density OrthoQNN", 28),
                            ("compressed", "Density OrthoQNN (compressed)", 30)):
        out.append(Claim(f"pyramid-shots/count-{m.replace('_', '-')}", f"{paper}/32 of the "
                         f"{m.replace('_', '-')} runs reach 80%", _COUNTS, "equivalence",
                         f"{m}/runs_above", reference=float(paper), margins=(3.0, 1.5),
                         margin_reason="3 runs of 32 (about 10%, the spread between the paper's "
                                       "three models); 1.5: half that",
                         quote=(_COUNTS_RULE, f"{label}: {paper}/32")))
    return out


def _overfitting(s: str, where, label: str) -> list[Claim]:
    tag = s.replace("_", "-")
    series = {q: tuple((L, f"{s}/vanilla/L{L}/{q}") for L in _L) for q in ("test_mse", "gap")}
    parts = [
        Claim(f"reuploading/{tag}-vanilla-trend", f"{label}: the vanilla model's test MSE grows "
              "with L", where[0], "trend", series=series["test_mse"]),
        Claim(f"reuploading/{tag}-vanilla-gap-trend", f"{label}: the vanilla model's "
              "generalisation gap grows with L", where[0], "trend", series=series["gap"]),
        Claim(f"reuploading/{tag}-gap", f"{label}: at L = 50 the density model's generalisation "
              "gap is below the vanilla model's", where[0], "superiority",
              f"{s}/vanilla/L50/gap", f"{s}/density/L50/gap"),
        Claim(f"reuploading/{tag}-test", f"{label}: at L = 50 the density model's test MSE is "
              "below the vanilla model's", where[0], "superiority",
              f"{s}/vanilla/L50/test_mse", f"{s}/density/L50/test_mse"),
    ]
    return _composite(f"reuploading/{tag}", f"{label}: the vanilla model overfits more and its "
                      "test error grows with L; the density model's gap and test error stay "
                      "below it", where, parts)


def _reuploading() -> list[Claim]:
    out = _overfitting("methods", _FIG6_TEXT, "Methods (T_4)")
    out += _overfitting("supp_j", _FIG6_CAPTION, "Supp. J (T_2)")
    experts = [Claim(f"reuploading/supp-j-K{k}-gap", f"Supp. J (T_2): at L = 50 the K = {k} "
                     "density model's gap is below the vanilla model's", _FIG17[0],
                     "superiority", "supp_j/vanilla/L50/gap", f"supp_j/density_K{k}/L50/gap")
               for k in (2, 7)]
    experts.append(Claim("reuploading/supp-j-experts-trend", "Supp. J (T_2): at L = 50 the "
                         "density model's test MSE falls as K grows (2, 5, 7)", _FIG17[0],
                         "trend", sign=-1, series=((2, "supp_j/density_K2/L50/test_mse"),
                                                   (5, "supp_j/density/L50/test_mse"),
                                                   (7, "supp_j/density_K7/L50/test_mse"))))
    out += _composite("reuploading/supp-j-experts", "Supp. J (T_2): the K = 2 and K = 7 "
                      "density models overfit less than the vanilla model, and test MSE falls "
                      "as K grows", _FIG17, experts)
    t3 = [Claim("reuploading/t3-test", "Supp. J (T_3): at L = 50 the density model's test MSE "
                "is below the vanilla model's", _T3[0], "superiority", "t3/vanilla/L50/test_mse",
                "t3/density/L50/test_mse", max_seeds=14),
          Claim("reuploading/t3-gap", "Supp. J (T_3): at L = 50 the density model's gap is "
                "below the vanilla model's", _T3[0], "superiority", "t3/vanilla/L50/gap",
                "t3/density/L50/gap", max_seeds=14)]
    whole, *parts = _composite("reuploading/t3", "Supp. J (T_3): the density model fits the "
                               "test data better than the vanilla model and overfits less",
                               _T3, t3)
    t4 = [Claim(f"reuploading/t4-{q}", f"Supp. J (T_4): at L = 50 the density model's {what} "
                "is below the vanilla model's", _T3[0], "superiority", f"t4/vanilla/L50/{q}",
                f"t4/density/L50/{q}", max_seeds=6)
          for q, what in (("test", "test MSE"), ("gap", "gap"))]
    t4 = [replace(c, a=c.a.replace("/test", "/test_mse"), b=(c.b or "").replace(
        "/test", "/test_mse")) if c.key.endswith("-test") else c for c in t4]
    whole4, *parts4 = _composite("reuploading/t4", "Supp. J (T_4): the density model fits the "
                                 "test data better than the vanilla model and overfits less",
                                 _T3, t4)
    return [*out, replace(whole, max_seeds=14), *parts, replace(whole4, max_seeds=6), *parts4]


def _moe() -> list[Claim]:
    gate = [Claim("moe/odd-even-gate-helps", "the MoE gate raises the odd-even density model's "
                  "mean accuracy over the sweep", _MOE, "superiority",
                  "odd_even/moe/mean_accuracy", "odd_even/density/mean_accuracy"),
            Claim("moe/odd-even-gate-level", "with the MoE gate the odd-even density model "
                  "reaches the pure pyramid's mean accuracy", _MOE, "non-inferiority",
                  "odd_even/moe/mean_accuracy", "pyramid/pure/mean_accuracy",
                  margins=_ACCURACY, margin_reason=_ACCURACY_WHY)]
    out = _composite("moe/odd-even-gate", "the MoE gate helps the odd-even density model and "
                     "lifts it to the pure pyramid's level", (_MOE, (
                         "for models with larger parameter counts per sub-unitary, e.g. the "
                         "uncompressed odd-even decomposition, the data-dependent attention "
                         "does appear to help", "and can boost performance to the level of the "
                         "original model")), gate)
    out.append(_paper("moe/butterfly-density-best", "the butterfly density model's best "
                      "accuracy is above the pure butterfly's", (_MOE, (
                          "the vanilla density model can outperform it's pure version, e.g. "
                          "comparing best accuracy achieved by the density QNN-butterfly versus "
                          "the OrthoQNN-butterfly",)), "superiority",
                      "butterfly/density/best_accuracy", "butterfly/pure/best_accuracy"))
    spread = [Claim(f"moe/spread-{d.replace('_', '-')}", f"the MoE gate narrows the spread "
                    f"over hyperparameters ({d.replace('_', '-')}, std over trials)", _MOE,
                    "superiority", f"{d}/moe/std_accuracy", f"{d}/density/std_accuracy",
                    sign=-1) for d in ("butterfly", "odd_even", "compressed")]
    out += _composite("moe/spread", "the MoE gate narrows the spread over hyperparameters in "
                      "all three decompositions", (_MOE, (
                          "making alpha(x) data dependent (including a MoE), and predictable by "
                          "a neural network, reduces the variance of the training over "
                          "hyperparameter runs, which can be observed in all scenarios",)),
                      spread)
    return out


_DROPOUT = ("Quantum dropout (the two phases proposed; the paper's overfitting numerics train "
            "exactly, so these runs are our extension)")

#: Every claim, in the order of the paper's experiments.
CLAIMS: tuple[Claim, ...] = (
    *_equivariant(), *_orthoqnn(), *_pyramid(), *_reuploading(),
    _paper("lcu-vs-single/lcu-beats-single", "the LCU QNN beats the single-circuit QNN",
           ("Supp. C", ("We see that the final LCU QNN can outperform any single circuit QNN in "
                        "terms of MNIST test accuracy.",)), "superiority", "lcu/minus_single"),
    Claim("mixing-lemma/hastings-campbell", "the channel distance stays below eps_1^2 + 2 eps_2 "
          "in every seed", "Supp. B.2, Hastings-Campbell mixing lemma (eq. mixing_lemma_result), "
          "a theorem", "bound", "lemma/bound", "lemma/distance_max", category="structural"),
    Claim("mixing-lemma/lemma-1", "the density model's prediction error stays below "
          "delta_1^2 / (4 ||O||) + 2 delta_2 in every seed", "Lemma 1 (eq. "
          "supervised_mixing_corollary), a theorem", "bound", "lemma1/lemma1_bound",
          "lemma1/density_error", category="structural"),
    *_moe(),
    Claim("dropout/mitigates", "trained by the randomised preparation and predicting with the "
          "deterministic one, the density model overfits less than the vanilla model "
          "(generalisation gap)", _DROPOUT, "superiority", "vanilla/gap", "dropout/gap",
          category="extension"),
    Claim("dropout/level-with-exact", "dropout training loses little or nothing in test MSE "
          "against exact training of the same density model", _DROPOUT, "non-inferiority",
          "dropout/test_mse", "exact/test_mse", sign=-1, margins=(0.01, 0.005),
          margin_reason="a quarter and an eighth of the variance of Supp. J's label noise "
          "(0.04): test-MSE differences small beside what the noise alone adds",
          category="extension"),
)


def claims_of(experiment: str) -> list[Claim]:
    """The claims of one experiment, in table order."""
    return [c for c in CLAIMS if c.experiment == experiment]


def counted(claim: Claim) -> bool:
    """Whether the headline counts ``claim``: a ``paper`` claim, not a part, not a second
    reading."""
    return claim.category == "paper" and not claim.part_of and not claim.beside


def parts_of(claim: Claim) -> list[Claim]:
    """A composite's part claims, in order."""
    by_key = {c.key: c for c in CLAIMS}
    return [by_key[k] for k in claim.parts]


def _check_unique() -> None:
    keys = [c.key for c in CLAIMS]
    if len(set(keys)) != len(keys):  # pragma: no cover - a table edit
        raise RuntimeError(f"claim keys repeat: {sorted(k for k in keys if keys.count(k) > 1)}")
    missing = [p for c in CLAIMS for p in c.parts if p not in keys]
    if missing:  # pragma: no cover - a table edit
        raise RuntimeError(f"composite parts not in the table: {missing}")


_check_unique()
