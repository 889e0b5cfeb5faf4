"""The drone: a holonomic point mass in a walled volume (:mod:`cml_edge.drone.sim`), driven
by the robot's CML loops."""
