"""The continuous wheeled robot (paper 2.5, 3.5): simulators, observations, the training and
planning loops, model files and a Gymnasium environment."""
