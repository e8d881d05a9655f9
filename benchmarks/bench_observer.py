"""The solenoid's sensorless position (emla_identification.solenoid_observer): the causal filter per sample, frame
by frame as the identifier node runs it, and the offline filter plus smoother, on the suite's simulated valve at
5 kHz; against the sample period it must keep up with."""
from benchmarks.harness import Row, best_time
from emla_core.physics.solenoid import SolenoidParameters
from emla_identification.solenoid_observer import PositionObserver, observe_position
from emla_sim.solenoid import record

PERIOD = 2e-4        # s: 5 kHz
FRAME = 50           # samples per frame at 5 kHz in the ROS graph (10 ms)


def run():
    params = SolenoidParameters(stroke_min=0.0, stroke_max=1.2e-3)
    recording, _ = record(params, duration=1.0, sample_period=PERIOD, seed=0)
    u, i = recording.signals['voltage'], recording.signals['current']
    samples = len(u)
    observe_position(params, PERIOD, u[:100], i[:100], current_noise=5e-3)   # compile outside the timing

    def causal():
        observer = PositionObserver(params, PERIOD, current_noise=5e-3)
        for k in range(0, samples, FRAME):
            observer.update(u[k:k + FRAME], i[k:k + FRAME])

    t_causal = best_time(causal, repeats=3) / samples * 1e6
    t_offline = best_time(lambda: observe_position(params, PERIOD, u, i, current_noise=5e-3), repeats=3) \
        / samples * 1e6
    period = PERIOD * 1e6
    return [Row(f'solenoid position observer, causal, frames of {FRAME}', t_causal, 'us/sample', period,
                '5 kHz sample period', '<= 25 % of the period', t_causal <= 0.25 * period),
            Row('solenoid position observer, offline (filter + smoother)', t_offline, 'us/sample', period,
                '5 kHz sample period')]
