"""labgen's physics and instruments against closed forms and direct
computations (each bound stated)."""

import csv
import json
import os

import numpy as np
import pytest

from labgen import families
from labgen.__main__ import main
from labgen.effects import Effects, read, resistance_profile, strain_profile
from labgen.film import Film
from labgen.line import input_impedance, uniform_impedance
from labgen.meter import SAMPLE_S, Meter, digits, pink
from labgen.motion import Strokes


@pytest.mark.parametrize("freq_hz", [100.0, 1e3, 1e4, 1e5])
@pytest.mark.parametrize("r_ohm", [2e5, 7e5, 3e6])
def test_the_integrated_line_is_the_closed_form_on_a_uniform_film(freq_hz, r_ohm):
    """RK4 against z/γ·coth γ: relative error below 1e-7 over 100 Hz-100 kHz
    and 0.2-3 MΩ with 150-400 pF (ωRC up to 750)."""
    for c in (150e-12, 400e-12):
        z = np.array([r_ohm + 0j])
        y = np.array([2j * np.pi * freq_hz * c])
        got = input_impedance(lambda x: z, lambda x: y)
        want = uniform_impedance(z, y)
        assert abs(got[0] / want[0] - 1) < 1e-7


def test_a_nonuniform_line_converges_with_the_steps():
    """A thickness taper and a narrow press: the steps used (256) against
    1024 within 1e-7 (128 steps: 4e-7)."""
    fx = Effects(thickness_taper=0.7, press=(1.5, 0.3, 0.08))
    film = Film()
    p, w = strain_profile(fx), resistance_profile(fx)
    lam = film.lam(np.array([25.0]))
    r = film.r0_top_ohm + film.r0_bottom_ohm

    def z_at(x):
        return (r * film.r_factor(1 + (lam - 1) * p(x)) * w(x)).astype(complex)

    def y_at(x):
        return 2j * np.pi * 2e4 * film.c_per_length(1 + (lam - 1) * p(x))

    a = input_impedance(z_at, y_at)
    b = input_impedance(z_at, y_at, steps=1024)
    assert abs(a[0] / b[0] - 1) < 1e-7


def test_profiles_keep_their_mean():
    """Every profile has mean 1 along the film (to 1e-9)."""
    fx = Effects(width_taper=-0.4, clamp_zone=(0.5, 0.1), press=(-0.6, 0.8, 0.1))
    fx.patch, fx.thickness_taper = (4.0, 0.3, 0.1, 0.01), 0.8
    xs = np.linspace(0, 1, 200001)
    for prof in (strain_profile(fx), resistance_profile(fx)):
        assert abs((getattr(np, "trapezoid", None) or np.trapz)(prof(xs), xs) - 1) < 1e-9


def test_the_film_reads_as_a_capacitor_at_low_frequency():
    """At 10 Hz the line's Cs is its C within 1e-5, and R end to end the
    film's at rest."""
    film = Film()
    r = read(film, Effects(), [0.0], 0.0, 10.0)
    cs = -1 / (2 * np.pi * 10.0 * r.z_ohm.imag)
    assert abs(cs[0] / film.c0_f - 1) < 1e-5
    assert abs(r.r_top_ohm[0] / film.r0_top_ohm - 1) < 1e-6
    # Lumped Rs of a line read at one end: (R_top + R_bottom)/3.
    assert abs(r.z_ohm.real[0] / ((film.r0_top_ohm + film.r0_bottom_ohm) / 3) - 1) < 1e-4


def test_strokes_and_damage():
    s = Strokes(peak_speed_mm_s=20.0, cycles=2)
    t = np.arange(-1.0, s.duration_s + 2.0, SAMPLE_S)
    x = s.stretch_mm(t)
    assert x.min() == 0.0 and abs(x.max() - 30.0) < 1e-9
    v = np.diff(x) / SAMPLE_S
    assert abs(np.abs(v).max() - 20.0) < 0.01
    d = Film().damage(t, x)
    assert 0.1 < d.max() < 1.0
    assert d[-1] < 0.05 * d.max()


def test_the_window_is_the_mean_of_its_samples():
    """A window's reading is the mean of the admittance samples it
    covers, wherever its stamp sits."""
    y = np.sin(np.arange(2000) * 0.01) + 0j
    for stamp in (0.0, 0.5, 1.0):
        m = Meter(kind="window", length_s=0.05, stamp=stamp)
        out, at = m.analog(y)
        k = 1000
        want = y[k - 49 : k + 1].mean()
        assert abs(out[k] - want) < 1e-12
        assert at == pytest.approx(stamp * 49)


def test_a_response_is_normalised_and_centred_at_n_tau():
    m = Meter(kind="response", tau_s=0.02, sections=3)
    step = np.ones(3000) + 0j
    out, _ = m.analog(step)
    assert abs(out[-1] - 1) < 1e-12
    impulse = np.zeros(3000) + 0j
    impulse[0] = 1
    k = m.analog(impulse)[0].real
    centroid = np.sum(k * (np.arange(3000) + 0.5)) * SAMPLE_S
    assert abs(centroid - 0.06) < 1e-3


def test_logger_kernels():
    cs = np.arange(20.0)
    m = Meter(kind="mean", readings=4, delay_rows=2)
    got, _ = m.logger(cs, cs)
    assert got[10] == pytest.approx(np.mean(cs[5:9]))
    e = Meter(kind="ewma", ewma_readings=3.0)
    got, _ = e.logger(cs, cs)
    a = 1 - np.exp(-1 / 3)
    assert got[5] == pytest.approx(got[4] + a * (cs[5] - got[4]))


def test_noise_helpers():
    rng = np.random.Generator(np.random.PCG64(1))
    x = pink(rng, 4096, 0.004)
    assert abs(np.std(x) - 0.004) < 1e-12 and abs(np.mean(x)) < 1e-12
    assert list(digits([123456.78, 0.001234567], 6)) == [123457.0, 0.00123457]


def test_the_plan_draws_every_kind():
    got = [families.plan(s)[0] for s in range(100)]
    assert got.count(None) == 10
    assert sum(g in families.OUTSIDE for g in got) == 10
    for f in families.FAMILIES:
        fx, meter, v = families.draw(f, np.random.Generator(np.random.PCG64(3)))
        assert np.isfinite(v)


def test_a_data_set_is_written_in_the_format(tmp_path):
    out = tmp_path / "set"
    assert main(["--seed", "3", "--family", "contact", "--out", str(out)]) == 0
    truth = json.loads((out / "truth.json").read_text())
    assert truth["family"] == "contact" and truth["catalogue_ids"] == ["contact_resistance"]
    names = sorted(os.listdir(out))
    assert "calibration.csv" in names and "sweep.csv" in names
    traces = [n for n in names if n.startswith("trace_")]
    assert len(traces) == 6
    with open(out / traces[0]) as fh:
        rows = list(csv.DictReader(fh))
    t = [float(r["time_s"]) for r in rows]
    assert all(b > a for a, b in zip(t, t[1:]))
    assert len({r["freq_hz"] for r in rows}) == 1
    assert all(float(r["cs_pf"]) > 0 for r in rows)
