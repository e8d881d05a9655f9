"""An inductance term bends the current's path through an interval (rows.Rows._bent): a coil saturating to half
its inductance doubles the current's rate and its bend by L/R, so the candidate columns must take l dI/dt on the
path the fitted inductance gives, not on the nominal model's. Checked on nearly noise-free records of the
independent plant (tests/independent_plant.py, RK4, no code shared with the suite), at the true saturation
current: R, Km and m come back within 0.002-0.01 % at 20 kHz and 0.01-0.1 % at 5 kHz, where the path at the model's
own L left them 0.07-0.4 % and 0.8-1.9 % off (20 kHz: hundreds of sigmas without noise, 4-5 with the sweep's,
case 225). What is left at 5 kHz is the pieces' quadrature of a current bending within a sample period (L/R = 1.3
sample periods; docs/physics.md 6.3)."""
import pytest
from independent_plant import record

from emla_core.physics.effects.inductance_saturation import InductanceSaturation
from emla_identification.discrepancy.data import Data
from emla_identification.discrepancy.fit import fit

VOICE_COIL = {'resistance': 6.0, 'inductance': 0.9e-3, 'emf_constant': 6.0, 'mass': 0.02, 'damping': 1.5,
              'load_force': 0.0}   # L/R 0.15 ms: three sample periods at 20 kHz


@pytest.mark.parametrize('rate, tolerance, quadratic_tolerance', [(20000.0, 2e-4, 0.01), (5000.0, 2e-3, 0.05)])
def test_a_saturating_coil_fitted_at_its_saturation_current_gives_back_the_nominal_parameters(rate, tolerance,
                                                                                            quadratic_tolerance):
    saturation = 2.5   # A: L falls to a third at the loop's 4 A peaks
    effects = [('inductance_saturation', {'saturation_current': saturation})]
    recording, _ = record(0.5, params=VOICE_COIL, effects=effects, seed=3, current_noise=1e-6,
                          resolution=1e-9, sample_period=1.0 / rate, substeps=8)
    data = Data.from_recording(recording)
    candidate = InductanceSaturation.candidate().at(data, saturation)
    result = fit(data, [candidate], fit(data))
    for name in ('resistance', 'emf_constant', 'mass'):
        assert result.parameters[name] == pytest.approx(VOICE_COIL[name], rel=tolerance), name
    quadratic = -VOICE_COIL['inductance'] / saturation ** 2
    assert result.added[0] == pytest.approx(quadratic, rel=quadratic_tolerance)
