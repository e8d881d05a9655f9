"""Fixtures shared by the test modules, and the `slow` mark of the long cases (mostly the discrepancy workflow's)."""
import pytest
from ros_isolation import isolated_env

from emla_cli.launcher import reserved_domain

# Tests that run the discrepancy workflow on generated records, 10-70 s each (about 25 minutes in all on 2 cores):
# `make test` leaves them to `make test-all` and `make sweep` and keeps the fixed subset KEPT (a clean record, a
# hidden effect named, a delay re-aligned, the sweep's own cases, the README's walkthrough, the model file).
SLOW = {
    'test_discrepancy.py': ('test_names_the_hidden_effect_and_halves_the_gap', 'test_a_registered_candidate_is_ranked',
                            'test_no_missing_effect_is_no_false_alarm', 'test_two_effects_are_named_in_turn',
                            'test_coulomb_friction_from_force_and_position_only'),
    'test_discrepancy_hidden.py': ('test_a_clean_record_is_adequate', 'test_a_library_effect_is_named',
                                   'test_a_registered_candidate_explains_what_was_unexplained',
                                   'test_an_effect_the_library_lacks_is_unexplained_and_located',
                                   'test_two_effects_are_both_named_and_the_joint_model_is_right'),
    'test_discrepancy_acceptance.py': ('test_pairs_of_effects_are_both_named',
                                       'test_a_continuous_setting_is_refined_between_its_grid_points'),
    'test_bench_effects.py': ('test_a_current_late_by_half_a_sample_is_named_and_explained',
                              'test_a_current_sensors_filter_is_named_at_the_sensor_and_closed',
                              'test_a_late_current_the_data_cannot_place_is_a_rival_and_the_model_within_its_sigma',
                              'test_stribeck_friction_is_named_after_the_coulomb_level',
                              'test_smooth_friction_is_named_closed_and_its_speed_estimated',
                              'test_a_sharper_smooth_friction_is_named_with_its_level',
                              'test_a_coulomb_friction_is_not_called_stribeck_or_smooth',
                              'test_a_dead_time_drop_stiff_about_zero_current_leaves_the_model_within_its_sigma',
                              'test_one_filter_on_every_sensor_is_named_once_and_closed'),
    'test_position_inductance.py': ('test_the_discrepancy_workflow_names_it_on_independent_data',),
    'test_discrepancy_rescue.py': ('test_a_record_the_nominal_model_alone_cannot_fit_is_diagnosed',
                                   'test_a_dry_friction_with_a_damped_stuck_contact_closes',
                                   'test_a_delay_beside_a_missing_spring_is_not_scored_on_its_misfit_read_as_noise'),
    # the solenoid's: each effect at a second strength (the weaker one stays), a pair, its sigma over realisations,
    # the observer on four more records
    'test_solenoid_discrepancy.py': ('test_a_hidden_friction_is_named_and_the_mechanics_come_back',
                                     'test_a_hidden_iron_saturation_is_named_and_every_parameter_comes_back',
                                     'test_a_hidden_residual_magnetism_is_named_and_every_parameter_comes_back',
                                     'test_hidden_eddy_currents_are_named_and_every_parameter_comes_back',
                                     'test_a_saturation_and_a_friction_together_are_both_named'),
    # the sweep's 20 kHz pair whose best score is a partial match (~25 s) and its 2-sample delay polished (~11 s)
    'test_discrepancy_sweep.py': ('test_a_best_score_that_only_partly_matches_gives_way_to_the_next_candidate',
                                  'test_a_setting_the_search_left_short_is_polished_to_its_minimum'),
    'test_solenoid_observer.py': ('test_other_records_and_a_constant_r_within_two_percent',),
    'test_solenoid_identification.py': ('test_the_errors_over_noise_realisations_are_about_one_reported_sigma',),
    # not the discrepancy's: the grey box's sigma against the scatter over 16 noise realisations (25-40 s)
    'test_greybox.py': ('test_reported_std_matches_the_scatter_over_noise_realisations',),
    # not the discrepancy's either, 10-25 s each, where make test keeps a sibling covering the same code: the
    # compare command (test_outputs), its figures' axes, the discrepancy on a damaged bag (identify's stays), play
    # from a sqlite3 bag (mcap stays), a flag shared with import, the whole solenoid identified by its node
    'test_model_file.py': ('test_compare_shows_the_augmented_model_fitting_better_than_the_nominal',),
    'test_plot_axes.py': ('test_the_discrepancy_report_and_compare_figures',),
    'test_damaged_inputs.py': ('test_commands_on_a_bag_with_a_corrupt_chunk',),
    'test_play_echo.py': ('test_a_live_identifier_fed_by_play_agrees_with_offline_identification',),
    'test_foreign_data.py': ('test_discrepancy_and_import_take_the_same_flags',),
    'test_solenoid_node.py': ('test_the_identifier_node_identifies_a_whole_solenoid_online',),
}
KEPT = {'test_a_hidden_friction_is_named_and_the_mechanics_come_back[0.05-8]',
        'test_a_hidden_iron_saturation_is_named_and_every_parameter_comes_back[0.05-6]',
        'test_commands_on_a_bag_with_a_corrupt_chunk[identify]',
        'test_a_live_identifier_fed_by_play_agrees_with_offline_identification[mcap]'}


def pytest_collection_modifyitems(items):
    for item in items:
        if item.originalname in SLOW.get(item.path.name, ()) and item.name not in KEPT:
            item.add_marker(pytest.mark.slow)


@pytest.fixture
def ros_env():
    """The environment of a ROS domain no other launch or test uses meanwhile (locked), for one test."""
    with reserved_domain() as domain:
        yield isolated_env(ROS_DOMAIN_ID=domain)
