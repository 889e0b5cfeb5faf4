"""The devices of the kit's tutorial (docs/your-device.md), shipped as plugins:
``cml-edge --plugin cml_edge.kit.examples.ternary ...``. Each file is the tutorial's code
block of the same name, verbatim (a test holds them equal)."""
