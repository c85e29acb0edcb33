"""Latitude-longitude grids: grid specifications, row-wise synthesis, longitude sums (FFT)."""
