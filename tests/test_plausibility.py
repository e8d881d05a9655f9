"""Plausibility and robust numerics (issue 19): a unit slip in a record (current in mA, voltage in mV, time in
ms, position in mm or um, none of them labelled) is warned about by name with the --units flag that fixes it,
by `emla identify`, `emla discrepancy` and `emla compare`; a negated sensor gets the advice for its root cause
only; clean data get no warning; extreme settings and data give one line, never a traceback, a NaN or an
impossible figure."""
import json
from types import SimpleNamespace

import numpy as np
import pytest
import scipy.io
from independent_data import TRUTH, simulate
from independent_plant import record

from emla_cli.cli import main
from emla_core.data import load
from emla_core.errors import InputError
from emla_identification.arx import identify_arx
from emla_identification.greybox import identify, parameter_scales, unit_scales
from emla_identification.plausibility import plausibility_warnings, unit_flag
from emla_identification.rls import RecursiveLeastSquares, forgetting_factor
from emla_sim.datasets import closed_loop, force_driven

SLIPS = {   # signal: (index in (t, voltage, current, position), factor, the flag that fixes it)
    'current in mA': (2, 1e3, '--units current=mA'),
    'voltage in mV': (1, 1e3, '--units voltage=mV'),
    'time in ms': (0, 1e3, '--units t=ms'),
    'position in mm': (3, 1e3, '--units position=mm'),
    'position in um': (3, 1e6, '--units position=um'),
}
FLIPS = {   # the signals negated: the one flag advised (negating current and position = negating the voltage)
    'current': ((2,), '--units current=-A'),
    'position': ((3,), '--units position=-m'),
    'voltage': ((1,), '--units voltage=-V'),
    'current and position': ((2, 3), '--units voltage=-V'),
}


@pytest.fixture(scope='module')
def clean():
    """(t, voltage, current, position) of the tests' independent actuator, in SI."""
    return simulate(duration=0.3)


def plain_csv(path, signals):
    """A CSV with the plain header t,voltage,current,position: no unit anywhere."""
    np.savetxt(path, np.column_stack(signals), delimiter=',', header='t,voltage,current,position', comments='',
               fmt='%.10g')
    return path


def changed(signals, indices, factor):
    return [s * factor if j in indices else s for j, s in enumerate(signals)]


def run(capsys, *args):
    """(exit status, JSON or None, stderr) of `emla ARGS` run in this process."""
    status = main([str(a) for a in args])
    out, err = capsys.readouterr()
    assert 'Traceback' not in err and 'nan' not in out.lower() and 'inf' not in out.replace('inputs', '')
    return status, (json.loads(out) if status == 0 and out else None), err


def warned(capsys, *args):
    """The JSON warnings of `emla ARGS`, checked against its stderr lines."""
    status, result, err = run(capsys, *args)
    assert status == 0, err
    lines = [line for line in err.splitlines() if ': warning: ' in line]
    assert [line.split(': warning: ', 1)[1] for line in lines] == result['warnings']
    return result['warnings']


@pytest.mark.parametrize('command', ['identify', 'discrepancy'])
@pytest.mark.parametrize('slip', list(SLIPS))
def test_a_unit_slip_is_warned_by_name_with_its_fix(clean, tmp_path, capsys, command, slip):
    index, factor, flag = SLIPS[slip]
    path = plain_csv(tmp_path / 'run.csv', changed(clean, (index,), factor))
    (warning,) = warned(capsys, command, path)
    name = slip.split()[0]
    assert flag in warning and f'the {name}' in warning and f'in {flag.split("=")[1]}?' in warning, warning


def test_an_int16_current_in_ma_in_a_mat_file(clean, tmp_path, capsys):
    t, voltage, current, position = clean
    scipy.io.savemat(tmp_path / 'scope.mat', {'time': t, 'coil_voltage': voltage, 'stroke': position,
                                              'coil_current': np.round(current * 1e3).astype(np.int16)})
    (warning,) = warned(capsys, 'identify', tmp_path / 'scope.mat', '--columns',
                        't=time,voltage=coil_voltage,current=coil_current,position=stroke')
    assert '--units current=mA' in warning


