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
    nominal_degree : int
        Degree the model file declares (its ``max_degree`` header key), kept through
        truncation. The degree held is :attr:`lmax` (also :attr:`max_degree`).
    tide_system : str
        ``tide_free``, ``zero_tide``, ``mean_tide`` or ``unknown``.
    epoch : float or None
        Decimal year at which time-variable terms were evaluated (None: static model).
    source : str
        Where the coefficients came from (file path, or ``"synthetic"``).
    header : dict
        The raw header key/value pairs.
    sigma_c, sigma_s : numpy.ndarray or None
        Calibrated standard deviations of C and S, same shape and indexing (None: the file gives
        none). For time-variable models, σ of the static (``gfct``) part only.
    """

    name: str
    gm: float
    radius: float
    C: np.ndarray
    S: np.ndarray
    nominal_degree: int
    tide_system: str = "unknown"
    epoch: float | None = None
    source: str = ""
    header: dict = field(default_factory=dict)
    sigma_c: np.ndarray | None = None
    sigma_s: np.ndarray | None = None

    def __post_init__(self) -> None:
        for sig in (self.sigma_c, self.sigma_s):
            if sig is not None and np.shape(sig) != np.shape(self.C):
                raise ValueError("sigma_c and sigma_s must have the shape of C")
        if (self.sigma_c is None) != (self.sigma_s is None):
            raise ValueError("give both sigma_c and sigma_s, or neither")

    @property
    def has_sigma(self) -> bool:
        """True when the model carries coefficient standard deviations."""
        return self.sigma_c is not None

    @property
    def lmax(self) -> int:
        """Degree of the coefficients held (after any truncation)."""
        return self.C.shape[0] - 1

    @property
    def max_degree(self) -> int:
        """Maximum degree of the coefficients held: :attr:`lmax` (after any truncation).

        The degree of the model file is :attr:`nominal_degree`.
        """
        return self.lmax

    def __repr__(self) -> str:
        """One line: name, degree held (and the file's, when truncated), GM, a, tide, epoch."""
        degree = f"{self.lmax}"
        if self.nominal_degree != self.lmax:
            degree += f" (of {self.nominal_degree})"
        epoch = "static" if self.epoch is None else f"{self.epoch:.4f}"
        tide = "" if self.tide_system == "unknown" else f", tide_system={self.tide_system}"
        return (
            f"SHModel({self.name!r}, degree={degree}, GM={self.gm:.12g} m3/s2, "
            f"a={self.radius:.12g} m{tide}, epoch={epoch})"
        )

    def truncated(self, lmax: int) -> "SHModel":
        """Return a copy holding degrees 0..lmax only.

        The copy's :attr:`lmax` and :attr:`max_degree` are ``lmax``; its
        :attr:`nominal_degree` stays the file's.

        Parameters
        ----------
        lmax : int
            Highest degree kept, within 0..``self.lmax``.

        Returns
        -------
        SHModel
            A copy with C, S (and sigma_c, sigma_s) cut to degrees 0..lmax.

        Raises
        ------
        fieldmap.errors.InputError
            ``lmax`` outside 0..``self.lmax``.

        Examples
        --------
        >>> from fieldmap.models.registry import load_model
        >>> low = load_model("eigen-6s").truncated(12)
        >>> low.lmax, low.max_degree, low.nominal_degree, low.C.shape
        (12, 12, 240, (13, 13))
        """
        from fieldmap.errors import InputError

        lmax = int(lmax)
        if lmax < 0 or lmax > self.lmax:
            raise InputError(f"degree {lmax} is outside the model {self.name} (0..{self.lmax})")
        return replace(self, **_sliced(self, lmax))


def _sliced(model: SHModel, lmax: int) -> dict:
    """C, S and (when present) sigma_c, sigma_s cut to degrees 0..lmax, for ``replace``."""
    out = {}
    for key in ("C", "S", "sigma_c", "sigma_s"):
        a = getattr(model, key)
        out[key] = None if a is None else np.ascontiguousarray(a[: lmax + 1, : lmax + 1])
    return out
