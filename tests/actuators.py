"""The actuators the tests and the discrepancy sweep draw parameters around (SI: ohm, H, V s/m, kg, N s/m, N),
each held by tests/independent_plant.py's loop within +-30 %. No suite import here: the sweep reads it before it
chooses which code to measure (--code)."""

ACTUATORS = {
    'table1': {'resistance': 4.0, 'inductance': 1.6e-3, 'emf_constant': 10.8, 'mass': 0.036, 'damping': 2.0,
               'load_force': 0.0},   # near the paper's Table 1 (independent_plant's NOMINAL)
    'independent_data': {'resistance': 3.2, 'inductance': 2.1e-3, 'emf_constant': 8.5, 'mass': 0.05,
                         'damping': 3.0, 'load_force': 0.0},   # tests/independent_data.TRUTH
    'voice_coil': {'resistance': 6.0, 'inductance': 0.9e-3, 'emf_constant': 6.0, 'mass': 0.02, 'damping': 1.5,
                   'load_force': 0.0},   # a small, fast voice coil (L/R 0.15 ms)
    'linear_motor': {'resistance': 2.5, 'inductance': 3.0e-3, 'emf_constant': 15.0, 'mass': 0.12, 'damping': 5.0,
                     'load_force': 0.0},  # a heavier moving-coil motor (L/R 1.2 ms)
}
