"""Simulation: trajectories, wind, the scenario files of the papers, the sensor data of
one Monte Carlo run and the simulated datasets of ``fednav simulate``."""
