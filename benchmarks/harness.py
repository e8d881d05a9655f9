"""Timing with repeats, result rows, the printed table and the JSON file."""
import json
import platform
import time
from dataclasses import asdict, dataclass

import numpy as np


@dataclass
class Row:
    """One measured figure; `baseline` is the anchor measured in the same run, `target` the goal."""
    name: str
    value: float
    unit: str
    baseline: float | None = None
    baseline_name: str = ''
    target: str = ''
    met: bool | None = None
    note: str = ''

    @property
    def ratio(self):
        if self.baseline is None or not self.value:
            return None
        # Ratios read "ours is N x better": time-like units shrink, rate-like units grow.
        better_low = self.unit.startswith(('us', 's', 'ms', '%'))
        return self.baseline / self.value if better_low else self.value / self.baseline


def best_time(fn, repeats=5, number=1):
    """The best wall time of `number` calls of fn, over `repeats` runs (the least disturbed one)."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(number):
            fn()
        times.append((time.perf_counter() - start) / number)
    return min(times)


def machine():
    import os
    return {'python': platform.python_version(), 'machine': platform.machine(), 'cpus': os.cpu_count(),
            'processor': _cpu_model(), 'numpy': np.__version__}


def _cpu_model():
    try:
        with open('/proc/cpuinfo') as f:
            return next(line.split(':', 1)[1].strip() for line in f if line.startswith('model name'))
    except (OSError, StopIteration):
        return platform.processor()


def print_table(rows):
    head = f'{"benchmark":70} {"value":>12} {"unit":12} {"anchor":>12} {"ratio":>8}  target'
    print(head)
    print('-' * len(head))
    for r in rows:
        base = f'{r.baseline:12.4g}' if r.baseline is not None else ' ' * 12
        ratio = f'{r.ratio:7.1f}x' if r.ratio is not None else ' ' * 8
        mark = '' if r.met is None else (' ok' if r.met else ' MISSED')
        print(f'{r.name:70} {r.value:12.4g} {r.unit:12} {base} {ratio}  {r.target}{mark}')
        if r.note:
            print(f'{"":72}{r.note}')


def write_json(rows, path):
    data = {'machine': machine(), 'results': [dict(asdict(r), ratio=r.ratio) for r in rows]}
    with open(path, 'w') as f:
        json.dump(data, f, indent=2)
