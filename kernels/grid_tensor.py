r"""Warp kernels: the gravity gradient tensor by grid synthesis, one Legendre pass per row.

On a circle of latitude (geocentric latitude φ, t = sin φ, u = cos φ, radius r, q = R/r) the
second derivatives of the potential

.. math::
    V = \frac{GM}{r}\sum_{n,m} q^n \bar P_{nm}(t)\,(\bar C_{nm}\cos m\lambda
        + \bar S_{nm}\sin m\lambda)

in the local geocentric east-north-up frame (e: λ, n: φ, u: r) are (Reed 1973, *Application
of kinematical geodesy for determining the short wave length components of the gravity field
by satellite gradiometry*, OSU report 201, eqs. 3.32-3.37; Petrovskaya & Vershkov 2006,
J. Geodesy 80:117-127, eqs. 5-10)

.. math::
    V_{uu} &= V_{rr}, \qquad
    V_{nu} = \tfrac{1}{r} V_{r\varphi} - \tfrac{1}{r^2} V_\varphi, \qquad
    V_{eu} = \tfrac{1}{r u}\big(V_{r\lambda} - \tfrac{1}{r} V_\lambda\big), \\
    V_{nn} &= \tfrac{1}{r^2} V_{\varphi\varphi} + \tfrac{1}{r} V_r, \qquad
    V_{ee} = \tfrac{1}{r^2u^2} V_{\lambda\lambda} + \tfrac{1}{r} V_r
             - \tfrac{t}{r^2 u} V_\varphi, \qquad
    V_{en} = \tfrac{1}{r^2 u}\big(V_{\varphi\lambda} + \tfrac{t}{u} V_\lambda\big).

Per order m these are Fourier coefficients of cos mλ and sin mλ (the factors m and m² of the
longitude derivatives go into the coefficients; the host sums the longitudes by FFT as for the
vector). The second latitude derivative comes from Legendre's equation,
:math:`\bar P'' = (t/u)\bar P' - n(n+1)\bar P + (m^2/u^2)\bar P`. With the Holmes &
Featherstone (2002) split :math:`\bar P_{nm} = u^m Q_{nm}` and their
:math:`\bar P'_{nm} = u^{m-1} D_{nm}`, :math:`D_{nm} = -n t Q_{nm} + f_{nm} Q_{n-1,m}` (their eqs.
11-16), the terms with 1/u and 1/u² are

.. math::
    H_{nm} \equiv \frac{t}{u}\bar P' + \frac{m^2}{u^2}\bar P = u^{m-2}(t D + m^2 Q), \qquad
    G_{nm} \equiv \frac{1}{u}\Big(\bar P' + \frac{t}{u}\bar P\Big) = u^{m-2}(D + t Q),

finite for m ≥ 2. For m = 1, :math:`D + tQ = u^2\, dQ/dt` (from
:math:`\bar P' = u^{m-1}(-m t Q + u^2 dQ/dt)`), so :math:`G = u\, dQ/dt` and
:math:`H = u(Q + t\, dQ/dt)`, with dQ/dt from the derivative of the column recursion
(:math:`Q'_n = a_n(Q_{n-1} + t Q'_{n-1}) - b_n Q'_{n-2}`): both vanish at the poles, exactly.
For m = 0, :math:`\bar P'_{n0} = \sqrt{n(n+1)/2}\, u Q_{n1}` and :math:`H = t \sqrt{n(n+1)/2}\,
Q_{n1}` (from the order-1 column). Then, with :math:`K = GM/r^3`,

.. math::
    V_{uu} = K\sum (n+1)(n+2) q^n \bar P, \quad
    V_{nu} = -K\sum (n+2) q^n \bar P', \quad
    V_{eu} = -K\sum (n+2) q^n \tfrac{1}{u}\partial_\lambda \bar P\cdots, \\
    V_{nn} = K\sum q^n\,[H - (n+1)^2 \bar P], \quad
    V_{ee} = K\sum q^n\,[-H - (n+1)\bar P], \quad
    V_{en} = K\sum q^n\, G\,\partial_\lambda(\cdots)

(their trace is zero term by term: Laplace). The powers of u are applied in halves and the
1e-280 scale last (:func:`fieldmap.kernels.grid.scaled_times`), as for the vector; a rotation
by δ = φ_geodetic − φ_geocentric about east turns the tensor into the geodetic ENU frame.

One thread per (row unit, order m); a unit is a row and its mirror at −latitude (same height),
which share the recursion: the sums are split by the parity of n − m, and at −t the sums of Q
are even − odd, those of the f Q_{n−1} and dQ/dt terms odd − even (exact sign flips, so a row
gets the same bits with or without its mirror). Degrees up to 2700 (the scaled recursion).
"""