def test_clean_data_give_no_warning(clean, tmp_path, capsys):
    path = plain_csv(tmp_path / 'run.csv', clean)
    for command in ('identify', 'discrepancy'):
        assert warned(capsys, command, path) == []
    assert warned(capsys, 'identify', 'docs/examples/logger.csv') == []      # units from the header
    records = [load('bags/example_discrepancy'), load('bags/example_unexplained'), force_driven(duration=0.3)[0],
               record(duration=0.3, seed=3)[0], *(closed_loop(duration=0.3, dither=0.2, seed=s)[0] for s in range(3))]
    for recording in records:
        result = identify(recording)
        assert plausibility_warnings(result.parameters, result.std, recording) == [], recording.source


@pytest.mark.parametrize('flipped', list(FLIPS))
def test_a_negated_sensor_gets_the_advice_for_its_root_cause_only(clean, tmp_path, capsys, flipped):
    indices, flag = FLIPS[flipped]
    path = plain_csv(tmp_path / 'run.csv', changed(clean, indices, -1.0))
    (warning,) = warned(capsys, 'identify', path)
    assert flag in warning and warning.count('--units') == 1, warning
    fixed = warned(capsys, 'identify', path, '--units', flag.split()[1])
    assert fixed == []


def test_doing_both_old_advices_leaves_a_negative_force_constant_that_is_warned(clean, tmp_path, capsys):
    """A negated current once got "flip the current" and "flip the position"; doing both leaves the position
    negated: Km < 0 with everything else positive."""
    path = plain_csv(tmp_path / 'run.csv', changed(clean, (2,), -1.0))
    (warning,) = warned(capsys, 'identify', path, '--units', 'current=-A,position=-m')
    assert 'emf_constant' in warning and '--units position=m' in warning     # undo the position's flip


def test_the_advised_flag_keeps_the_unit_the_signal_was_read_in():
    assert unit_flag({'current': {'unit': 'mA', 'scale': 1e-3}}, 'current', -1) == '--units current=-mA'
    assert unit_flag({'current': {'unit': '-A', 'scale': -1.0}}, 'current', -1) == '--units current=A'
    assert unit_flag({}, 'position', 1e-6) == '--units position=um'
    assert unit_flag({}, 't', 1e-3) == '--units t=ms'


def test_compare_checks_the_data_against_the_model(clean, tmp_path, capsys):
    model = tmp_path / 'model.yaml'
    assert run(capsys, 'identify', plain_csv(tmp_path / 'run.csv', clean), '--model-out', model)[0] == 0
    assert warned(capsys, 'compare', tmp_path / 'run.csv', '--model-file', model) == []
    for slip, (index, factor, flag) in SLIPS.items():
        path = plain_csv(tmp_path / 'slip.csv', changed(clean, (index,), factor))
        (warning,) = warned(capsys, 'compare', path, '--model-file', model)
        assert flag in warning, (slip, warning)
    for flipped, (indices, flag) in FLIPS.items():   # the model's voltage balance on the data: a, b = -1
        path = plain_csv(tmp_path / 'flipped.csv', changed(clean, indices, -1.0))
        (warning,) = warned(capsys, 'compare', path, '--model-file', model)
        assert flag in warning and warning.count('--units') == 1, (flipped, warning)
    path = plain_csv(tmp_path / 'gain.csv', changed(clean, (2,), 10.0))    # a shunt's gain 10 times off
    (warning,) = warned(capsys, 'compare', path, '--model-file', model)
    assert 'the current reads 10 times what the model expects' in warning and '--units current=0.1' in warning
    for change in ({'resistance': 1.26}, {'mass': 3.0}, {'emf_constant': 2.0}):   # a model that does not fit
        mismatched = {k: v * change.get(k, 1.0) for k, v in TRUTH.items()}
        assert plausibility_warnings(mismatched, {}, load(tmp_path / 'run.csv'), identified=False) == []
    # a current 30 times too large for its voltage and the model's R: no magnitude alone shows that
    t, voltage, current, position = changed(clean, (2,), 30.0)
    slipped = SimpleNamespace(signals={'voltage': voltage, 'current': current, 'position': position},
                              sample_period=1e-4)
    (warning,) = plausibility_warnings({'resistance': TRUTH['resistance']}, {}, slipped, identified=False)
    assert 'R = 3.2 ohm needs' in warning and '--units current=mA' in warning


