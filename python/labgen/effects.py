"""The sensor's effects, each by a parametrisation of its own, and the
sensor read through its wiring.

Profiles along the film are functions of ξ (0: the read end) normalised
to a mean of 1, so the totals a calibration records stay:

- `thickness_taper` g: a sprayed electrode thicker toward one end,
  t ∝ 1 + g(2ξ - 1), so resistance per length ∝ 1/t;
- `width_taper` τ: a strip cut wider toward one end, w ∝ 1 + τ(2ξ - 1);
  the force is the same through every section, so the strain ∝ 1/w;
- `clamp_zone` (a, ℓ): the clamps hold the strip's width at its ends, so
  the strain falls by a·(e^(-ξ/ℓ) + e^(-(1-ξ)/ℓ)) within about ℓ of each
  (Saint-Venant's decay);
- `press` (a, ξ₀, σ): a fingertip pressed into the skin, a Gaussian of
  extra strain;
- `patch` (a, ξ₀, half length, edge): a thinner (a > 0) or thicker patch
  of the electrode with soft (tanh) edges.

Outside the film: a contact at each of the four tabs (each its own),
leads of the electrode's own film running from the overlap to each tab,
a coax cable and a fixture at the meter; out of the library, a
constant-phase (blocking, rough) contact at the read tabs and a
Havriliak-Negami relaxation of the dielectric.
"""

from dataclasses import dataclass, field

import numpy as np

# numpy 2 renamed trapz to trapezoid (and dropped trapz); 1.x has only trapz.
_trapezoid = getattr(np, "trapezoid", None) or np.trapz

from .line import input_impedance

EPS0 = 8.854e-12
COAX_F_PER_M = 101e-12
"""RG-58's capacitance per metre."""


@dataclass
class Effects:
    contacts_ohm: tuple = (0.0, 0.0, 0.0, 0.0)
    """Tab contacts: top at the read end, bottom at the read end, top at
    the far end, bottom at the far end, Ω."""
    cable_m: float = 0.0
    """Coax between the sensor and the meter, m."""
    fixture_f: float = 0.0
    """The fixture's own capacitance, F."""
    thickness_taper: float = 0.0
    width_taper: float = 0.0
    clamp_zone: tuple = (0.0, 0.2)
    press: tuple = (0.0, 0.5, 0.1)
    patch: tuple = (0.0, 0.5, 0.1, 0.02)
    resistivity_ohm_m: float = float("inf")
    """The film's volume resistivity (bulk leakage), Ω·m."""
    eps_r: float = 4.0
    """Its relative permittivity (with the resistivity: G/C = 1/(ρε))."""
    lead_mm: float = 0.0
    """Each electrode's lead of its own film to each tab, mm (the film's
    width, so the lead is lead_mm/length of the electrode's resistance)."""
    film_corner_hz: float = float("inf")
    """The electrode's conductivity corner (its clusters' capacitance
    short their gaps above it): r/(1 + j f/f_c)."""
    cpe: tuple = (0.0, 1.0)
    """Out of the library: a constant-phase contact at each read tab,
    Z = 1/(Q (jω)^n): (Q in S·s^n, n)."""
    havriliak_negami: tuple = (0.0, 1e-3, 1.0, 1.0)
    """Out of the library: ε(ω)/ε(0) = 1 - Δ + Δ/(1 + (jωτ)^α)^β:
    (Δ, τ s, α, β)."""
    extra: dict = field(default_factory=dict)


def _mean_one(f):
    """`f(ξ)` over its mean along the film (Simpson on 2001 points)."""
    xs = np.linspace(0.0, 1.0, 2001)
    w = np.ones_like(xs)
    w[1:-1:2], w[2:-1:2] = 4.0, 2.0
    mean = float(np.sum(w * f(xs)) / (3.0 * (len(xs) - 1)))
    return lambda x: f(x) / mean


