"""Simulation of the digital twins: the C++ stepping loop and the experiments run on it."""
