"""The field at points: ellipsoids, normal gravity, SH synthesis, gravity, frames."""
