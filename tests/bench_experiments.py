"""The experiments a user runs first on a moving-coil bench, generated independently of emla_sim.

The actuator (SI units; state coil current I, position x, velocity v), linear and time-invariant:

    L dI/dt = u - R I - Km v,      m dv/dt = Km I - B v - k (x - x_c) - Fl,      dx/dt = v

integrated exactly over each zero-order-hold interval of the voltage: z_k+1 = expm(M Ts) applied to
[z_k, u_k, 1] (scipy.linalg.expm of the augmented matrix), so the record holds no integration error at all.
k = 0 is an actuator without a spring.

Experiments (`open_loop_steps`, `encoder_loop`):
  open_loop_steps   the voltage a random level in +-`level` held for a random 2-40 ms, no feedback: the spring
                    holds the coil at k x = Km I, the steps ring about it.
  encoder_loop      a PD position loop on a plain encoder (quantised to `resolution`, no noise beneath it)
                    tracking a square-wave stroke, its derivative the encoder's difference over one period;
                    the logged voltage carries `voltage_noise` (a logger's ADC), the applied one not.

The samples at t_k = k Ts: the current plus Gaussian noise `current_noise`, the position quantised to
`resolution` (plus Gaussian `position_noise` before quantising), the voltage held over [t_k, t_k+1).
Everything random comes from one numpy Generator: a seed gives the same record every time.

    rec, truth = open_loop_steps(rate=2000.0, duration=3.0, spring=2000.0, seed=1)
"""
import numpy as np
from scipy.linalg import expm

from emla_core.recording import Recording

ACTUATOR = {'resistance': 4.0, 'inductance': 1.6e-3, 'emf_constant': 10.8, 'mass': 0.036, 'damping': 2.0,
            'load_force': 0.0}
SUPPLY = 24.0     # V


def _transition(p, spring, center, ts):
    """(Phi, gamma): z_k+1 = Phi z_k + gamma u_k + the constant forces' response (gamma's last column)."""
    r, ind, km, m, b, fl = (p[n] for n in ('resistance', 'inductance', 'emf_constant', 'mass', 'damping',
                                            'load_force'))
    a = np.zeros((5, 5))
    a[0, :3] = (-r / ind, 0.0, -km / ind)
    a[0, 3] = 1.0 / ind
    a[1, 2] = 1.0
    a[2, :3] = (km / m, -spring / m, -b / m)
    a[2, 4] = (spring * center - fl) / m
    e = expm(a * ts)
    return e[:3, :3], e[:3, 3], e[:3, 4]


def _sensed(z, rng, current_noise, position_noise, resolution):
    current = z[:, 0] + current_noise * rng.standard_normal(len(z))
    position = z[:, 1] + position_noise * rng.standard_normal(len(z))
    if resolution:
        position = resolution * np.round(position / resolution)
    return current, position


def _recording(t_s, voltage, current, position, truth, source):
    return Recording(sample_period=t_s, signals={'voltage': voltage, 'current': current, 'position': position},
                     source=source, metadata={f'true_{k}': v for k, v in truth.items()})


def open_loop_steps(*, rate=2000.0, duration=3.0, spring=2000.0, center=0.0, level=3.0, hold=(2e-3, 40e-3),
                    params=None, current_noise=1e-3, position_noise=0.0, resolution=1e-6, seed=0):
    """(Recording, truth) of open-loop voltage steps on a sprung actuator (see the module doc)."""
    rng = np.random.default_rng(seed)
    p = dict(ACTUATOR, **(params or {}))
    ts = 1.0 / rate
    n = int(round(duration * rate))
    voltage = np.empty(n)
    k = 0
    while k < n:
        held = max(1, int(round(rng.uniform(*hold) / ts)))
        voltage[k:k + held] = rng.uniform(-level, level)
        k += held
    phi, gamma, constant = _transition(p, spring, center, ts)
    z = np.empty((n, 3))
    state = np.array([0.0, center - p['load_force'] / spring if spring else 0.0, 0.0])
    for j in range(n):
        z[j] = state
        state = phi @ state + gamma * voltage[j] + constant
    current, position = _sensed(z, rng, current_noise, position_noise, resolution)
    truth = dict(p, spring_stiffness=spring)
    return _recording(ts, voltage, current, position, truth, f'open_loop_steps(seed={seed})'), truth


def encoder_loop(*, rate=10000.0, duration=10.0, resolution=1e-6, stroke=2e-3, period=0.08, kp=8000.0, kd=40.0,
                 voltage_noise=0.01, current_noise=0.0, params=None, spring=0.0, seed=0):
    """(Recording, truth) of a PD position loop on a plain encoder (see the module doc)."""
    rng = np.random.default_rng(seed)
    p = dict(ACTUATOR, **(params or {}))
    ts = 1.0 / rate
    n = int(round(duration * rate))
    phi, gamma, constant = _transition(p, spring, 0.0, ts)
    t = np.arange(n) * ts
    reference = np.where((t % period) < period / 2, stroke, 0.0)
    z = np.empty((n, 3))
    applied = np.empty(n)
    state = np.zeros(3)
    before = 0.0
    for j in range(n):
        z[j] = state
        sensed = resolution * np.round(state[1] / resolution)
        u = kp * (reference[j] - sensed) - kd * (sensed - before) / ts
        applied[j] = min(max(u, -SUPPLY), SUPPLY)
        before = sensed
        state = phi @ state + gamma * applied[j] + constant
    current, position = _sensed(z, rng, current_noise, 0.0, resolution)
    voltage = applied + voltage_noise * rng.standard_normal(n)
    truth = dict(p, spring_stiffness=spring)
    return _recording(ts, voltage, current, position, truth, f'encoder_loop(seed={seed})'), truth
