"""One hidden effect per data set, drawn over its physical range (from
the literature on DE films, carbon-black electrodes, LCR meters and
loggers; never from `identify`'s search ranges), with the catalogue ids
an analysis may answer with (plain strings: nothing here links the
catalogue)."""

from dataclasses import replace

import numpy as np

from .effects import Effects
from .meter import Meter

KERNEL = ["meter_lag", "meter_response", "meter_mean", "meter_ewma"]

# family: (catalogue ids that name it right, what it is)
FAMILIES = {
    "contact": (["contact_resistance"], "a contact at each tab, 2 kΩ-1.5 MΩ each, all four different"),
    "parasitic": (["parasitic_capacitance"], "0.05-0.4 m of RG-58 and a 0.3-3 pF fixture"),
    "resistance_profile": (
        ["resistance_gradient", "resistance_bulge", "resistance_bump"],
        "a sprayed electrode's thickness taper, t ∝ 1 + g(2ξ - 1), |g| 0.1-0.85",
    ),
    "stretch_tilt": (
        ["nonuniform_stretch", "stretch_bulge", "stretch_bump"],
        "a strip cut tapered, width ratio up to 2.6 end to end",
    ),
    "stretch_bulge": (
        ["stretch_bulge", "nonuniform_stretch", "stretch_bump"],
        "clamp zones: the ends stretch 15-60 % less within 6-30 % of the length",
    ),
    "leakage": (["dielectric_leakage"], "a film of volume resistivity 1.5e7-3e9 Ω·m, εr 2.5-4.7"),
    "window": (KERNEL, "an integration window of 25 ms-1.2 s, stamped anywhere in it"),
    "first_order": (KERNEL, "an RC output filter, τ 12 ms-0.6 s"),
    "cascade": (KERNEL, "a lock-in's filter: 2-4 RC sections of 6-150 ms"),
    "moving_mean": (KERNEL, "a logger's running mean of 2-16 readings, 0-3 readings late"),
    "ewma": (KERNEL, "a logger's exponential mean of 0.7-20 readings' time constant, 0-3 late"),
    "offset": (["time_offset"], "the meter's trigger 8 ms-0.45 s late or early"),
    "leads": (["lead_resistance"], "leads of the electrode's film, 3-40 mm to each tab"),
    "film_dispersion": (["electrode_dispersion"], "the electrode's conductivity corner at 0.5-80 kHz"),
    "stretch_bump": (
        ["stretch_bump", "stretch_bulge", "nonuniform_stretch"],
        "a Gaussian press: 0.3-2 times more strain or 0.2-0.7 less, σ 5-25 % of the length",
    ),
    "resistance_bump": (
        ["resistance_bump", "resistance_bulge", "resistance_gradient"],
        "a soft-edged patch of the electrode 10-60 % long, 0.3-5 times more resistive or 0.2-0.7 less",
    ),
    "relaxation": ([], "outside: a Havriliak-Negami relaxation of the film, Δε 3-30 %"),
    "cpe_contact": ([], "outside: a constant-phase contact at the read tabs, |Z| 20 kΩ-2 MΩ at 1 kHz"),
}
IN_LIBRARY = [f for f, (ids, _) in FAMILIES.items() if ids]
OUTSIDE = [f for f, (ids, _) in FAMILIES.items() if not ids]


def log_uniform(rng, lo, hi):
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def signed(rng, lo, hi):
    return float(rng.choice([-1.0, 1.0]) * rng.uniform(lo, hi))


def amplitude(rng, more, less):
    """A relative amplitude: `more` (lo, hi) above, or `less` below."""
    return float(rng.uniform(*more) if rng.random() < 0.6 else -rng.uniform(*less))


