"""A small fixed subset of the discrepancy sweep (scripts/discrepancy_sweep/, `make sweep`): the machinery end to end
on the installed suite (a clean record comes out adequate, a strong Coulomb friction is named, a pair whose best
candidate by score is only a partial match is named right, a case that raises is a result, the dask run appends JSON
lines and resumes) and the report writers."""
import json

import pytest

from scripts import discrepancy_sweep as sweep


def test_a_clean_record_is_adequate_and_a_strong_friction_is_named():
    clean = sweep.run_case(sweep.make_case(25, kind='clean', effects={}, rate=10000.0, actuator='table1',
                                           duration=1.0))
    assert clean['error'] is None, clean.get('traceback')
    assert clean['verdict'] == 'adequate' and clean['named'] == [] and sweep.success(clean)
    friction = sweep.run_case(sweep.make_case(10, kind='single', rate=10000.0, actuator='table1', duration=1.0,
                                              effects={'coulomb_friction': {'force': 1.5, 'presliding': 2e-6}}))
    assert friction['error'] is None, friction.get('traceback')
    assert 'coulomb_friction' in friction['named'] and friction['strength'] > sweep.FIVE
    assert friction['effect_parameters']['coulomb_force']['value'] == pytest.approx(1.5, rel=0.05)
    for r in (clean, friction):   # every figure the sweep reads is there and JSON-able
        json.dumps(r, allow_nan=False) if not r['numeric_problems'] else json.dumps(r)
        assert set(r['nominal_sigma']) == set(sweep.NOMINAL)


def test_a_best_score_that_only_partly_matches_gives_way_to_the_next_candidate():
    """Sweep case 232, 0.7 s of it: a current sensor 0.165 samples late beside a 0.147 A offset at 20 kHz. The
    lag's filter scores best, but added first it leaves more disagreement than it found; the offset (the drive's
    equivalent current offset), next in score, is named, then the lag, and the model closes."""
    from emla_identification.discrepancy import diagnose
    case = sweep.make_case(232, duration=0.7)
    recording, _ = sweep.simulate(case)
    diagnosis = diagnose(recording)
    assert diagnosis.candidates[0].name == 'sensor_filter'                     # the lag scores best
    assert [stage.assessment.name for stage in diagnosis.stages] == ['drive_voltage_error', 'sensor_filter']
    assert diagnosis.verdict == 'explained'
    offset, std = diagnosis.added_parameters()['equivalent_current_offset']
    assert abs(offset - case['effects']['current_sensor_offset']['offset']) <= 3.0 * std


def test_an_effect_too_small_to_name_widens_the_parameters_it_moves():
    """Sweep case 2: a 5 mV dead-time drop fading over 46 mA at 5 kHz, 1.3 times the floor in power: adequate, and
    rightly, but about zero current the drop acts as a resistance, and R came out 0.06 % high, 15 of its sigmas.
    The data show the drop (better in 9 of 10 held-out blocks, resolved); the parameters' sigmas include what
    adding it changes, and a warning says so."""
    from emla_identification.discrepancy import diagnose
    case = sweep.make_case(2)
    recording, _ = sweep.simulate(case)
    truth, _ = sweep.expected(case, recording)
    result = diagnose(recording).to_dict()
    assert result['verdict'] == 'adequate' and result['effects'] == []
    found, std = result['reidentified_parameters'], result['reidentified_parameters_std']
    for name in ('resistance', 'inductance', 'emf_constant', 'mass', 'damping'):
        assert abs(found[name] - truth[name]) <= 3.0 * std[name], name
    assert any(w.startswith('the data show drive_voltage_error') for w in result['warnings'])


def test_a_spring_named_at_a_slow_logger_is_fitted_with_each_equation_weighed_by_its_own_residual():
    """Sweep case 74: a 770 N/m return spring on a 26 g voice coil at 2 kHz. Weighed by the nominal residuals (the
    spring missing swells the force balance's), the fit leaned on the electrical rows, whose weak hold on m carries
    their noise: m 0.8 % and k 0.85 % off, the force balance left at 14 times its floor (at the true values: 1.01).
    Weighed by its own residuals the model closes, k and every nominal parameter within 3 sigma."""
    r = sweep.run_case(sweep.make_case(74), report=False)
    assert r['error'] is None, r.get('traceback')
    assert r['verdict'] == 'explained' and r['named'] == ['return_spring'], r['disagreement_final']
    assert r['disagreement_final']['mechanical']['ratio'] < 1.5
    spring = r['effect_parameters']['spring_stiffness']
    assert abs(spring['value'] - spring['truth']) <= 3.0 * spring['std'] and spring['std'] < 0.002 * spring['truth']
    assert all(abs(s) < 3.0 for s in r['nominal_sigma'].values()), r['nominal_sigma']


