"""An inductance term bends the current's path through an interval (rows.Rows._bent): a coil saturating to half
its inductance doubles the current's rate and its bend by L/R, so the candidate columns must take l dI/dt on the
path the fitted inductance gives, not on the nominal model's. Checked on nearly noise-free records of the
independent plant (tests/independent_plant.py, RK4, no code shared with the suite), at the true saturation
current: R, Km and m come back within 0.001-0.01 % at 20 and 5 kHz and 0.2 % at 2 kHz, where the path at the
model's own L left them 0.07-0.4 % off at 20 kHz and 0.8-1.9 % at 5 kHz (20 kHz: hundreds of sigmas without noise,
4-5 with the sweep's, case 225). The path starts at the velocity that meets the measured end position, and where
the coil's least L/R is short beside the sample period its terms are taken on more parts (rows.Rows.parts; at
2 kHz here, L/R at its least is a twelfth of the sample period: 64 parts, the most)."""
import pytest
from independent_plant import record

from emla_core.physics.effects.inductance_saturation import InductanceSaturation
from emla_identification.discrepancy.data import Data
from emla_identification.discrepancy.fit import fit

VOICE_COIL = {'resistance': 6.0, 'inductance': 0.9e-3, 'emf_constant': 6.0, 'mass': 0.02, 'damping': 1.5,
              'load_force': 0.0}   # L/R 0.15 ms: three sample periods at 20 kHz


@pytest.mark.parametrize('rate, tolerance, quadratic_tolerance', [(20000.0, 2e-4, 0.01), (5000.0, 2e-4, 0.01),
                                                                  (2000.0, 5e-3, 0.02)])
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
