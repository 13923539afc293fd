"""Results of the paper reproduced.

* :func:`run` (:mod:`~.registry`): the paper's experiments by name (``equivariant``,
  ``orthoqnn-depth``, ``pyramid-shots``, ``moe``, ``reuploading``, ``lcu-vs-single``,
  ``mixing-lemma``, ``noise``), each over seeds with 95% confidence intervals, a results JSON
  and figures (``qdensity experiment NAME``);
* :mod:`~.results`: the results file and the statistics over seeds;
* :mod:`~.table1`: Table 1's gradient-circuit counts from real plans;
* :mod:`~.demo`: ``qdensity demo``.
"""

from qdensity_paper.registry import EXPERIMENTS, Experiment, get_experiment, run

__all__ = ["run", "EXPERIMENTS", "Experiment", "get_experiment"]