def test_a_friction_read_through_a_band_of_a_few_noise_sigmas_is_judged_against_the_noise_it_reads():
    """Sweep case 210: a 0.09 N Coulomb friction (a 2 um bristle) at 10 kHz on a 1 um quantiser. Named with Fc and
    every nominal parameter within 2.5 sigma, yet its force balance was left at 3.6 times the rows' noise floor: the
    candidate reads the friction's direction through a pre-sliding band a few position-noise sigmas wide, and the
    position's noise through it is force at every stop. With that noise in the floor (adequacy._through_terms) the
    force balance is at ~1.1 times it, and the case is explained."""
    r = sweep.run_case(sweep.make_case(210), report=False)
    assert r['error'] is None, r.get('traceback')
    assert r['verdict'] == 'explained' and r['named'] == ['coulomb_friction'], r['disagreement_final']
    assert r['disagreement_final']['mechanical']['ratio'] < 1.5
    assert r['effect_parameters']['coulomb_force']['within']
    assert all(abs(s) < 3.0 for s in r['nominal_sigma'].values()), r['nominal_sigma']


def test_an_effect_named_first_has_its_setting_searched_again_beside_the_next():
    """Sweep case 161: a Stribeck friction (0.04 N sliding, 0.10 N breakaway, a 2 um bristle) beside a 45 N/m
    magnetic stiffness at 5 kHz. The friction is named first, its pre-sliding band chosen while the stiffness was
    missing: 6.9 um, its level held at zero, and with the stiffness added the force balance was left at 16 times
    its floor. Its band searched again beside the stiffness (refine.backfitted) comes out near the bristle's, the
    level is free again, and the model closes with the stiffness and every nominal parameter within 3 sigma."""
    r = sweep.run_case(sweep.make_case(161), report=False)
    assert r['error'] is None, r.get('traceback')
    assert r['verdict'] == 'explained', r['disagreement_final']
    assert r['named'] == ['coulomb_friction', 'magnetic_stiffness'] and sweep.success(r)
    assert r['effect_parameters']['spring_stiffness']['within']
    assert not r['effect_parameters']['coulomb_force']['held_at_zero']
    assert all(abs(s) < 3.0 for s in r['nominal_sigma'].values()), r['nominal_sigma']


def test_a_fraction_of_a_sample_at_a_slow_logger_is_moved_back_and_its_interpolation_is_in_the_sigmas():
    """Sweep case 96: a position 0.637 samples late beside a position-dependent inductance at 2 kHz. Moved back by
    a third-order all-pass (not flat far enough for the fast motion a 2 kHz logger sees), the position left the
    electrical equation at 30 times its floor at the true delay, and a spurious stiffness was named third; the
    fifth-order one closes both equations. What it still leaves (Km and m 0.2 % low, 3.7 jackknife sigmas) is in
    the sigmas: the estimates' change when re-aligned with the next finer all-pass (profile.finer).

    `emla identify --model-file` with the model it learns (model.identified_structure) identifies that structure
    as the workflow does: it took the delay from its grid (0.5 samples) without the inductance beside it, and gave
    R 27 % high at 8 sigma and a negative damping."""
    from emla_identification.discrepancy import diagnose
    from emla_identification.model import from_fit, identified_structure
    case = sweep.make_case(96)
    recording, _ = sweep.simulate(case)
    truth, _ = sweep.expected(case, recording)
    diagnosis = diagnose(recording)
    result = diagnosis.to_dict()
    names = [e['effect'] for e in result['effects']]
    assert names == ['sensor_delay', 'position_inductance']
    assert result['verdict'] == 'explained', result['disagreement']
    delay = result['added_parameters']['position_delay']
    assert delay == pytest.approx(0.637 / case['rate'], rel=0.01)
    identified = identified_structure(from_fit(diagnosis.final, names, 'case 96', 'test', diagnosis.final_std),
                                      recording, 'case 96', 'test')[1]
    assert identified.effects[0].settings['position_delay_samples'] == pytest.approx(0.637, rel=0.01)
    for found, std in ((result['reidentified_parameters'], result['reidentified_parameters_std']),
                       ({k: v for k, (v, _) in identified.parameters.items()},
                        {k: s for k, (_, s) in identified.parameters.items()})):
        for name in ('resistance', 'inductance', 'emf_constant', 'mass', 'damping'):
            assert abs(found[name] - truth[name]) <= 3.0 * std[name], name


