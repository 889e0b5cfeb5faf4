"""Input and output: path checks and atomic writes (:mod:`~cml_edge.io.files`), figures
(:mod:`~cml_edge.io.figures`)."""