def test_a_time_in_ms_of_a_fast_record_is_seen_against_the_coils_time_constant():
    """100 kHz logged in ms: a sample period of 10 "s" is not slow enough to show, but the coil's L/R of
    0.66 ms (a model's, in compare) is a fifteenth of it."""
    fast = SimpleNamespace(signals={'position': np.array([0.0, 2e-3])}, sample_period=0.01)
    coil = {k: TRUTH[k] for k in ('resistance', 'inductance')}
    (warning,) = plausibility_warnings(coil, {}, fast, identified=False)
    assert 'whose L/R is 0.000656 s' in warning and '--units t=ms' in warning
    assert plausibility_warnings(coil, {}, SimpleNamespace(signals={}, sample_period=1e-4), identified=False) == []


def test_a_forgetting_factor_without_memory_is_one_line(clean, tmp_path, capsys):
    path = plain_csv(tmp_path / 'run.csv', clean)
    for args in (['--forgetting', '1e-300'], ['--forgetting', '1e-300', '--model', 'arx']):
        status, _, err = run(capsys, 'identify', path, *args)
        assert status == 2 and err.count('\n') == 1 and '--forgetting 1e-300' in err, err
    status, _, err = run(capsys, 'identify', path, '--memory-time', '1e-4')
    assert status == 2 and err.count('\n') == 1 and 'at least 2 sample periods' in err, err
    with pytest.raises(InputError, match='forgetting factor must be in'):
        identify(load(path), forgetting=1e-300)
    with pytest.raises(ValueError, match='memory 1/.1 - lambda. of at least 2 samples'):
        RecursiveLeastSquares(3, forgetting=0.3)
    assert forgetting_factor(0.5) == 0.5


@pytest.mark.parametrize('scales', [{'voltage': 1e-7, 'current': 1e-7, 'position': 1e-7}, {'position': 1e8},
                                    {'current': 1e-8}, {'t': 1e5}, {'voltage': 1e8, 't': 1e-4}])
def test_extreme_but_finite_data_are_identified_in_rescaled_units(clean, scales):
    """The regressions' prior and sums of squares are made for SI magnitudes; far from them the record is
    identified in rescaled units and the parameters scaled back by their dimensions."""
    t, voltage, current, position = clean
    base = identify(sample_period=1e-4, voltage=voltage, current=current, position=position)
    assert set(unit_scales(load_signals(clean)).values()) == {1.0}     # SI data: identified as they are
    s = dict.fromkeys(('t', 'voltage', 'current', 'position'), 1.0) | scales
    result = identify(sample_period=1e-4 * s['t'], voltage=voltage * s['voltage'], current=current * s['current'],
                      position=position * s['position'])
    factor = parameter_scales(list(base.parameters), s)
    for got, want, rtol in ((result.parameters, base.parameters, 1e-5), (result.std, base.std, 0.05)):
        np.testing.assert_allclose(np.array(list(got.values())) / factor, list(want.values()), rtol=rtol)
    assert result.sample_period == 1e-4 * s['t'] and result.trajectory.time[-1] == pytest.approx(
        base.trajectory.time[-1] * s['t'])


@pytest.mark.parametrize('su, sy', [(1e-90, 1e-90), (1e90, 1.0), (1.0, 1e-40)])
def test_extreme_but_finite_data_give_the_same_arx_model(clean, su, sy):
    _, voltage, current, _ = clean
    base, scaled = identify_arx(voltage, current, 2, 2, 1), identify_arx(voltage * su, current * sy, 2, 2, 1)
    np.testing.assert_allclose(scaled.a, base.a, rtol=1e-4)   # (the prior P0 weighs a little differently)
    np.testing.assert_allclose(scaled.b, base.b * sy / su, rtol=1e-4)
    assert scaled.fit_percent == pytest.approx(base.fit_percent, rel=1e-6)


def load_signals(signals):
    """A Recording of (t, voltage, current, position)."""
    from emla_core.recording import Recording
    return Recording(1e-4, dict(zip(('voltage', 'current', 'position'), signals[1:], strict=True)))


@pytest.mark.parametrize('index, factor, named', [(0, 1e-90, 'sample period'), (0, 1e90, 'sample period'),
                                                  (1, 1e50, 'voltage peaks'), (3, 1e-60, 'position peaks')])
