"""Issue 22 on the independent plant (tests/independent_plant.py) through the sweep's own cases
(scripts/discrepancy_sweep/, by seed): a dry friction whose stuck contact damps the motion (LuGre's
micro-damping) closes to its noise floor with the mass and damping re-identified within 3 sigma; records from which
the nominal model alone cannot be identified (a strong magnetic stiffness, a current sensor three samples late at
3 kHz) are diagnosed from the start an effect gives instead of refused."""
import pytest

from emla_core.model_file import read
from scripts import discrepancy_sweep as sweep


def _case(seed):
    result = sweep.run_case(sweep.make_case(seed), report=False)
    assert result['error'] is None, result.get('traceback')
    return result


def test_a_dry_friction_with_a_damped_stuck_contact_closes():
    """Seed 101: 0.094 N of dry friction on a 0.12 kg linear motor at 3 kHz, its contact critically damped over
    2 um (sigma1 = 2 sqrt(m Fc / delta) = 149 N s/m): without the damping term the mechanical residual stayed 48
    times its floor; with it, explained, Fc within 3 %, m and B within 3 sigma."""
    r = _case(101)
    assert r['verdict'] == 'explained' and r['named'] == ['coulomb_friction'], r['candidates']
    truth = r['case']['effects']['coulomb_friction']['force']
    assert r['effect_parameters']['coulomb_force']['value'] == pytest.approx(truth, rel=0.03)
    assert r['effect_parameters']['presliding_damping']['value'] == pytest.approx(149.0, rel=0.15)
    assert all(abs(r['nominal_sigma'][name]) < 3.0 for name in ('mass', 'damping')), r['nominal_sigma']


@pytest.mark.parametrize('seed, hidden', [(81, 'magnetic_stiffness'), (38, 'sensor_delay')])
def test_a_record_the_nominal_model_alone_cannot_fit_is_diagnosed(seed, hidden):
    """Seed 81: a 1100 N/m magnetic stiffness on a voice coil at 3 kHz (the grey-box nominal gives a negative
    inductance); seed 38: the current three samples late at 3 kHz (a negative resistance). Both raised 'cannot be
    identified'; now the start comes from the effect, the verdict is explained and the nominal parameters are
    within 3 sigma."""
    r = _case(seed)
    assert r['verdict'] == 'explained' and hidden in r['named'], r['candidates']
    assert any('cannot be identified' in w for w in r['warnings'])
    assert all(abs(s) < 3.0 for s in r['nominal_sigma'].values()), r['nominal_sigma']


def test_a_model_file_from_before_the_friction_damping_reads_it_as_zero(tmp_path):
    path = tmp_path / 'old.yaml'
    path.write_text('emla_model: 1\nsample_period: 1e-4\nparameters: {mass: 0.036, damping: 2.0, load_force: 0.0}\n'
                    'effects: [{effect: coulomb_friction, '
                    'parameters: {coulomb_force: {value: 1.0, std: 0.01}}}]\n')
    effect = read(path).effects[0]
    assert effect.parameters == {'coulomb_force': (1.0, 0.01), 'presliding_damping': (0.0, None)}


def test_a_delay_beside_a_missing_spring_is_not_scored_on_its_misfit_read_as_noise():
    """Seed 205: a 1577 N/m return spring and the current one sample late at 3 kHz. The nominal model alone is
    impossible (a negative resistance) and comes from the delay's start. Against it the delay was searched to
    2.84 samples with the spring missing; the noise levels fitted to that fit's residual (235 mA for 5) put more
    into its held-out error than it held, and taking that off scored the worst fit 2.0 (nothing named). Now such
    levels are not the fit's noise (noise.noise_known): the spring is named, then the delay at one sample."""
    r = _case(205)
    assert r['verdict'] == 'explained' and sorted(r['named']) == ['return_spring', 'sensor_delay'], r['candidates']
    delay = r['effect_parameters']['current_delay']
    assert delay['within'], delay
    assert abs(delay['value'] / delay['truth'] - 1.0) < 0.01, delay
