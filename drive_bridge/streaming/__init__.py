"""Trajectories on SYNC: the trajectory model and sampling (cyclic setpoints), later IP and PVT."""
