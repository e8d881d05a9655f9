"""DSP-like sampling of the coil current and the position.

Per sample: a delay line of `delay_samples` samples (both signals; before the line has filled it repeats the
first sample), then additive Gaussian noise, then position quantisation to the nearest multiple of
`position_resolution` (the LSB; round half up). The noise comes from numpy.random.default_rng(seed), drawn in
fixed blocks, so a seed gives the same measurements whether the samples are measured one by one or in arrays.
"""
import collections
import dataclasses
import math

import numpy as np

_BLOCK = 4096  # standard normals drawn at a time


@dataclasses.dataclass
class SensorConfig:
    sample_period: float = 1e-4  # s
    current_noise_std: float = 5e-3  # A
    position_resolution: float = 1e-6  # m (LSB); 0 = no quantisation
    position_noise_std: float = 0.0  # m, added before quantisation
    delay_samples: int = 0
    seed: int = 0

    def __post_init__(self):
        if not self.sample_period > 0.0:
            raise ValueError(f'SensorConfig.sample_period must be positive, got {self.sample_period!r}')
        for name in ('current_noise_std', 'position_resolution', 'position_noise_std'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f'SensorConfig.{name} must be finite and >= 0, got {value!r}')
        if isinstance(self.delay_samples, bool) or int(self.delay_samples) != self.delay_samples \
                or self.delay_samples < 0:
            raise ValueError(f'SensorConfig.delay_samples must be an integer >= 0, got {self.delay_samples!r}')
        self.delay_samples = int(self.delay_samples)


class _NormalStream:
    """Standard normal numbers from one generator, the same sequence however they are requested."""

    def __init__(self, rng):
        self._rng, self._block, self._next = rng, [], 0

    def draw(self):
        if self._next == len(self._block):
            self._block, self._next = self._rng.standard_normal(_BLOCK).tolist(), 0
        self._next += 1
        return self._block[self._next - 1]

    def take(self, n):
        out = np.empty(n)
        filled = 0
        while filled < n:
            if self._next == len(self._block):
                self._block, self._next = self._rng.standard_normal(_BLOCK).tolist(), 0
            chunk = min(n - filled, len(self._block) - self._next)
            out[filled:filled + chunk] = self._block[self._next:self._next + chunk]
            self._next += chunk
            filled += chunk
        return out


class Sensor:
    """Measures (current, position) pairs: scalars one sample at a time or 1-D arrays of consecutive samples."""

    def __init__(self, config: SensorConfig | None = None) -> None:
        self.config = config if config is not None else SensorConfig()
        current_rng, position_rng = np.random.default_rng(self.config.seed).spawn(2)
        self._current_noise = _NormalStream(current_rng)
        self._position_noise = _NormalStream(position_rng)
        # the last delay_samples true (current, position) pairs
        self._line: collections.deque[tuple[float, float]] = collections.deque()

    def measure(self, current: float | np.ndarray,
                position: float | np.ndarray) -> tuple[float, float] | tuple[np.ndarray, np.ndarray]:
        """(current_measured, position_measured), floats for scalars, arrays for arrays."""
        if isinstance(current, (int, float)) and isinstance(position, (int, float)):
            return self._measure_one(float(current), float(position))
        currents, positions = np.broadcast_arrays(np.asarray(current, float), np.asarray(position, float))
        if currents.ndim == 0:
            return self._measure_one(float(currents), float(positions))
        if currents.ndim != 1:
            raise ValueError('Sensor.measure takes scalars or 1-D arrays of consecutive samples')
        currents, positions = self._delay_array(currents, positions)
        cfg = self.config
        if cfg.current_noise_std:
            currents = currents + cfg.current_noise_std * self._current_noise.take(currents.size)
        if cfg.position_noise_std:
            positions = positions + cfg.position_noise_std * self._position_noise.take(positions.size)
        if cfg.position_resolution:
            positions = np.floor(positions / cfg.position_resolution + 0.5) * cfg.position_resolution
        return currents, positions

    def _measure_one(self, current, position):
        cfg = self.config
        if cfg.delay_samples:
            if not self._line:
                self._line.extend([(current, position)] * cfg.delay_samples)
            self._line.append((current, position))
            current, position = self._line.popleft()
        if cfg.current_noise_std:
            current += cfg.current_noise_std * self._current_noise.draw()
        if cfg.position_noise_std:
            position += cfg.position_noise_std * self._position_noise.draw()
        if cfg.position_resolution and math.isfinite(position):   # a non-finite one as it is, as measure() does
            position = math.floor(position / cfg.position_resolution + 0.5) * cfg.position_resolution
        return current, position

    def _delay_array(self, currents, positions):
        d = self.config.delay_samples
        if not d or currents.size == 0:
            return currents, positions
        if not self._line:
            self._line.extend([(currents[0], positions[0])] * d)
        held = np.array(self._line, dtype=float).reshape(d, 2)
        all_currents = np.concatenate((held[:, 0], currents))
        all_positions = np.concatenate((held[:, 1], positions))
        self._line = collections.deque(zip(all_currents[-d:].tolist(), all_positions[-d:].tolist()))
        return all_currents[:currents.size], all_positions[:positions.size]