import warp as wp

from .grid import half_powers_tab, scaled_times, zero_tail
from .sh import SCALE, SHKernelModel, sh_degree_cut

wp.set_module_options({"enable_backward": False})

#: per-parity column sums, for X = C (even index) and S (odd index):
#: [0,1] X Q, [2,3] (n+1) X Q, [4,5] (n+1)(n+2) X Q, [6,7] X f Q_{n-1} (q-folded),
#: [8,9] (n+2) X f Q_{n-1}, [10,11] X dQ/dt (m = 1), [12] c_n C_n0 Q_n1, [13] (n+2) of it (m = 1)
tensor_sums = wp.types.vector(length=14, dtype=wp.float64)
#: the six components ee, en, eu, nn, nu, uu of a symmetric tensor
vec6d = wp.types.vector(length=6, dtype=wp.float64)


@wp.func
def _term(
    model: SHKernelModel,
    m: int,
    n: int,
    pn: wp.float64,
    p1: wp.float64,
    rn: wp.float64,
) -> tensor_sums:
    """Return the terms of degree n of :data:`tensor_sums` (pn = q^n Q_n, p1 = q^(n-1) Q_(n-1))."""
    c = model.cnm[m, n]
    s = model.snm[m, n]
    a1 = wp.float64(n + 1)
    a2 = a1 * wp.float64(n + 2)
    b = wp.float64(n + 2)
    wc = c * pn
    ws = s * pn
    out = tensor_sums()
    out[0] = wc
    out[1] = ws
    out[2] = a1 * wc
    out[3] = a1 * ws
    out[4] = a2 * wc
    out[5] = a2 * ws
    if m >= 1:
        fp = model.fnm[m, n] * p1
        out[6] = c * fp
        out[7] = s * fp
        out[8] = b * c * fp
        out[9] = b * s * fp
    if m == 1:
        out[10] = c * rn
        out[11] = s * rn
        z = model.fnm[0, n] * model.cnm[0, n] * pn
        out[12] = z
        out[13] = b * z
    return out


@wp.func
def tensor_column(model: SHKernelModel, m: int, t: wp.float64, q: wp.float64):
    """Column sums of order m at t, split by the parity of n − m: (even, odd).

    See :data:`tensor_sums`; the recursion is that of :func:`fieldmap.kernels.sh.sh_column`
    (Holmes & Featherstone 2002 eqs. 11-13, q^n folded in), and for m = 1 its derivative in t.
    """
    ev = tensor_sums()
    od = tensor_sums()
    lmax = sh_degree_cut(model, q)
    if m > lmax:
        return ev, od
    tq = t * q
    qq = q * q
    p1 = SCALE * model.sect[m] * wp.pow(q, wp.float64(m))
    p2 = wp.float64(0.0)
    r1 = wp.float64(0.0)  # dQ'/dt: the seed does not depend on t
    r2 = wp.float64(0.0)
    ev = _term(model, m, m, p1, p2, r1)
    n = m + 1
    while n <= lmax:
        a = model.anm[m, n]
        bq = model.bnm[m, n] * qq
        pn = a * tq * p1 - bq * p2
        rn = wp.float64(0.0)
        if m == 1:
            rn = a * (q * p1 + tq * r1) - bq * r2
        od = od + _term(model, m, n, pn, p1, rn)
        p2 = p1
        p1 = pn
        r2 = r1
        r1 = rn
        n = n + 1
        if n <= lmax:
            a = model.anm[m, n]
            bq = model.bnm[m, n] * qq
            pn = a * tq * p1 - bq * p2
            rn = wp.float64(0.0)
            if m == 1:
                rn = a * (q * p1 + tq * r1) - bq * r2
            ev = ev + _term(model, m, n, pn, p1, rn)
            p2 = p1
            p1 = pn
            r2 = r1
            r1 = rn
            n = n + 1
    return ev, od


