"""``cml-edge bench``: the timing of the compiled loops (:mod:`~cml_edge.bench.timing`)
against a hand-fused yardstick (:mod:`~cml_edge.bench.fused`)."""
