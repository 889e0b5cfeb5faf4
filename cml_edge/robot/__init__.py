"""The continuous wheeled robot (paper 2.5, 3.5): simulators, observations, the training and
planning loops, model files, a Gymnasium environment, and the robot as a world of the
scenarios (world.py)."""