def test_a_re_alignment_whose_form_the_first_stage_cannot_tell_is_chosen_by_the_final_model():
    """Sweep case 40 (1 s of it): a current sensor a sample late beside a Stribeck friction at 20 kHz. Named
    first, the delay closes the electrical equation whether the current alone or current and position are late,
    and the force balance, the only equation a position a sample late changes, is at 95 times its floor from the
    friction: both were named late, a spring next, and the record was left unexplained. Named again from the
    delay's other form (name.other_form), a Coulomb friction follows and the model explains the record, with
    a warning that says which form was taken and why, and every nominal parameter within 3 sigma."""
    from emla_identification.discrepancy import diagnose
    case = sweep.make_case(40, duration=1.0)
    recording, _ = sweep.simulate(case)
    truth, _ = sweep.expected(case, recording)
    result = diagnose(recording).to_dict()
    assert [e['effect'] for e in result['effects']] == ['sensor_delay', 'coulomb_friction']
    assert result['verdict'] == 'explained', result['disagreement']
    added = result['added_parameters']
    assert 'current_delay' in added and 'position_delay' not in added
    assert added['coulomb_force'] == pytest.approx(case['effects']['stribeck_friction']['coulomb'], rel=0.2)
    assert any(w.startswith('sensor_delay is named as current_delay_samples') for w in result['warnings'])
    found, std = result['reidentified_parameters'], result['reidentified_parameters_std']
    for name in ('resistance', 'inductance', 'emf_constant', 'mass', 'damping'):
        assert abs(found[name] - truth[name]) <= 3.0 * std[name], name


def test_a_setting_the_search_left_short_is_polished_to_its_minimum():
    """Sweep case 196: a position 2 samples late at 5 kHz. The held-out search, linearised about the misaligned
    model, put the delay at 1.984 samples; one parabola step took it to 1.994, which left the force balance at 9.5
    times its floor. Polished again while the step is a whole one, it reaches 2.000 and the model closes."""
    from emla_identification.discrepancy import diagnose
    case = sweep.make_case(196)
    recording, _ = sweep.simulate(case)
    truth, _ = sweep.expected(case, recording)
    result = diagnose(recording).to_dict()
    assert result['verdict'] == 'explained' and [e['effect'] for e in result['effects']] == ['sensor_delay']
    assert result['added_parameters']['position_delay'] * case['rate'] == pytest.approx(2.0, abs=1e-3)
    found, std = result['reidentified_parameters'], result['reidentified_parameters_std']
    for name in ('resistance', 'inductance', 'emf_constant', 'mass', 'damping'):
        assert abs(found[name] - truth[name]) <= 3.0 * std[name], name


def test_a_case_that_raises_is_a_result():
    case = sweep.make_case(3, kind='single', effects={'no_such_effect': {}}, duration=0.2)
    r = sweep.run_case(case)
    assert r['error'].startswith('ValueError') and 'no_such_effect' in r['error']
    assert sweep.outcome(r) == 'failed' and not sweep.success(r)


def test_numeric_problems_are_found():
    found = sweep.numeric_problems({'a': float('nan'), 'b': [1.0, float('inf')],
                                    'c': 'removes -1286 % of the disagreement; removes only nan % of it',
                                    'd': 'removes -50 % (information, infinite care) 100 %'})
    assert {(p['where'], p['what']) for p in found} == {
        ('json.a', 'nan'), ('json.b[i]', 'inf'), ('json.c', 'percentage < -100 %'), ('json.c', 'nan')}


def _result(seed, kind, hidden, verdict, named, strength=10.0, rate=10000.0, sigma=0.5, problems=()):
    case = {'seed': seed, 'kind': kind, 'actuator': 'table1', 'params': {}, 'rate': rate, 'duration': 3.0,
            'effects': {h: {'force': 1.0} for h in hidden}, 'levels': {h: 0.5 for h in hidden}}
    return {'seed': seed, 'case': case, 'hidden': sorted(hidden), 'kind': kind, 'rate': rate, 'code': 'abc123',
            'error': None, 'verdict': verdict, 'named': named, 'strength': strength, 'power_ratio': strength ** 2,
            'single_strength': {h: strength for h in hidden} if kind == 'pair' else None,
            'disagreement_final': {'mechanical': {'ratio': 9.0 if verdict == 'unexplained' else 1.0,
                                                  'adequate': verdict != 'unexplained', 'depends_on': []}},
            'candidates': [{'effect': 'coulomb_friction', 'score': 0.9, 'significant': True}],
            'nominal_sigma': {k: sigma for k in sweep.NOMINAL}, 'nominal_error': {k: 1e-4 for k in sweep.NOMINAL},
            'effect_parameters': {}, 'numeric_problems': list(problems), 'seconds': 1.0}


