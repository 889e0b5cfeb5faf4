"""The grid world (paper 2.1-2.4, 3.1-3.4): arenas and maps, exploration, the training and
planning loops, the evaluation protocol and its metrics, a Gymnasium environment, and the
grid as a world of the scenarios (world.py)."""
