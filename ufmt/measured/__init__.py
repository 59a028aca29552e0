"""Measured surfaces: maps read from interferometers and profilers (:mod:`.read`), their areal
parameters and filters (:mod:`.areal`), the instrument pipeline a simulated surface goes
through (:mod:`.analysis`) and the comparison with a prediction (:mod:`.compare`)."""
