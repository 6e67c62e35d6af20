"""The sensor as a distributed R-C line read at one end, far end open.

Along the film (ξ = 0 at the read end, 1 at the far end, in rest length)
the differential voltage V and the electrode current I obey

    dV/dξ = -z(ξ) I,    dI/dξ = -y(ξ) V,

z the series impedance (both electrodes) and y the shunt admittance per
unit ξ. From the open end (I = 0, V = 1) the pair is integrated back to
ξ = 0 by classical Runge-Kutta (RK4), every sample at once; the input
impedance is V(0)/I(0). The step count is checked against the closed
form of the uniform line, Z = z/γ·coth γ with γ = √(zy)
(`tests/test_labgen.py`).
"""

import numpy as np

STEPS = 256
"""RK4 steps along the film (relative error < 1e-7 on the uniform line to
100 kHz on the largest sensor the bench makes)."""


def input_impedance(z_at, y_at, steps=STEPS):
    """Input impedance (Ω, complex array) of the line whose series
    impedance and shunt admittance per unit length at ξ are `z_at(ξ)` and
    `y_at(ξ)` (complex arrays of one shape, one entry per sample)."""
    h = -1.0 / steps
    xi = 1.0
    z1, y1 = z_at(xi), y_at(xi)
    v = np.ones_like(z1)
    i = np.zeros_like(z1)
    for _ in range(steps):
        zm, ym = z_at(xi + 0.5 * h), y_at(xi + 0.5 * h)
        z2, y2 = z_at(xi + h), y_at(xi + h)
        kv1, ki1 = -z1 * i, -y1 * v
        kv2, ki2 = -zm * (i + 0.5 * h * ki1), -ym * (v + 0.5 * h * kv1)
        kv3, ki3 = -zm * (i + 0.5 * h * ki2), -ym * (v + 0.5 * h * kv2)
        kv4, ki4 = -z2 * (i + h * ki3), -y2 * (v + h * kv3)
        v = v + h / 6.0 * (kv1 + 2 * kv2 + 2 * kv3 + kv4)
        i = i + h / 6.0 * (ki1 + 2 * ki2 + 2 * ki3 + ki4)
        xi += h
        z1, y1 = z2, y2
    return v / i


def uniform_impedance(z, y):
    """Closed form of the uniform line: z/γ · coth γ, γ = √(zy)."""
    g = np.sqrt(z * y)
    return z / g / np.tanh(g)


def series_c(z, freq_hz):
    """Series capacitance (F) of impedance `z` at `freq_hz`: the Cs of
    Cs-Rs."""
    return -1.0 / (2 * np.pi * freq_hz * np.imag(z))
