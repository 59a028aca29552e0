"""Measured surfaces: maps read from interferometers and profilers (:mod:`.read`), their areal
parameters and filters (:mod:`.areal`), fits and spectra with missing pixels (:mod:`.fits`),
the instrument pipeline a simulated surface goes through (:mod:`.analysis`), the comparison
with a prediction (:mod:`.compare`) and the attribution of a spectrum to the error sources
(:mod:`.attribution`)."""
