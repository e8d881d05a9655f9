"""Closed-loop test data the identification code has never seen.

The plant (emla_sim.Plant, exact ZOH or RK4 with effects) runs at 10 kHz under a PID position controller
on the sensed position (voltage clipped to the supply) tracking a square-wave stroke, optionally with a
small voltage dither; emla_sim.Sensor adds 5 mA current noise and 1 um position quantisation.
"""
from collections.abc import Iterable

import numpy as np

from emla_core.parameters import PARAMETER_NAMES, TABLE1, ActuatorParameters
from emla_core.physics import Effect
from emla_core.recording import Recording
from emla_sim.effects import ParameterChange
from emla_sim.plant import Plant
from emla_sim.sensor import Sensor, SensorConfig

# Gains for Table 1 (about 200 Hz position bandwidth); they stay stable for +-30 % parameters and m x 2.
KP = 15000.0  # V/m
KI = 2.0e5    # V/(m s)
KD = 30.0     # V s/m


# The paper's Table 2 simulation conditions (physics.md), as changes to Table 1.
TABLE2 = [dict(mass=m) for m in (0.036, 0.054, 0.072)] \
    + [dict(load_force=f) for f in (10.0, -10.0, 20.0, -20.0)] \
    + [dict(damping=b) for b in (3.0, 4.0)] \
    + [dict(mass=0.072, load_force=f, damping=b) for f, b in ((20.0, 2.0), (-20.0, 4.0), (10.0, 3.0))]


def true_metadata(params):
    """Bag/recording metadata with the true parameters: {'true_resistance': '4.0', ...}."""
    return {f'true_{name}': repr(value) for name, value in params.physical().items()}


def closed_loop(params: ActuatorParameters = TABLE1, duration: float = 1.0, *, effects: Iterable[Effect | str] = (),
                changes: Iterable[ParameterChange] = (), stroke: float = 3e-3, period: float = 0.04,
                dither: float = 0.0, seed: int = 0, sample_period: float = 1e-4, current_noise: float = 5e-3,
                resolution: float = 1e-6) -> tuple[Recording, ActuatorParameters]:
    """(Recording of t, voltage, current, position; the true ActuatorParameters at the start).

    effects, changes: as for emla_sim.plant.Plant (e.g. a ParameterChange of the resistance mid-run).
    """
    ts = sample_period
    plant = Plant(params, effects, changes)
    sensor = Sensor(SensorConfig(sample_period=ts, current_noise_std=current_noise,
                                 position_resolution=resolution, seed=seed))
    rng = np.random.default_rng(seed + 1)
    n = int(round(duration / ts))
    noise = dither * rng.standard_normal(n)
    supply = params.supply_voltage
    voltage, current, position = np.empty(n), np.empty(n), np.empty(n)
    integral = previous = 0.0
    for k in range(n):
        current[k], position[k] = sensor.measure(plant.current, plant.position)
        reference = stroke if (k * ts) % period < period / 2 else 0.0
        error = reference - position[k]
        integral += error * ts
        speed = (position[k] - previous) / ts if k else 0.0
        previous = position[k]
        u = min(max(KP * error + KI * integral - KD * speed + noise[k], -supply), supply)
        voltage[k] = u
        plant.step(u, ts)
    recording = Recording(ts, {'voltage': voltage, 'current': current, 'position': position},
                          source='closed-loop simulation', metadata=true_metadata(params))
    return recording, params


def random_parameters(rng, spread=0.3, **fixed):
    """Table 1 with R, L, Km, m, B each scaled by a uniform factor in 1 +- spread; `fixed` values set."""
    factors = {name: rng.uniform(1 - spread, 1 + spread)
               for name in PARAMETER_NAMES if name != 'load_force'}
    return TABLE1.scaled(**factors).replace(**fixed)


def force_driven(mass: float = 0.036, damping: float = 2.0, load_force: float = 0.0, duration: float = 1.0, *,
                 seed: int = 0, sample_period: float = 1e-4, force_noise: float = 0.05, resolution: float = 1e-6,
                 lines: int = 8, band: tuple[float, float] = (20.0, 100.0)) -> tuple[Recording, dict[str, float]]:
    """Mechanical-only data (t, force, position) of a mass driven by a measured force, from the exact solution.

    m v' = F - B v - Fl with F = Fl + sum of `lines` sines in `band` Hz (random phases; 3 N each), from
    rest at x = 0; the force is measured with Gaussian noise, the position quantised.
    """
    rng = np.random.default_rng(seed)
    omega = 2 * np.pi * rng.uniform(*band, lines)
    phase = rng.uniform(0, 2 * np.pi, lines)
    amplitude = np.full(lines, 3.0)
    t = sample_period * np.arange(int(round(duration / sample_period)))
    impedance = np.hypot(damping, mass * omega)
    lag = np.arctan2(mass * omega, damping)
    tau = mass / damping
    arg = np.outer(t, omega) + phase - lag
    c = -np.sum(amplitude / impedance * np.sin(phase - lag))  # v(0) = 0
    position = (np.sum(amplitude / (impedance * omega) * (np.cos(phase - lag) - np.cos(arg)), axis=1)
                + c * tau * (1 - np.exp(-t / tau)))
    force = load_force + np.sum(amplitude * np.sin(np.outer(t, omega) + phase), axis=1)
    force = force + force_noise * rng.standard_normal(len(t))
    position = np.floor(position / resolution + 0.5) * resolution if resolution else position
    truth = {'mass': mass, 'damping': damping, 'load_force': load_force}
    recording = Recording(sample_period, {'force': force, 'position': position}, source='force-driven mass',
                          metadata={f'true_{k}': repr(v) for k, v in truth.items()})
    return recording, truth
