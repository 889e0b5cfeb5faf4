"""IBM aihwkit 1.1.0 beside the crossbar: its tiles measured like the project's devices
(:mod:`.compare`, ``cml-edge device characterize --against aihwkit``), its preset devices
as crossbar presets (:mod:`.presets`, ``--preset aihwkit:NAME``), run in aihwkit's own
environment (:mod:`.runner` starts :mod:`.worker` there; built by
``bash scripts/aihwkit_env.sh``)."""