def test_the_report_lists_rates_and_every_miss(tmp_path):
    results = [
        _result(1, 'clean', [], 'adequate', [], strength=0.3),
        _result(2, 'clean', [], 'unexplained', [], strength=3.0),                            # a miss
        _result(3, 'single', ['coulomb_friction'], 'explained', ['coulomb_friction']),
        _result(4, 'single', ['return_spring'], 'unexplained', [], strength=40.0),          # a miss
        _result(5, 'single', ['return_spring'], 'adequate', [], strength=1.0),              # weak: not counted
        _result(6, 'pair', ['coulomb_friction', 'return_spring'], 'explained', ['return_spring', 'coulomb_friction']),
        _result(7, 'single', ['sensor_delay'], 'explained', ['sensor_delay'], rate=2000.0, sigma=7.0),
        _result(8, 'outside', ['cogging'], 'unexplained', ['return_spring'], problems=[
            {'where': 'json.candidates[i].evidence', 'what': 'percentage < -100 %', 'text': 'removes -300 %'}]),
    ]
    results.append({'seed': 9, 'case': results[2]['case'] | {'seed': 9}, 'hidden': ['coulomb_friction'],
                    'kind': 'single', 'rate': 10000.0, 'code': 'abc123', 'error': 'RuntimeError: boom'})
    doc = sweep.write_report({r['seed']: r for r in results}, tmp_path / 'sweep.md', command='the command')
    text = doc.read_text()
    assert 'the command' in text and '9 cases' in text
    assert '| clean records called adequate (nothing named) | 1/2 (50.0 %) | 0/0 (-) | 1/2 (50.0 %) |' in text
    assert '| a pair, both above 5x: both named and explained | 1/1 (100.0 %) |' in text
    assert '| an effect outside the library: nothing named | 0/1 (0.0 %) |' in text
    misses = text.split('## Every miss, by case')[1]
    for seed in (2, 4, 8, 9):
        assert f'--case {seed} --code abc123' in misses
    assert '--case 5 ' not in misses.split('Re-identified parameters beyond')[0]
    assert '| 7 | 2 kHz |' in misses                      # its parameters are 7 sigma off
    assert 'percentage < -100 %' in text and 'RuntimeError: boom' in text


def test_the_headline_page_has_the_headline_and_names_the_full_report(tmp_path):
    results = [_result(1, 'clean', [], 'adequate', [], strength=0.3),
               _result(4, 'single', ['return_spring'], 'unexplained', [], strength=40.0)]
    text = sweep.write_headline(results, tmp_path / 'headline.md', command='the command',
                                full='sweep-results/abc1234.md').read_text()
    assert 'the command' in text and '2 cases' in text and 'sweep-results/abc1234.md' in text
    assert '| clean records called adequate (nothing named) | 1/1 (100.0 %) | 0/0 (-) | 1/1 (100.0 %) |' in text
    assert '## Every miss, by case' not in text and '--case 4 ' not in text   # the misses: in the full report


def test_the_sweep_runs_on_dask_appends_and_resumes(tmp_path):
    out, doc, headline = tmp_path / 'sweep.jsonl', tmp_path / 'sweep.md', tmp_path / 'headline.md'
    argv = ['--cases', '2', '--first-seed', '19', '--workers', '1', '--duration', '0.5', '--out', str(out),
            '--doc', str(doc), '--headline', str(headline), '--code', 'installed', '--no-report-text']
    assert sweep.main(argv) == 0
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    assert sorted(r['seed'] for r in lines) == [19, 20]
    assert '2 cases' in doc.read_text() and '## Every miss, by case' in doc.read_text()
    assert '2 cases' in headline.read_text() and doc.name in headline.read_text()
    assert sweep.main(argv + ['--resume']) == 0           # nothing left to run: the same results
    assert len(out.read_text().splitlines()) == 2