#: packed table entry of degree n of order m (:func:`fieldmap.grids.tables.tensor_tables`):
#: a_nm, b_nm, C, S, (n+1) C, (n+1) S, (n+1)(n+2) C, (n+1)(n+2) S, f_{n+1} C_{n+1},
#: f_{n+1} S_{n+1}, (n+3) f_{n+1} C_{n+1}, (n+3) f_{n+1} S_{n+1}
vec12d = wp.types.vector(length=12, dtype=wp.float64)


@wp.func
def tensor_column_packed(
    rec: wp.array(dtype=vec12d),
    s0: int,
    nterm: int,
    seed: wp.float64,
    tq: wp.float64,
    qq: wp.float64,
):
    """:func:`tensor_column` for m >= 2 on the packed table ``rec[s0 + j]`` (degree m + j).

    The products with (n+1), (n+1)(n+2), f_{n+1} and (n+3) are formed once on the host, and
    the sums of f_n X_n Q_{n-1} are taken at Q_{n-1} (one degree down: every product of a step
    multiplies the same Q_n), so they land in the other parity's sums; they are moved back to
    the parity of their degree n here. Same layout as :func:`tensor_column` (entries 10-13
    zero: m >= 2).
    """
    z = wp.float64(0.0)
    w = rec[s0]
    p1 = seed
    p2 = z
    e0 = w[2] * p1
    e1 = w[3] * p1
    e2 = w[4] * p1
    e3 = w[5] * p1
    e4 = w[6] * p1
    e5 = w[7] * p1
    e6 = w[8] * p1
    e7 = w[9] * p1
    e8 = w[10] * p1
    e9 = w[11] * p1
    o0 = z
    o1 = z
    o2 = z
    o3 = z
    o4 = z
    o5 = z
    o6 = z
    o7 = z
    o8 = z
    o9 = z
    j = s0 + 1
    jend = s0 + nterm
    while j < jend:
        w = rec[j]
        pn = w[0] * tq * p1 - w[1] * qq * p2
        o0 = o0 + w[2] * pn
        o1 = o1 + w[3] * pn
        o2 = o2 + w[4] * pn
        o3 = o3 + w[5] * pn
        o4 = o4 + w[6] * pn
        o5 = o5 + w[7] * pn
        o6 = o6 + w[8] * pn
        o7 = o7 + w[9] * pn
        o8 = o8 + w[10] * pn
        o9 = o9 + w[11] * pn
        p2 = p1
        p1 = pn
        j = j + 1
        if j >= jend:
            break
        w = rec[j]
        pn = w[0] * tq * p1 - w[1] * qq * p2
        e0 = e0 + w[2] * pn
        e1 = e1 + w[3] * pn
        e2 = e2 + w[4] * pn
        e3 = e3 + w[5] * pn
        e4 = e4 + w[6] * pn
        e5 = e5 + w[7] * pn
        e6 = e6 + w[8] * pn
        e7 = e7 + w[9] * pn
        e8 = e8 + w[10] * pn
        e9 = e9 + w[11] * pn
        p2 = p1
        p1 = pn
        j = j + 1
    ev = tensor_sums(e0, e1, e2, e3, e4, e5, o6, o7, o8, o9, z, z, z, z)
    od = tensor_sums(o0, o1, o2, o3, o4, o5, e6, e7, e8, e9, z, z, z, z)
    return ev, od


@wp.func
def mirror_sums(ev: tensor_sums, od: tensor_sums) -> tensor_sums:
    """Return the sums at −t: even − odd for Q terms, odd − even for f Q_{n−1} and dQ/dt."""
    out = ev - od
    for k in range(6, 12):
        out[k] = od[k] - ev[k]
    return out


