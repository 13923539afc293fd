"""Results of the paper reproduced: Table 1 gradient-circuit counts (:mod:`~.table1`) and the
demo (:mod:`~.demo`)."""
