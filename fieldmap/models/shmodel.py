"""In-memory spherical-harmonic gravity model."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np


@dataclass(frozen=True)
class SHModel:
    r"""Fully normalised spherical-harmonic coefficients of a gravitational potential.

    The potential is (Chen et al. 2022 eq. 1, fully normalised, no Condon-Shortley phase)

    .. math::
        V = \frac{GM}{r}\sum_{n=0}^{N}\left(\frac{R}{r}\right)^n\sum_{m=0}^{n}
            (\bar C_{nm}\cos m\lambda + \bar S_{nm}\sin m\lambda)\bar P_{nm}(\sin\varphi)

    Attributes
    ----------
    name : str
        Model name (``modelname`` of the ICGEM header).
    gm : float
        Units: m³/s². The model's ``earth_gravity_constant``.
    radius : float
        Units: m. The model's reference ``radius``.
    C, S : numpy.ndarray
        Shape ``(lmax + 1, lmax + 1)``, indexed ``[n, m]``, zero for m > n; fully normalised.
    max_degree : int
        Maximum degree stored in the file (``max_degree`` header key).
    tide_system : str
        ``tide_free``, ``zero_tide``, ``mean_tide`` or ``unknown``.
    epoch : float or None
        Decimal year at which time-variable terms were evaluated (None: static model).
    source : str
        Where the coefficients came from (file path, or ``"synthetic"``).
    header : dict
        The raw header key/value pairs.
    """

    name: str
    gm: float
    radius: float
    C: np.ndarray
    S: np.ndarray
    max_degree: int
    tide_system: str = "unknown"
    epoch: float | None = None
    source: str = ""
    header: dict = field(default_factory=dict)

    @property
    def lmax(self) -> int:
        """Degree of the coefficients held (after any truncation)."""
        return self.C.shape[0] - 1

    def truncated(self, lmax: int) -> "SHModel":
        """Return a copy holding degrees 0..lmax only."""
        from fieldmap.errors import InputError

        lmax = int(lmax)
        if lmax < 0 or lmax > self.lmax:
            raise InputError(f"degree {lmax} is outside the model {self.name} (0..{self.lmax})")
        return replace(
            self,
            C=np.ascontiguousarray(self.C[: lmax + 1, : lmax + 1]),
            S=np.ascontiguousarray(self.S[: lmax + 1, : lmax + 1]),
        )
