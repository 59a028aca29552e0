"""The accelerometer chain (oracles: the SDOF base-excitation response integrated in time, the
analogue Butterworth of scipy and its closed-form magnitude, a sine evaluated at the
recorder's instants directly, the expected peak of a sine under a free-running clock)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.integrate
import scipy.signal
from machine_text import set_machine_keys  # tests/ helper
from synthetic import packaged_text

from ufmt.errors import ModelError
from ufmt.machining.instruments import (
    ANTI_ALIAS_ORDER,
    SAMPLING_PHASES,
    AccelerometerChain,
    accelerometer_peak,
)
from ufmt.model.load import load_model_text
from ufmt.model.machine import OPTIONAL_FIELDS, machine_of

SPINDLE_HZ = 5.0  # 300 rpm


def record(frequency_hz: float, periods: int = 2, per_period: int = 2**14, amplitude=3.0):
    """A sine of ``frequency_hz`` [Hz] (whole cycles per spindle period) over ``periods``
    spindle periods of ``per_period`` samples: times [s] and values."""
    t = np.arange(periods * per_period) / (SPINDLE_HZ * per_period)
    return t, amplitude * np.sin(2 * np.pi * frequency_hz * t)


def test_the_sensor_is_the_sdof_base_excitation_integrated_in_time():
    """z'' + 2 zeta w_n z' + w_n^2 z = -a(t): the output -w_n^2 z in steady state has the
    amplitude |H_s(f)| (a sine of 1 m/s^2 at 0.6 f_n, after 40 decay times)."""
    chain = AccelerometerChain(resonance_hz=8e3, damping_ratio=0.05)
    wn, zeta, f = 2 * np.pi * chain.resonance_hz, chain.damping_ratio, 0.6 * chain.resonance_hz
    w = 2 * np.pi * f

    def rhs(t, state):
        z, v = state
        return [v, -np.sin(w * t) - 2 * zeta * wn * v - wn**2 * z]

    decay = 1 / (zeta * wn)
    t_end = 40 * decay + 5 / f
    t = np.linspace(40 * decay, t_end, 4001)
    sol = scipy.integrate.solve_ivp(
        rhs, (0, t_end), [0.0, 0.0], t_eval=t, rtol=1e-10, atol=1e-16, method="DOP853"
    )
    output = -(wn**2) * sol.y[0]
    fitted = np.linalg.lstsq(np.column_stack([np.sin(w * t), np.cos(w * t)]), output, rcond=None)[0]
    assert np.hypot(*fitted) == pytest.approx(abs(chain.sensor_gain(f)), rel=1e-6)


def test_the_sensor_resonance_amplifies_by_one_over_two_zeta():
    chain = AccelerometerChain(resonance_hz=10e3, damping_ratio=0.03)
    assert abs(chain.sensor_gain(10e3)) == pytest.approx(1 / (2 * 0.03), rel=1e-12)
    assert chain.sensor_gain(0.0) == 1.0


@pytest.mark.parametrize("ratio", [0.1, 0.5, 1.0, 1.7, 4.0])
def test_the_anti_alias_filter_is_the_analogue_butterworth(ratio):
    """Against scipy's analogue Butterworth of the same order and cut-off, and its
    magnitude 1 / sqrt(1 + (f / f_c)^(2 n))."""
    chain = AccelerometerChain(sampling_hz=10e3)
    f = ratio * chain.cutoff_hz
    b, a = scipy.signal.butter(ANTI_ALIAS_ORDER, 2 * np.pi * chain.cutoff_hz, analog=True)
    _, expected = scipy.signal.freqs(b, a, worN=[2 * np.pi * f])
    assert chain.anti_alias_gain(f) == pytest.approx(expected[0], rel=1e-9)
    magnitude = 1 / math.sqrt(1 + ratio ** (2 * ANTI_ALIAS_ORDER))
    assert abs(chain.anti_alias_gain(f)) == pytest.approx(magnitude, rel=1e-9)
    assert chain.cutoff_hz == pytest.approx(10e3 / 2.56, rel=1e-15)


def sampled_peak(chain: AccelerometerChain, frequency_hz: float, amplitude: float) -> float:
    """The recorder's report of the sine A sin(2 pi f t) through the chain, evaluated at the
    recorder's instants directly: gain |H| and phase arg H of the analogue chain, instants
    (j / P + k) / f_s for the P sampling phases j over one spindle period (f_s rounded to whole
    samples per period, as the recorder model does)."""
    per_period = round(chain.sampling_hz / SPINDLE_HZ)
    h = chain.gain(frequency_hz)
    phases = np.arange(SAMPLING_PHASES)[:, None] / SAMPLING_PHASES
    instants = (phases + np.arange(per_period)[None, :]) / (per_period * SPINDLE_HZ)
    values = abs(h) * amplitude * np.sin(2 * np.pi * frequency_hz * instants + np.angle(h))
    return float(np.abs(values).max(axis=1).mean())


@pytest.mark.parametrize("frequency_hz", [55.0, 1250.0, 2000.0, 3300.0, 6000.0])
def test_a_sine_through_the_chain_is_its_gain_at_the_recorder_instants(frequency_hz):
    """The FFT chain against the sine evaluated at the sampling instants (to rounding)."""
    chain = AccelerometerChain()
    t, a = record(frequency_hz)
    expected = sampled_peak(chain, frequency_hz, 3.0)
    assert accelerometer_peak(t, a, 2, chain) == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("samples_per_cycle", [4, 8, 16])
def test_sampling_lowers_a_sine_peak_by_its_expected_share(samples_per_cycle):
    """A sine sampled m times per cycle (m even) under a free-running clock: the largest
    |a| among the samples is A cos(2 pi d), d uniform in [0, 1 / (2 m)] cycles, whose mean is
    A sin(pi / m) / (pi / m). The recorder averages SAMPLING_PHASES = 16 phases: a midpoint
    rule over a period of a function with one kink (slope jump 2 (2 pi / m) sin(pi / m) in
    the sampling phase), error <= jump / (8 P^2) = 1.7e-4 A at m = 4."""
    fast = AccelerometerChain(resonance_hz=30e3, sampling_hz=20e3)
    frequency_hz = fast.sampling_hz / samples_per_cycle  # 5, 2.5, 1.25 kHz: whole cycles
    t, a = record(frequency_hz, amplitude=1.0)
    reported = accelerometer_peak(t, a, 2, fast) / abs(fast.gain(frequency_hz))
    m = samples_per_cycle
    expected = math.sin(math.pi / m) / (math.pi / m)
    bound = 2 * (2 * math.pi / m) * math.sin(math.pi / m) / (8 * SAMPLING_PHASES**2)
    assert abs(reported - expected) <= bound
    assert reported < 1.0  # sampling lowers a peak


def test_the_chain_passes_a_constant_and_reads_any_number_of_periods():
    t = np.arange(3 * 512) * 1e-4
    assert accelerometer_peak(t, np.full(t.size, 2.5), 3) == pytest.approx(2.5, rel=1e-12)
    t2, a2 = record(1250.0, periods=2)
    t4, a4 = record(1250.0, periods=4)
    assert accelerometer_peak(t4, a4, 4) == pytest.approx(accelerometer_peak(t2, a2, 2), 1e-12)


def test_the_chain_is_linear_in_the_acceleration():
    rng = np.random.default_rng(3)
    t = np.arange(2 * 4096) / (SPINDLE_HZ * 4096)
    a = rng.standard_normal(t.size)
    assert accelerometer_peak(t, -7.0 * a, 2) == pytest.approx(
        7.0 * accelerometer_peak(t, a, 2), rel=1e-12
    )


def with_machine_key(key: str, value: float):
    text = set_machine_keys(packaged_text(), **{key: repr(value)})
    return load_model_text(text, source="chain.toml")


@pytest.mark.parametrize(
    "key, value",
    [
        ("accelerometer_resonance_hz", 12e3),
        ("accelerometer_damping_ratio", 0.02),
        ("recorder_sampling_hz", 20e3),
    ],
)
def test_the_machine_keys_set_the_chain(key, value):
    machine = machine_of(with_machine_key(key, value))
    field = {
        "accelerometer_resonance_hz": "resonance_hz",
        "accelerometer_damping_ratio": "damping_ratio",
        "recorder_sampling_hz": "sampling_hz",
    }[key]
    assert getattr(AccelerometerChain.of(machine), field) == value


@pytest.mark.parametrize(
    "key", ["accelerometer_resonance_hz", "accelerometer_damping_ratio", "recorder_sampling_hz"]
)
def test_a_chain_key_outside_its_band_names_the_file_field_and_range(key):
    _, _, high, _ = OPTIONAL_FIELDS[key]
    with pytest.raises(ModelError) as error:
        with_machine_key(key, 2 * high)
    message = str(error.value)
    assert "chain.toml" in message and key in message and f"{high:g}" in message
    with pytest.raises(ModelError, match=key):
        with_machine_key(key, float("nan"))