@wp.func
def _store_rotated(
    coef: wp.array3d(dtype=wp.vec2d),
    row: int,
    m: int,
    a: vec6d,
    b: vec6d,
    cd: wp.float64,
    sd: wp.float64,
):
    """Rotate the cos (``a``) and sin (``b``) parts by δ about east and store them as (A, −B).

    ``a``, ``b`` hold the geocentric ee, en, eu, nn, nu, uu; T' = R T Rᵀ with
    north' = cd n − sd u, up' = sd n + cd u (as the vector's rotation): geodetic ENU.
    """
    cc = cd * cd
    ss = sd * sd
    cs = cd * sd
    two = wp.float64(2.0)
    coef[row, 0, m] = wp.vec2d(a[0], -b[0])
    coef[row, 1, m] = wp.vec2d(cd * a[1] - sd * a[2], -(cd * b[1] - sd * b[2]))
    coef[row, 2, m] = wp.vec2d(sd * a[1] + cd * a[2], -(sd * b[1] + cd * b[2]))
    coef[row, 3, m] = wp.vec2d(
        cc * a[3] - two * cs * a[4] + ss * a[5], -(cc * b[3] - two * cs * b[4] + ss * b[5])
    )
    coef[row, 4, m] = wp.vec2d(
        cs * (a[3] - a[5]) + (cc - ss) * a[4], -(cs * (b[3] - b[5]) + (cc - ss) * b[4])
    )
    coef[row, 5, m] = wp.vec2d(
        ss * a[3] + two * cs * a[4] + cc * a[5], -(ss * b[3] + two * cs * b[4] + cc * b[5])
    )


@wp.func
def _order_parts(
    sm: tensor_sums,
    x: int,
    m: int,
    t: wp.float64,
    q: wp.float64,
    hm: wp.vec2d,
    hm1: wp.vec2d,
    hm2: wp.vec2d,
) -> vec6d:
    """(ee, nn, nu, uu, ew, G) of order m >= 1 from the C (x = 0) or S (x = 1) sums.

    ew = Σ (n+2) q^n X P̄/u and G the 1/u² term of V_en (see the module docstring), before
    the factors K, m and the signs of the longitude derivative.
    """
    s0 = sm[0 + x]
    s1 = sm[2 + x]
    s2 = sm[4 + x]
    d0 = -t * (s1 - s0) + q * sm[6 + x]
    d2 = -t * (s2 - s1 - s0) + q * sm[8 + x]
    hh = wp.float64(0.0)
    gg = wp.float64(0.0)
    if m == 1:
        hh = scaled_times(s0 + t * sm[10 + x], hm)
        gg = scaled_times(sm[10 + x], hm)
    else:
        fm = wp.float64(m)
        hh = scaled_times(t * d0 + fm * fm * s0, hm2)
        gg = scaled_times(d0 + t * s0, hm2)
    return vec6d(
        -hh - scaled_times(s1, hm),
        hh - scaled_times(s2 - s1, hm),
        -scaled_times(d2, hm1),
        scaled_times(s2, hm),
        scaled_times(s1 + s0, hm1),
        gg,
    )


@wp.func
def tensor_coefficients(
    sm: tensor_sums,
    z0: wp.float64,
    z2: wp.float64,
    m: int,
    t: wp.float64,
    upow: wp.array2d(dtype=wp.float64),
    q: wp.float64,
    k: wp.float64,
    cd: wp.float64,
    sd: wp.float64,
    coef: wp.array3d(dtype=wp.vec2d),
    row: int,
):
    """Write the six geodetic-ENU Fourier coefficients (A, −B) of order m of one row.

    ``sm``: the column sums of the row (:data:`tensor_sums`, both parities added); ``z0``,
    ``z2``: entries [12], [13] of the order-1 sums (used by m = 0); ``k = GM/r^3`` times the
    order's factor; the powers of u from the row's table ``upow``
    (:func:`fieldmap.kernels.grid.row_powers_kernel`). Components in the order ee, en, eu,
    nn, nu, uu (see the module docstring).
    """
    zero = wp.float64(0.0)
    if m == 0:
        h0 = wp.vec2d(wp.float64(1.0), wp.float64(1.0))
        hq = half_powers_tab(upow, row, 1)
        hh = scaled_times(t * z0, h0)
        a = vec6d(
            k * (-hh - scaled_times(sm[2], h0)),
            zero,
            zero,
            k * (hh - scaled_times(sm[4] - sm[2], h0)),
            -k * scaled_times(z2, hq),
            k * scaled_times(sm[4], h0),
        )
        _store_rotated(coef, row, m, a, vec6d(), cd, sd)
        return
    hm = half_powers_tab(upow, row, m)
    hm1 = half_powers_tab(upow, row, m - 1)
    hm2 = hm1
    if m >= 2:
        hm2 = half_powers_tab(upow, row, m - 2)
    pc = _order_parts(sm, 0, m, t, q, hm, hm1, hm2)
    ps = _order_parts(sm, 1, m, t, q, hm, hm1, hm2)
    km = k * wp.float64(m)
    # the λ-derivative turns C into the sin part of eu and en and S into their cos part:
    # eu: A = -K m ew_S, B = K m ew_C; en: A = K m G_S, B = -K m G_C
    a = vec6d(k * pc[0], km * ps[5], -km * ps[4], k * pc[1], k * pc[2], k * pc[3])
    b = vec6d(k * ps[0], -km * pc[5], km * pc[4], k * ps[1], k * ps[2], k * ps[3])
    _store_rotated(coef, row, m, a, b, cd, sd)