def test_data_beyond_double_precision_are_one_line(clean, tmp_path, capsys, index, factor, named):
    path = plain_csv(tmp_path / 'run.csv', changed(clean, (index,), factor))
    model = tmp_path / 'model.yaml'
    assert run(capsys, 'identify', plain_csv(tmp_path / 'clean.csv', clean), '--model-out', model)[0] == 0
    for args in (['identify', path], ['discrepancy', path], ['compare', path, '--model-file', model]):
        status, _, err = run(capsys, *args)
        assert status == 2 and err.count('\n') == 1 and named in err and '--units' in err, err


def test_figures_that_cannot_be_computed_are_null_with_a_warning(clean, tmp_path, capsys):
    t, voltage, current, position = clean
    path = plain_csv(tmp_path / 'flat.csv', (t, voltage, np.full_like(current, 1.0), position))
    warnings = warned(capsys, 'identify', path, '--model', 'arx')
    assert warnings == ['fit_percent cannot be computed from these data (null in the JSON)']
    model = tmp_path / 'model.yaml'
    assert run(capsys, 'identify', plain_csv(tmp_path / 'clean.csv', clean), '--model-out', model)[0] == 0
    status, result, err = run(capsys, 'compare', path, '--model-file', model)
    assert status == 0 and result['fit_percent']['current'] is None and 'fit current n/a' in err
    assert 'fit_percent.current cannot be computed from these data (null in the JSON)' in result['warnings']


def test_a_record_shorter_than_the_prediction_horizon_reports_what_it_cannot(clean, tmp_path, capsys):
    """At 10 MHz the 10 ms position horizon is 1e5 samples, more than the record: its gap cannot be computed;
    the report says n/a and the plots say why, instead of failing."""
    path = plain_csv(tmp_path / 'fast.csv', changed(clean, (0,), 1e-3))
    status, _, err = run(capsys, 'discrepancy', path, '--report', tmp_path / 'report', '--json', tmp_path / 'd.json')
    assert status == 0, err
    warnings = json.loads((tmp_path / 'd.json').read_text())['warnings']
    assert 'gap_before.position cannot be computed from these data (null in the JSON)' in warnings
    assert '| position | n/a | n/a |' in (tmp_path / 'report' / 'report.md').read_text()
    model = tmp_path / 'model.yaml'
    assert run(capsys, 'identify', plain_csv(tmp_path / 'clean.csv', clean), '--model-out', model)[0] == 0
    status, _, err = run(capsys, 'compare', path, '--model-file', model, '--plot', tmp_path / 'compare.png')
    assert status == 0 and 'fit current n/a, position n/a' in err and (tmp_path / 'compare.png').exists()


def test_a_voltage_that_cannot_drive_the_current_is_not_taken_for_a_unit_slip(clean, tmp_path, capsys):
    """A constant 12 V (a supply logged instead of the coil voltage) cannot drive the current it was logged
    with: `identify` refuses it in one line (a held voltage that never changes does not excite the electrical
    equation, whose rows have a constant term), and the discrepancy workflow finds no model."""
    t, voltage, current, position = clean
    path = plain_csv(tmp_path / 'supply.csv', (t, np.full_like(voltage, 12.0), current, position))
    status, _, err = run(capsys, 'identify', path)
    assert status == 2 and err.count('\n') == 1 and 'do not excite the electrical equation' in err
    status, _, err = run(capsys, 'discrepancy', plain_csv(tmp_path / 'none.csv', (t, voltage, 0 * current, position)))
    assert status == 2 and err.count('\n') == 1 and 'nominal model cannot be identified' in err and 'nan' not in err
    assert 'do not excite the electrical equation' in err


def test_a_negative_damping_alone_is_no_sign_slip():
    """No flipped signal makes B < 0 alone (a sensor delay the model lacks does): no --units advice."""
    parameters = dict(TRUTH, damping=-8.0)
    record_ = SimpleNamespace(signals={'position': np.array([0.0, 2e-3])}, sample_period=1e-4)
    (warning,) = plausibility_warnings(parameters, {'damping': 0.1}, record_)
    assert 'damping -8 N s/m is negative beyond its uncertainty' in warning and '--units' not in warning
    assert plausibility_warnings(parameters, {'damping': 5.0}, record_) == []     # within 3 sigma of zero
