"""The CML core, the same in every world: the CML and its three synaptic arrays
(:mod:`~cml_edge.core.cml`), the local rule in readable form
(:mod:`~cml_edge.core.learning`) and the compiled step every world's loops call
(:mod:`~cml_edge.core.step`)."""
