"""The film: an incompressible elastomer strip between two carbon-black
electrodes, clamped at both ends and stretched along its length.

At a local stretch λ, with the width contracting as λ^-ν (ν between 0
for a strip held at its width, pure shear, and ½ for a free one) the
thickness goes as λ^(ν-1), so per rest length

- capacitance C₀·λ^(2-2ν) (area over thickness);
- each electrode's resistance R₀·λ²·e^(κ(λ-1)): the geometry's λ² and
  carbon black's piezoresistance (its contacts part as it stretches),
  times (1 + D), D the share of conductive paths the motion broke.

D relaxes with two time constants (a fast reconnection of touching
aggregates and a slow one of the network), driven by the rate of
stretch, more on release:

    dx_k/dt = |λ̇|·(1 + e·[λ̇ < 0]) - x_k/τ_k,   D = Σ g_k·x_k.
"""

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Film:
    c0_f: float = 205e-12
    """Capacitance at rest (prestretched), F."""
    nu: float = 0.42
    """Width contraction exponent ν."""
    r0_top_ohm: float = 331e3
    """Top electrode's end-to-end film resistance at rest, Ω."""
    r0_bottom_ohm: float = 372e3
    """Bottom electrode's, Ω."""
    kappa: float = 0.8
    """Piezoresistive coefficient κ of the carbon black."""
    length_mm: float = 58.0
    """Length between the clamps at rest, mm."""
    gains: tuple = (2.5, 0.6)
    """g_k of the broken paths' two modes."""
    taus_s: tuple = (0.12, 1.2)
    """τ_k of the two modes, s."""
    release_extra: float = 0.4
    """e: extra breakage on release."""

    def lam(self, stretch_mm):
        """Mean stretch ratio at `stretch_mm`."""
        return 1.0 + np.asarray(stretch_mm) / self.length_mm

    def c_per_length(self, lam):
        """Capacitance per unit rest length at local stretch λ, F."""
        return self.c0_f * lam ** (2.0 - 2.0 * self.nu)

    def r_factor(self, lam):
        """Electrode resistance per rest length at λ over that at rest."""
        return lam**2 * np.exp(self.kappa * (lam - 1.0))

    def damage(self, t, stretch_mm):
        """D along samples `t` (s, uniform) of the rig's `stretch_mm`."""
        dt = t[1] - t[0]
        lam = self.lam(stretch_mm)
        dl = np.diff(lam, prepend=lam[0])
        drive = np.abs(dl) * np.where(dl < 0, 1.0 + self.release_extra, 1.0)
        d = np.zeros_like(t)
        for g, tau in zip(self.gains, self.taus_s):
            a = np.exp(-dt / tau)
            x = 0.0
            out = np.empty_like(t)
            for k, u in enumerate(drive):
                x = a * x + u
                out[k] = x
            d += g * out
        return d
