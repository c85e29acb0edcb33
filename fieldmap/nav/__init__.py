"""Strapdown navigation: launch frames, trajectories, IMU synthesis/errors, mechanizations."""
