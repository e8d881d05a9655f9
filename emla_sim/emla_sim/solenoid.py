"""The solenoid plant and its open-loop recordings (docs/physics.md §9).

SolenoidPlant advances the circuit's current M_c (the coil current I without eddy currents: physics.solenoid), the
armature position x and velocity v over zero-order-hold voltage intervals by RK4 sub-steps of at most
plant.MAX_SUBSTEP, compiled (emla_core.physics.solenoid.solenoid_sequence,
whose right-hand side is equations.coil_rates with the solenoid's l, e, F), with inelastic end stops.
`excitation` is a voltage that moves the armature across its stroke at a bias current of 1-3 A, and `record`
samples the plant under it with emla_sim.Sensor, in the moving coil's recording form (voltage, current,
position; the true parameters in the metadata).
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from emla_core.physics.solenoid import SolenoidParameters, coil_current, solenoid_sequence
from emla_core.recording import Recording

from .plant import MAX_SUBSTEP
from .sensor import Sensor, SensorConfig

DWELL = (3e-3, 12e-3)    # s: how long each voltage level of the excitation is held (uniform)
# A: the steady currents the levels ask for, uniform in one of these bands, each band equally often: the bias
# band in which the armature of SolenoidParameters() floats between its stops (1.06-1.43 A: the spring balances
# the force), the bias band that pulls it shut (up to 3 A) and the drop that releases it (below 0.6 A).
LEVELS = ((1.0, 1.45), (1.45, 3.0), (0.0, 0.5))


class SolenoidPlant:
    """A solenoid from rest at `initial_state` = (I, x, v) (default: no current, armature on its lower stop; a
    current there as if held by the voltage R I).

    Parameters
    ----------
    params : SolenoidParameters
        The actuator.
    initial_state : sequence of float, optional
        (I in A, x in m, v in m/s).
    substeps : int, optional
        RK4 sub-steps per interval (default: ceil(dt / MAX_SUBSTEP)).
    """

    def __init__(self, params: SolenoidParameters | None = None, *, initial_state: Sequence[float] | None = None,
                 substeps: int | None = None) -> None:
        self.params = params if params is not None else SolenoidParameters()
        state = tuple(initial_state) if initial_state is not None else (0.0, self.params.stroke_min, 0.0)
        if len(state) != 3:
            raise ValueError(f'initial_state is (current, position, velocity), got {state!r}')
        if substeps is not None and not (isinstance(substeps, int) and substeps >= 1):
            raise ValueError(f'substeps must be a positive integer or None, got {substeps!r}')
        self._state = np.array(state, dtype=float)   # (M_c, x, v): the circuit's current (I at rest, or without
        self._voltage = self.params.resistance * state[0]   # eddy currents) and the voltage held last
        self._substeps = substeps
        self._kernel = self.params.kernel_vector()
        self.time = 0.0

    current = property(lambda self: float(coil_current(self._state[0], self._voltage, self.params.resistance,
                                                       self.params.eddy_conductance)),
                       doc='Coil current I (A).')
    position = property(lambda self: float(self._state[1]), doc='Armature position x (m).')
    velocity = property(lambda self: float(self._state[2]), doc='Armature velocity v (m/s).')

    def step(self, voltage: float, dt: float) -> None:
        """Hold `voltage` (clipped to +-supply_voltage) over dt (s): one interval of the lockstep loop."""
        u = np.array([min(max(float(voltage), -self.params.supply_voltage), self.params.supply_voltage)])
        substeps = self._substeps or max(1, math.ceil(dt / MAX_SUBSTEP - 1e-9))
        self._state = solenoid_sequence(self._state, u, dt, substeps, self._kernel)[0, [4, 1, 2]]
        self._voltage = float(u[0])
        self.time += dt

    def change(self, **values: float) -> None:
        """From now on the plant has these parameters (SolenoidParameters fields), e.g. a warmer coil's
        resistance; its state is kept."""
        self.params = self.params.replace(**values)
        self._kernel = self.params.kernel_vector()

    def run(self, voltages: Sequence[float] | np.ndarray, dt: float, *, sampling: str = 'end') -> dict[str, np.ndarray]:
        """Apply a voltage sequence, one ZOH interval of dt per value (clipped to +-supply_voltage).

        Returns
        -------
        dict of numpy.ndarray
            time, voltage (as applied), current, position, velocity, force (the coil's co-energy force), as
            emla_sim.Plant.run: sampling='end' at the end of each interval, 'start' at its start.
        """
        if sampling not in ('end', 'start'):
            raise ValueError(f"sampling must be 'end' or 'start', got {sampling!r}")
        u = np.asarray(voltages, dtype=float)
        if u.ndim != 1 or np.isnan(u).any() or not dt > 0.0:
            raise ValueError('run needs a 1-D voltage sequence without NaN and dt > 0')
        supply = self.params.supply_voltage
        u = np.clip(u, -supply, supply)
        x = self._state[1]
        first = np.array([self.current, x, self._state[2], self.params.coil_force(x, self._state[0]),
                          self._state[0]])
        substeps = self._substeps or max(1, math.ceil(dt / MAX_SUBSTEP - 1e-9))
        rows = solenoid_sequence(self._state, u, dt, substeps, self._kernel)
        t0 = self.time
        if u.size:
            self._state, self._voltage = rows[-1, [4, 1, 2]], float(u[-1])
        self.time += u.size * dt
        if sampling == 'start':
            rows = np.vstack((first, rows[:-1]))[:u.size]
            times = t0 + dt * np.arange(u.size)
        else:
            times = t0 + dt * np.arange(1, u.size + 1)
        return dict(time=times, voltage=u, current=rows[:, 0].copy(), position=rows[:, 1].copy(),
                    velocity=rows[:, 2].copy(), force=rows[:, 3].copy())


def excitation(params: SolenoidParameters, duration: float, sample_period: float, seed: int = 0) -> np.ndarray:
    """A voltage (V per sample) that moves the armature across its stroke: levels R I_bias, I_bias uniform in a
    band of LEVELS drawn at random, each held a time uniform in DWELL."""
    rng = np.random.default_rng(seed)
    n = int(round(duration / sample_period))
    u = np.empty(n)
    k = 0
    while k < n:
        hold = max(1, int(round(rng.uniform(*DWELL) / sample_period)))
        u[k:k + hold] = params.resistance * rng.uniform(*LEVELS[rng.integers(len(LEVELS))])
        k += hold
    return u


def record(params: SolenoidParameters | None = None, duration: float = 2.0, *, sample_period: float = 1e-4,
           seed: int = 0, current_noise: float = 5e-3, resolution: float = 1e-6) -> tuple[Recording, dict]:
    """(Recording of voltage, current, position; the plant's true values) of the solenoid under `excitation`.

    Parameters
    ----------
    params : SolenoidParameters, optional
        The actuator (default: SolenoidParameters()).
    duration, sample_period : float
        s.
    seed : int
        Of the excitation and the sensor noise.
    current_noise, resolution : float
        The sensor's Gaussian current noise (A) and position quantisation step (m).

    Returns
    -------
    (Recording, dict)
        The measured record (its metadata `true_<name>` of SolenoidParameters.identified()) and the true
        signals {'current', 'position', 'voltage'}, sampled like it.
    """
    params = params if params is not None else SolenoidParameters()
    u = excitation(params, duration, sample_period, seed)
    truth = SolenoidPlant(params).run(u, sample_period, sampling='start')
    sensor = Sensor(SensorConfig(sample_period=sample_period, current_noise_std=current_noise,
                                 position_resolution=resolution, seed=seed))
    current, position = sensor.measure(truth['current'], truth['position'])
    metadata = {'actuator': 'solenoid', **{f'true_{k}': repr(v) for k, v in params.identified().items()}}
    recording = Recording(sample_period, {'voltage': truth['voltage'], 'current': current, 'position': position},
                          source='solenoid simulation', metadata=metadata)
    return recording, {name: truth[name] for name in ('voltage', 'current', 'position')}
