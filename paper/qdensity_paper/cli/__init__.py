"""The paper's sub-commands of ``qdensity``: ``experiment`` (:mod:`~.experiment`) and
``results`` (:mod:`~.results`), added through the ``qdensity.commands`` entry points
(:mod:`qdensity.cli.plugins`)."""
