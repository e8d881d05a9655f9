"""The in-process closed loop at 10 kHz (plant + sensor + identifier + adaptive controller), in simulated
seconds per wall second, against the same loop without the identifier (its share of the cost)."""
import dataclasses

from benchmarks.harness import Row, best_time
from emla_bench import scenarios

DURATION = 2.0  # s simulated


def run():
    adaptive = scenarios.get('default')
    fixed = dataclasses.replace(adaptive, cases={'fixed': (False, False)})
    adaptive.run_case('adaptive', duration=0.05)   # compile outside the timing
    t_adaptive = best_time(lambda: adaptive.run_case('adaptive', duration=DURATION), repeats=3)
    t_fixed = best_time(lambda: fixed.run_case('fixed', duration=DURATION), repeats=3)
    speed = DURATION / t_adaptive
    return [
        Row(f'closed loop in-process, 10 kHz, adaptive ({adaptive.frame_samples}-sample frames)', speed,
            'x real time', target='>= 10x', met=speed >= 10,
            note=f'without identifier/adaptation: {DURATION / t_fixed:.1f}x real time'),
    ]
