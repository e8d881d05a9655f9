"""The position-dependent inductance L(x), added through the physics layer alone (one file in
emla_core/physics/effects/): simulated by the plant, named by the discrepancy workflow on data from the
independent test plant (which models it its own way, L0 exp(a (x - xc))), carried by the model file, and
refused with its reasons online and by the inverse law."""
import math

import numpy as np
import pytest
from independent_plant import record
from scipy.integrate import solve_ivp

from emla_core.errors import InputError
from emla_core.model_file import Model, ModelEffect, read, write
from emla_core.parameters import TABLE1
from emla_core.physics import EFFECTS, PositionInductance
from emla_identification.discrepancy import diagnose
from emla_identification.online_effects import columns_for
from emla_sim.plant import Plant

TS = 1e-4


def test_the_plant_follows_the_flux_linkage_equations_as_an_independent_integrator_does():
    """psi = L(x) I + Km x: L(x) dI/dt = u - R I - Km v - I L'(x) v, m dv/dt = Km I + I^2 L'(x)/2 - B v - Fl,
    integrated by scipy's DOP853 at tight tolerances, against the plant's RK4 through the effect's hooks."""
    effect = PositionInductance(inductance_slope=0.2, inductance_curvature=40.0, center=1e-3)
    p = TABLE1.replace(load_force=0.5)
    voltages = 12.0 * np.sign(np.sin(2 * np.pi * np.arange(200) / 80.0)) + 3.0

    def rhs(t, z, u):
        i, x, v = z
        d = x - effect.center
        inductance = p.inductance + effect.inductance_slope * d + effect.inductance_curvature * d * d
        slope = effect.inductance_slope + 2.0 * effect.inductance_curvature * d
        di = (u - p.resistance * i - p.emf_constant * v - i * slope * v) / inductance
        dv = (p.emf_constant * i + 0.5 * i * i * slope - p.damping * v - p.load_force) / p.mass
        return [di, v, dv]

    z, expected = [0.0, 0.0, 0.0], []
    for u in voltages:
        z = solve_ivp(rhs, (0.0, TS), z, args=(u,), method='DOP853', rtol=1e-11, atol=1e-14).y[:, -1]
        expected.append(z)
    expected = np.array(expected)
    out = Plant(p, [effect]).run(voltages, TS)
    assert np.max(np.abs(out['current'] - expected[:, 0])) < 1e-7 * np.max(np.abs(expected[:, 0]))
    assert np.max(np.abs(out['position'] - expected[:, 1])) < 1e-7 * np.max(np.abs(expected[:, 1]))
    # the force the plant reports is the co-energy's: Km I + I^2 L'(x) / 2
    slope = effect.inductance_slope + 2.0 * effect.inductance_curvature * (out['position'] - effect.center)
    np.testing.assert_allclose(out['force'], p.emf_constant * out['current'] + 0.5 * out['current'] ** 2 * slope,
                               rtol=1e-12)


@pytest.mark.parametrize('seed', [1, 2])
def test_the_discrepancy_workflow_names_it_on_independent_data(seed):
    rec, truth = record(effects=['position_inductance'], seed=seed)
    result = diagnose(rec).to_dict()
    assert result['missing_effect'] == 'position_inductance', result['candidates']
    assert result['verdict'] == 'explained'
    # L'(x) = a L0 exp(a (x - xc)) at the record's mean position, where the candidate's polynomial is centred
    growth, center = 40.0, 1.25e-3   # the independent plant's defaults
    slope = growth * truth['inductance'] * math.exp(growth * (np.mean(rec.signals['position']) - center))
    fitted, std = result['added_parameters']['inductance_slope'], result['effects'][0]['std']['inductance_slope']
    assert fitted == pytest.approx(slope, rel=0.03)
    assert abs(fitted - slope) < 4 * std + 0.01 * slope


def test_the_model_file_carries_it_to_the_plant_and_the_online_identifier_and_law_refuse_it(tmp_path):
    model = Model(TS, {k: (v, None) for k, v in TABLE1.physical().items()},
                  [ModelEffect('position_inductance', 'position_inductance',
                               {'inductance_slope': (0.06, 3e-4), 'inductance_curvature': (1.0, 0.5)},
                               {'center': 1e-3})], {'data': 'x', 'command': 'test'})
    write(model, tmp_path / 'm.yaml')
    back = read(tmp_path / 'm.yaml')
    (effect,) = back.plant_effects()
    assert effect == PositionInductance(inductance_slope=0.06, inductance_curvature=1.0, center=1e-3)
    assert effect.compensation() == {} and EFFECTS['position_inductance'].control_refusal
    with pytest.raises(InputError, match='position_inductance .an inductance term has no place'):
        columns_for(['position_inductance'], 0.999)