def draw_meter(family, rng):
    """(meter, value) of a family of the meter's, or None."""
    m = Meter()
    if family == "window":
        v = log_uniform(rng, 0.025, 1.2)
        return replace(m, kind="window", length_s=v, stamp=float(rng.uniform())), v
    if family == "first_order":
        v = log_uniform(rng, 0.012, 0.6)
        return replace(m, kind="response", tau_s=v), v
    if family == "cascade":
        v = log_uniform(rng, 0.006, 0.15)
        return replace(m, kind="response", tau_s=v, sections=int(rng.integers(2, 5))), v
    if family == "moving_mean":
        n = int(rng.integers(2, 17))
        return replace(m, kind="mean", readings=n, delay_rows=int(rng.integers(0, 4))), float(n)
    if family == "ewma":
        v = log_uniform(rng, 0.7, 20.0)
        return replace(m, kind="ewma", ewma_readings=v, delay_rows=int(rng.integers(0, 4))), v
    if family == "offset":
        v = signed(rng, 0.008, 0.45)
        return replace(m, trigger_delay_s=v), v
    return None


def draw_effects(family, rng):
    """(effects, value) of a family of the sensor's."""
    fx = Effects()
    if family == "contact":
        fx.contacts_ohm = tuple(log_uniform(rng, 2e3, 1.5e6) for _ in range(4))
        v = fx.contacts_ohm[0]
    elif family == "parasitic":
        fx.cable_m, fx.fixture_f = rng.uniform(0.05, 0.4), rng.uniform(0.3e-12, 3e-12)
        v = fx.cable_m * 101e-12 + fx.fixture_f
    elif family == "resistance_profile":
        v = fx.thickness_taper = signed(rng, 0.1, 0.85)
    elif family == "stretch_tilt":
        v = fx.width_taper = signed(rng, 0.1, 0.45)
    elif family == "stretch_bulge":
        fx.clamp_zone = (rng.uniform(0.15, 0.6), rng.uniform(0.06, 0.3))
        v = fx.clamp_zone[0]
    elif family == "leakage":
        fx.resistivity_ohm_m, fx.eps_r = log_uniform(rng, 1.5e7, 3e9), rng.uniform(2.5, 4.7)
        v = 1.0 / (fx.resistivity_ohm_m * 8.854e-12 * fx.eps_r)
    elif family == "leads":
        v = fx.lead_mm = rng.uniform(3.0, 40.0)
    elif family == "film_dispersion":
        v = fx.film_corner_hz = log_uniform(rng, 500.0, 80e3)
    elif family == "stretch_bump":
        fx.press = (amplitude(rng, (0.3, 2.0), (0.2, 0.7)), rng.uniform(0.1, 0.9), rng.uniform(0.05, 0.25))
        v = fx.press[0]
    elif family == "resistance_bump":
        fx.patch = (
            amplitude(rng, (0.3, 5.0), (0.2, 0.7)),
            rng.uniform(0.1, 0.9),
            rng.uniform(0.05, 0.3),
            rng.uniform(0.005, 0.05),
        )
        v = fx.patch[0]
    elif family == "relaxation":
        fx.havriliak_negami = (
            rng.uniform(0.03, 0.3),
            log_uniform(rng, 2e-6, 2e-3),
            rng.uniform(0.4, 0.9),
            rng.uniform(0.3, 1.0),
        )
        v = fx.havriliak_negami[0]
    elif family == "cpe_contact":
        n = rng.uniform(0.5, 0.85)
        mag = log_uniform(rng, 2e4, 2e6)
        fx.cpe = (1.0 / (mag * (2 * np.pi * 1e3) ** n), n)
        v = mag
    else:
        raise ValueError(f"no family {family!r}")
    return fx, float(v)


def draw(family, rng):
    """(effects, meter, value) of one data set of `family` (None: clean)."""
    if family is None:
        return Effects(), Meter(), 0.0
    got = draw_meter(family, rng)
    if got is not None:
        return Effects(), got[0], got[1]
    fx, v = draw_effects(family, rng)
    return fx, Meter(), v


def plan(seed):
    """The survey's family for set `seed`: every tenth clean (9), every
    tenth from the fifth outside the library, the rest in it at random
    (drawn from the set's own stream)."""
    rng = np.random.Generator(np.random.PCG64([7, seed]))
    if seed % 10 == 9:
        return None, rng
    if seed % 10 == 4:
        return OUTSIDE[(seed // 10) % len(OUTSIDE)], rng
    return IN_LIBRARY[int(rng.integers(0, len(IN_LIBRARY)))], rng
