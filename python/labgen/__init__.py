"""labgen: a third bench for `identify`, written apart from `skin-sim` and
`rig-sim` from the physics and instrument literature by routes of its own.

It writes data sets in the project's interchange format
(`docs/data-format.md`), one hidden effect each, and a `truth.json`
naming the effect and the catalogue ids an analysis may answer with.
Nothing here is tuned against `identify`: the survey reports what comes
out (`cargo xtask survey`, `host-sim/tests/third_generator.rs`).

What differs from the other two generators, on purpose:

- line: the telegrapher's equations integrated along the film (RK4,
  shooting from the open far end), not a ladder or power series
  (`line.py`);
- film: an incompressible strip whose width contracts as λ^-ν, carbon
  black's piezoresistance e^(κ(λ-1)), a two-time-constant relaxation of
  the electrode's broken paths after motion (`film.py`);
- meter: an LCR meter whose analog kernels average the current phasor
  (admittance) and whose logger kernels average the reported numbers;
  noise a fraction of |Z| on both axes, 1/f drift, 6-digit display,
  25 ms rows with a logger's jitter (`meter.py`);
- rig: raised-cosine strokes, not trapezoids (`motion.py`);
- effects: other shapes and parametrisations (a sprayed electrode's
  thickness taper, a tapered strip's strain, clamp end zones, Gaussian
  presses, soft-edged patches, coax by the metre, film resistivity,
  Havriliak–Negami relaxation and constant-phase contacts outside the
  library) (`effects.py`).
"""