@wp.kernel
def row_tensor_kernel(
    model: SHKernelModel,
    rec: wp.array(dtype=vec12d),
    start: wp.array(dtype=wp.int32),
    t: wp.array(dtype=wp.float64),
    u: wp.array(dtype=wp.float64),
    r: wp.array(dtype=wp.float64),
    q: wp.array(dtype=wp.float64),
    cdel: wp.array(dtype=wp.float64),
    sdel: wp.array(dtype=wp.float64),
    row_a: wp.array(dtype=wp.int32),
    row_b: wp.array(dtype=wp.int32),
    upow: wp.array2d(dtype=wp.float64),
    qpow: wp.array2d(dtype=wp.float64),
    nm: int,
    osc: wp.array(dtype=wp.float64),
    coef: wp.array3d(dtype=wp.vec2d),
    offset: wp.int32,
):
    """Fourier coefficients of the gravitation tensor for every (row unit, order m).

    Thread ``i`` handles unit ``i // nm`` (row ``row_a``, its mirror ``row_b`` or −1) and order
    ``m = i % nm``, the powers of u and q from the rows' tables ``upow``/``qpow``
    (:func:`fieldmap.kernels.grid.row_powers_kernel`): orders m >= 2 on the packed tables
    ``rec``/``start`` (:func:`tensor_column_packed`), 0 and 1 on the model's square tables
    (:func:`tensor_column`); the m = 0 thread also sums the order-1 column for the zonal
    terms of V_nu and V_nn (1/(lmax/2) of a row's work). Order m is written times ``osc[m]`` (see
    :func:`fieldmap.kernels.grid.row_fourier_kernel`); the m = nm - 1 thread zeroes the
    columns past nm.
    """
    i = wp.tid() + offset
    unit = i / nm
    m = i - unit * nm
    ra = row_a[unit]
    rb = row_b[unit]
    ta = t[ra]
    qa = q[ra]
    ev = tensor_sums()
    od = tensor_sums()
    if m >= 2:
        top = sh_degree_cut(model, qa)
        if m <= top:
            seed = SCALE * model.sect[m] * qpow[m, ra]
            ev, od = tensor_column_packed(rec, start[m], top + 1 - m, seed, ta * qa, qa * qa)
    else:
        ev, od = tensor_column(model, m, ta, qa)
    e1 = tensor_sums()
    o1 = tensor_sums()
    if m == 0 and model.lmax >= 1:
        e1, o1 = tensor_column(model, 1, ta, qa)
    ra_r = r[ra]
    k = model.gm / (ra_r * ra_r * ra_r) * osc[m]
    tensor_coefficients(
        ev + od, e1[12] + o1[12], e1[13] + o1[13], m, ta, upow, qa, k, cdel[ra], sdel[ra],
        coef, ra,
    )  # fmt: skip
    if m == nm - 1:
        zero_tail(coef, ra, nm)
    if rb >= 0:
        rb_r = r[rb]
        kb = model.gm / (rb_r * rb_r * rb_r) * osc[m]
        tensor_coefficients(
            mirror_sums(ev, od), e1[12] - o1[12], e1[13] - o1[13], m, -ta, upow, q[rb], kb,
            cdel[rb], sdel[rb], coef, rb,
        )  # fmt: skip
        if m == nm - 1:
            zero_tail(coef, rb, nm)