def strain_profile(fx):
    """p(ξ): the local strain over the mean strain (mean 1)."""
    tau = fx.width_taper
    a, ell = fx.clamp_zone
    pa, pc, ps = fx.press

    def p(x):
        x = np.asarray(x, dtype=float)
        out = 1.0 / (1.0 + tau * (2.0 * x - 1.0))
        out = out * (1.0 - a * (np.exp(-x / ell) + np.exp(-(1.0 - x) / ell)))
        return out * (1.0 + pa * np.exp(-0.5 * ((x - pc) / ps) ** 2))

    return _mean_one(p)


def resistance_profile(fx):
    """w(ξ): the electrode's resistance per length over its mean."""
    g = fx.thickness_taper
    a, c, half, edge = fx.patch

    def w(x):
        x = np.asarray(x, dtype=float)
        inside = 0.5 * (np.tanh((x - (c - half)) / edge) - np.tanh((x - (c + half)) / edge))
        return (1.0 + a * inside) / (1.0 + g * (2.0 * x - 1.0))

    return _mean_one(w)


@dataclass
class Reading:
    z_ohm: np.ndarray
    """Impedance at the meter, Ω (complex)."""
    r_top_ohm: np.ndarray
    """Four-terminal resistance of the top electrode through its tabs, Ω."""
    r_bottom_ohm: np.ndarray
    c_true_f: np.ndarray
    """The film's capacitance at its static permittivity, F."""


def permittivity(fx, freq_hz):
    """ε(ω)/ε(0) of the film (Havriliak-Negami; 1 without)."""
    d, tau, alpha, beta = fx.havriliak_negami
    if d == 0.0:
        return 1.0
    jwt = (1j * 2 * np.pi * freq_hz * tau) ** alpha
    return 1.0 - d + d / (1.0 + jwt) ** beta


def read(film, fx, stretch_mm, damage, freq_hz):
    """The sensor at mean stretches `stretch_mm` (array) with the film's
    broken share `damage`, read at `freq_hz`."""
    lam = film.lam(np.atleast_1d(np.asarray(stretch_mm, dtype=float)))
    dmg = np.broadcast_to(np.asarray(damage, dtype=float), lam.shape)
    p, w = strain_profile(fx), resistance_profile(fx)
    omega = 2 * np.pi * freq_hz
    eps = permittivity(fx, freq_hz)
    g_over_c = 1.0 / (fx.resistivity_ohm_m * EPS0 * fx.eps_r)
    r_sum = film.r0_top_ohm + film.r0_bottom_ohm
    disp = 1.0 / (1.0 + 1j * freq_hz / fx.film_corner_hz)

    def local(x):
        return 1.0 + (lam - 1.0) * p(x)

    def z_at(x):
        return (r_sum * film.r_factor(local(x)) * (1.0 + dmg) * w(x) * disp).astype(complex)

    def y_at(x):
        c = film.c_per_length(local(x))
        return 1j * omega * c * eps + g_over_c * c

    z = input_impedance(z_at, y_at)
    scale = film.r_factor(lam) * (1.0 + dmg)
    share = fx.lead_mm / film.length_mm
    lead_top, lead_bottom = (r0 * share * scale for r0 in (film.r0_top_ohm, film.r0_bottom_ohm))
    ct, cb, ft, fb = fx.contacts_ohm
    z = z + lead_top + lead_bottom + ct + cb
    q, n = fx.cpe
    if q > 0.0:
        z = z + 2.0 / (q * (1j * omega) ** n)
    y = 1.0 / z + 1j * omega * (fx.cable_m * COAX_F_PER_M + fx.fixture_f)
    # The film's own end-to-end resistance: the mean of its profile, 1.
    xs = np.linspace(0.0, 1.0, 401)
    film_share = _trapezoid(np.stack([film.r_factor(local(x)) for x in xs]) * w(xs)[:, None], xs, axis=0)
    film_share = film_share * (1.0 + dmg)
    c_true = _trapezoid(np.stack([film.c_per_length(local(x)) for x in xs]), xs, axis=0)
    return Reading(
        z_ohm=1.0 / y,
        r_top_ohm=film.r0_top_ohm * film_share + 2 * lead_top + ct + ft,
        r_bottom_ohm=film.r0_bottom_ohm * film_share + 2 * lead_bottom + cb + fb,
        c_true_f=c_true,
    )
