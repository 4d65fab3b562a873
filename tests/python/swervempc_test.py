"""The Python module swervempc against the library's own behaviour: configs load, a controller
steps on numpy arrays and closes the loop on the plant, a scenario run's log agrees with its
metrics, the sweep runs, and every bad input is a ValueError carrying the library's message."""
import math
import os
import unittest

import numpy as np

import swervempc as sm

SOURCE = os.environ.get("SWERVE_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
CONFIGS = os.path.join(SOURCE, "configs")
TEST_DATA = os.path.join(SOURCE, "tests", "app", "data")
VEHICLE = os.path.join(CONFIGS, "vehicles", "agv_4wheel.yaml")
CONTROLLER = os.path.join(CONFIGS, "controllers", "default.yaml")
BASELINE = os.path.join(CONFIGS, "controllers", "kinematic_baseline.yaml")


def straight_line(t0, seconds, speed=0.5):
    """Rows (t, x, y, psi): a line along x at `speed`, as a planner would publish it."""
    t = t0 + np.arange(0.0, seconds, 0.1)
    return np.column_stack([t, speed * t, np.zeros_like(t), np.zeros_like(t)])


class Configs(unittest.TestCase):
    def test_vehicle_loads_with_its_layout(self):
        vehicle = sm.load_vehicle(VEHICLE)
        self.assertEqual(vehicle.module_count, 4)
        self.assertEqual(vehicle.module_positions.shape, (4, 2))
        self.assertGreater(vehicle.mass, 0.0)
        self.assertTrue(sm.__version__.count(".") == 2)

    def test_controller_config_loads_and_its_settings_change(self):
        config = sm.load_controller_config(CONTROLLER)
        self.assertEqual(config.type, "wear_mpc")
        config.horizon = 10
        config.wear_weight = 0.1
        self.assertEqual(config.horizon, 10)
        self.assertEqual(config.control_period, config.dt)  # unset: one step per period
        config.control_period = config.dt / 2
        self.assertEqual(config.control_period, config.dt / 2)
        config.validate()

    def test_staleness_and_polish_read_the_file_and_are_checked(self):
        config = sm.load_controller_config(CONTROLLER)
        self.assertEqual(config.stale_measurement, (0.0, 3, 0.01))  # default.yaml's block
        self.assertEqual(config.polish_share, 0.3)
        config.stale_measurement = (0.2, 5, 0.05)
        config.polish_share = 0.0
        self.assertEqual(config.stale_measurement, (0.2, 5, 0.05))
        self.assertEqual(config.polish_share, 0.0)
        config.validate()
        config.stale_measurement = (0.2, 1, 0.05)
        with self.assertRaisesRegex(ValueError, "frozen_cycles = 1"):
            config.validate()
        config.stale_measurement = (0.0, 3, 0.01)
        config.polish_share = 1.5
        with self.assertRaisesRegex(ValueError, "polish_share = 1.5"):
            sm.make_controller(config, sm.load_vehicle(VEHICLE), sm.TrajectoryReference(16))

    def test_a_missing_file_is_a_value_error_naming_it(self):
        with self.assertRaisesRegex(ValueError, "no_such_vehicle.yaml"):
            sm.load_vehicle(os.path.join(CONFIGS, "no_such_vehicle.yaml"))

    def test_an_invalid_setting_is_a_value_error_naming_the_field(self):
        config = sm.load_controller_config(CONTROLLER)
        config.control_period = 2 * config.dt
        with self.assertRaisesRegex(ValueError, "control_period"):
            config.validate()
        config.control_period = 0.0
        config.horizon = 0
        with self.assertRaisesRegex(ValueError, "horizon = 0"):
            config.validate()
        with self.assertRaisesRegex(ValueError, "horizon = 0"):
            sm.make_controller(config, sm.load_vehicle(VEHICLE), sm.TrajectoryReference(16))


class TrajectoryReference(unittest.TestCase):
    def test_refused_samples_name_the_sample_and_keep_the_previous_trajectory(self):
        reference = sm.TrajectoryReference(64)
        reference.publish(straight_line(0.0, 4.0))
        bad = straight_line(0.0, 4.0)
        bad[3, 0] = bad[2, 0]  # time not increasing at sample 3
        with self.assertRaisesRegex(ValueError, "sample 3"):
            reference.publish(bad)
        nan = straight_line(0.0, 4.0)
        nan[5, 1] = float("nan")
        with self.assertRaisesRegex(ValueError, "sample 5"):
            reference.publish(nan)
        with self.assertRaisesRegex(ValueError, "2-D"):
            reference.publish(np.zeros(4))
        # The first trajectory (0 to 3.9 s) is still the one the controller would take up.
        controller = sm.make_controller(VEHICLE, BASELINE, reference)
        self.assertNotEqual(controller.step(np.zeros(10), 0.0).source, "safe_stop")
        self.assertAlmostEqual(reference.duration, 3.9)
        with self.assertRaisesRegex(ValueError, "capacity"):
            sm.TrajectoryReference(1)


    def test_sample_reads_the_newest_trajectory_and_version_counts_them(self):
        reference = sm.TrajectoryReference(64)
        with self.assertRaisesRegex(ValueError, "no trajectory"):
            reference.sample(0.0)
        self.assertEqual(reference.version, 0)
        # Given velocities: (t, x, y, psi, vx, vy, r) along x at 0.5 m/s from t = 2 s.
        t = 2.0 + np.arange(0.0, 4.0, 0.1)
        rows = np.column_stack([t, 0.5 * (t - 2.0), np.zeros_like(t), np.zeros_like(t),
                                np.full_like(t, 0.5), np.zeros_like(t), np.zeros_like(t)])
        reference.publish(rows)
        pose, twist = reference.sample(3.25)
        np.testing.assert_allclose(pose, [0.625, 0.0, 0.0], atol=1e-9)
        np.testing.assert_allclose(twist, [0.5, 0.0, 0.0], atol=1e-9)
        self.assertEqual(reference.version, 1)
        # A newer trajectory (along y) is what the next sample reads.
        turned = rows[:, [0, 2, 1, 3, 5, 4, 6]].copy()
        reference.publish(turned)
        pose, _ = reference.sample(3.25)
        np.testing.assert_allclose(pose[:2], [0.0, 0.625], atol=1e-9)
        self.assertEqual(reference.version, 2)
        with self.assertRaisesRegex(ValueError, "t: must be finite"):
            reference.sample(float("nan"))


    def test_choreo_and_pose_list_files_load_as_rows_the_reference_takes(self):
        import tempfile
        folder = tempfile.mkdtemp()
        with open(os.path.join(folder, "ahead.traj"), "w") as out:
            # Facing +y (heading pi/2) while moving along +x: body twist (0, -1, 0).
            out.write('{"name": "ahead", "trajectory": {"sampleType": "Swerve", "samples": ['
                      '{"t": 0, "x": 0, "y": 0, "heading": 1.5707963267948966, "vx": 1, "vy": 0, "omega": 0},'
                      '{"t": 1, "x": 1, "y": 0, "heading": 1.5707963267948966, "vx": 1, "vy": 0, "omega": 0}]}}')
        rows = sm.load_choreo_trajectory(folder, trajectory="ahead")
        self.assertEqual(rows.shape, (2, 7))
        np.testing.assert_allclose(rows[1, 4:], [0.0, -1.0, 0.0], atol=1e-15)
        reference = sm.TrajectoryReference(16)
        reference.publish(rows)
        pose, _ = reference.sample(0.5)
        self.assertAlmostEqual(pose[0], 0.5)
        poses = os.path.join(folder, "poses.json")
        with open(poses, "w") as out:
            out.write('[{"t": 0, "x": 0, "y": 0, "psi": 0}, {"t": 1, "x": 1, "y": 0}]')
        with self.assertRaisesRegex(ValueError, "sample 1: missing 'psi'"):
            sm.load_pose_list(poses)
        with self.assertRaisesRegex(ValueError, "split 3 asked for"):
            sm.load_choreo_trajectory(os.path.join(folder, "ahead.traj"), split=3)


class Kinematics(unittest.TestCase):
    def test_inverse_forward_flip_and_desaturate_on_the_four_module_agv(self):
        kin = sm.Kinematics(sm.load_vehicle(VEHICLE))
        n = kin.module_count
        # Pure translation along +y: every module at 1 m/s pointing at +90 deg.
        speeds, angles = kin.inverse(np.array([0.0, 1.0, 0.0]))
        np.testing.assert_allclose(speeds, np.ones(n), atol=1e-12)
        np.testing.assert_allclose(angles, np.full(n, math.pi / 2), atol=1e-12)
        # Forward kinematics recovers a rotation's twist from its own inverse.
        twist = np.array([0.3, -0.2, 0.7])
        np.testing.assert_allclose(kin.forward(*kin.inverse(twist)), twist, atol=1e-12)
        # A module at 0 rad asked for 180 deg drives backwards instead.
        flipped_speeds, flipped_angles = kin.flip(np.ones(n), np.full(n, math.pi), np.zeros(n))
        np.testing.assert_allclose(flipped_speeds, -np.ones(n), atol=1e-12)
        np.testing.assert_allclose(flipped_angles, np.zeros(n), atol=1e-12)
        # One factor for all: the fastest goes to the limit, the ratios stay.
        np.testing.assert_allclose(kin.desaturate(np.array([4.0, 2.0, -1.0, 0.0]), 2.0), [2.0, 1.0, -0.5, 0.0])
        # The command chain remembers headings: standing still holds the last direction.
        kin.command(np.array([0.0, 1.0, 0.0]))
        _, held = kin.command(np.zeros(3))
        np.testing.assert_allclose(held, np.full(n, math.pi / 2), atol=1e-12)
        with self.assertRaisesRegex(ValueError, "twist_body: expected a 1-D array of 3 values"):
            kin.inverse(np.zeros(2))
        with self.assertRaisesRegex(ValueError, "inverse: non_finite_input"):
            kin.inverse(np.array([float("nan"), 0.0, 0.0]))
        with self.assertRaisesRegex(ValueError, "priority = 'fast'"):
            kin.desaturate_twist(np.zeros(3), 1.0, "fast")
        with self.assertRaisesRegex(ValueError, "flip_hysteresis"):
            sm.Kinematics(sm.load_vehicle(VEHICLE), flip_hysteresis=-1.0)


class Plant(unittest.TestCase):
    def drive(self, plant, periods):
        for _ in range(periods):
            self.assertTrue(plant.advance(np.zeros(4), np.zeros(4), np.full(4, 5.0)))

    def test_a_delayed_measurement_is_the_true_state_of_periods_ago(self):
        vehicle = sm.load_vehicle(VEHICLE)
        plant = sm.Simulator(vehicle, control_period=0.05, measurement_delay_steps=2)
        plant.reset(np.zeros(10))
        truth = []
        for _ in range(6):
            truth.append(plant.state[:10].copy())
            self.drive(plant, 1)
        truth.append(plant.state[:10].copy())
        np.testing.assert_allclose(plant.measurement[:10], truth[-3], atol=1e-12)
        self.assertGreater(plant.state[0], truth[-3][0])  # it moved on since
        self.assertAlmostEqual(plant.measurement_age, 0.1)

    def test_noise_perturbs_the_measurement_only_and_friction_is_accounted(self):
        vehicle = sm.load_vehicle(VEHICLE)
        plant = sm.Simulator(vehicle, seed=7, noise={"position": 0.01})
        plant.reset(np.zeros(10))
        self.drive(plant, 10)
        self.assertGreater(abs(plant.measurement[0] - plant.state[0]), 0.0)
        self.assertEqual(plant.measurement[2], plant.state[2])  # no heading noise asked
        # The agv has no caster: all the sliding energy is its modules' wear (coefficient 1), up to
        # the two integrals' rules (the energy's rectangle rule on the substeps, the wear's RK4).
        self.assertGreater(plant.frictional_energy, 0.0)
        wear = float(np.sum(plant.module_wear))
        self.assertLess(abs(plant.frictional_energy - wear), 1e-3 * wear)
        with self.assertRaisesRegex(ValueError, "noise.speed: unknown"):
            sm.Simulator(vehicle, noise={"speed": 0.1})
        with self.assertRaisesRegex(ValueError, "position"):
            sm.Simulator(vehicle, noise={"position": -0.1})
        with self.assertRaisesRegex(ValueError, "measurement_delay_steps"):
            sm.Simulator(vehicle, measurement_delay_steps=-1)


class ClosedLoop(unittest.TestCase):
    def test_controller_tracks_a_published_line_on_the_plant(self):
        vehicle = sm.load_vehicle(VEHICLE)
        reference = sm.TrajectoryReference(128, max_age=5.0)
        reference.publish(straight_line(0.0, 8.0))
        controller = sm.make_controller(VEHICLE, BASELINE, reference)
        plant = sm.Simulator(vehicle, control_period=0.05, seed=3)
        plant.reset(np.zeros(6 + vehicle.module_count))
        errors = []
        for k in range(60):
            t = 0.05 * k
            out = controller.step(plant.measurement, t)
            self.assertEqual(out.wheel_speed.shape, (4,))
            self.assertNotEqual(out.source, "safe_stop", out.reason)
            self.assertTrue(plant.advance(out))
            x, y = plant.measurement[0], plant.measurement[1]
            errors.append(math.hypot(x - 0.5 * plant.time, y))
        # Three seconds along a 0.5 m/s line: the vehicle moved and stayed on it.
        self.assertGreater(plant.measurement[0], 1.0)
        self.assertLess(max(errors[20:]), 0.05)
        self.assertTrue(np.all(plant.module_wear >= 0.0))

    def test_faults_grip_and_tire_wear_reach_the_controller_and_bad_ones_are_refused(self):
        reference = sm.TrajectoryReference(128)
        reference.publish(straight_line(0.0, 8.0))
        controller = sm.make_controller(VEHICLE, BASELINE, reference)
        self.assertEqual(controller.module_faults, ["none"] * 4)
        controller.set_module_fault(1, "stuck_steering")
        self.assertEqual(controller.module_faults, ["none", "stuck_steering", "none", "none"])
        with self.assertRaisesRegex(ValueError, "set_module_fault.module = 4"):
            controller.set_module_fault(4, "stuck_steering")
        with self.assertRaisesRegex(ValueError, "set_module_fault.kind = flat_tire"):
            controller.set_module_fault(0, "flat_tire")
        controller.set_friction_scale(0.5)
        with self.assertRaisesRegex(ValueError, "set_friction_scale.scale = 0"):
            controller.set_friction_scale(0.0)
        controller.set_module_wear(np.array([0.0, 1.0, 2.0, 3.0]))
        with self.assertRaisesRegex(ValueError, r"set_module_wear.wear\[2\] = -1"):
            controller.set_module_wear(np.array([0.0, 1.0, -1.0, 3.0]))
        with self.assertRaisesRegex(ValueError, "set_module_wear.wear: expected a 1-D array of 4 values"):
            controller.set_module_wear(np.zeros(3))
        self.assertEqual(controller.module_faults[1], "stuck_steering")  # refusals change nothing

    def test_wear_aware_controller_steps_and_reports_its_solve(self):
        reference = sm.TrajectoryReference(128)
        reference.publish(straight_line(0.0, 8.0))
        controller = sm.make_controller(VEHICLE, CONTROLLER, reference)
        state = np.zeros(10)
        out = controller.step(state, 0.0)
        self.assertEqual(out.steering_angle.shape, (4,))
        self.assertTrue(np.all(np.isfinite(out.wheel_speed)))
        self.assertNotEqual(out.solve_status, "not_run")

    def test_rti_prepares_between_steps_and_the_next_step_runs_its_feedback(self):
        reference = sm.TrajectoryReference(128)
        reference.publish(straight_line(0.0, 8.0))
        config = sm.load_controller_config(CONTROLLER)
        config.backend = "rti"
        controller = sm.make_controller(config, sm.load_vehicle(VEHICLE), reference)
        period = config.control_period
        plant = sm.Simulator(sm.load_vehicle(VEHICLE), control_period=period, seed=3)
        plant.reset(np.zeros(10))
        prepared = 0
        for k in range(30):
            out = controller.step(plant.measurement, k * period)
            self.assertNotEqual(out.source, "safe_stop", out.reason)
            prepared += controller.prepare((k + 1) * period)
            self.assertTrue(plant.advance(out))
        self.assertGreaterEqual(prepared, 15)
        with self.assertRaisesRegex(ValueError, "t_next = nan"):
            controller.prepare(float("nan"))
        # The baseline has nothing to prepare.
        baseline = sm.make_controller(VEHICLE, BASELINE, reference)
        baseline.step(np.zeros(10), 0.0)
        self.assertFalse(baseline.prepare(period))

    def test_a_wrong_state_shape_is_a_value_error_and_nan_is_a_safe_stop(self):
        reference = sm.TrajectoryReference(16)
        reference.publish(straight_line(0.0, 1.0))
        controller = sm.make_controller(VEHICLE, BASELINE, reference)
        with self.assertRaisesRegex(ValueError, r"expected a 1-D array of 10 values, got shape \(7,\)"):
            controller.step(np.zeros(7), 0.0)
        out = controller.step(np.full(10, np.nan), 0.0)
        self.assertEqual(out.source, "safe_stop")
        self.assertTrue(np.all(out.wheel_speed == 0.0))

    def test_no_trajectory_yet_is_a_safe_stop_with_the_reason(self):
        controller = sm.make_controller(VEHICLE, BASELINE, sm.TrajectoryReference(16))
        out = controller.step(np.zeros(10), 0.0)
        self.assertEqual(out.source, "safe_stop")
        self.assertIn("trajectory", out.reason)


class Runs(unittest.TestCase):
    def test_run_scenario_writes_the_logs_asked_for(self):
        import tempfile
        out = tempfile.mkdtemp()
        runs = sm.run_scenario(os.path.join(TEST_DATA, "short_curve_baseline.yaml"), out_dir=out, log="wpilog,mcap")
        self.assertIn("kinematic_baseline", runs)
        written = sorted(os.listdir(out))
        self.assertEqual(written, ["run.mcap", "run.wpilog", "summary.json"])
        with open(os.path.join(out, "run.wpilog"), "rb") as f:
            self.assertEqual(f.read(6), b"WPILOG")
        with self.assertRaisesRegex(ValueError, "unknown format 'bag'"):
            sm.run_scenario(os.path.join(TEST_DATA, "short_curve_baseline.yaml"), out_dir=out, log="csv,bag")

    def test_scenario_log_agrees_with_its_metrics(self):
        runs = sm.run_scenario(os.path.join(TEST_DATA, "short_curve_baseline.yaml"))
        self.assertIn("kinematic_baseline", runs)
        for name, run in runs.items():
            self.assertTrue(run["completed"], run["failure"])
            log, metrics = run["log"], run["metrics"]
            self.assertEqual(len(log["t"]), metrics["steps"])
            self.assertEqual(log["wheel_speed"].shape[0], metrics["steps"])
            # The RMSE recomputed here from the logged positions is the library's.
            rmse = math.sqrt(np.mean((log["x"] - log["x_ref"]) ** 2 + (log["y"] - log["y_ref"]) ** 2))
            self.assertAlmostEqual(rmse, metrics["tracking_rmse_m"], places=9, msg=name)

    def test_the_log_carries_each_plans_predicted_cost_and_the_best_guess(self):
        runs = sm.run_scenario(os.path.join(TEST_DATA, "short_offset60.yaml"))
        # The baseline runs no optimiser: no predicted cost at any step.
        self.assertTrue(np.all(np.isnan(runs["kinematic_baseline"]["log"]["plan_cost"])))
        log = runs["wear_mpc"]["log"]
        solved = ~np.isnan(log["plan_cost"])
        self.assertTrue(solved.any())
        # Every backend returns nothing worse than its best initial guess.
        self.assertTrue(np.all(log["plan_cost"][solved] <= log["initial_guess_cost"][solved] * (1 + 1e-12)))
        parts = log["plan_tracking_cost"][solved] + log["plan_wear_cost"][solved]
        self.assertTrue(np.all(parts <= log["plan_cost"][solved] * (1 + 1e-12)))

    def test_overrides_are_checked(self):
        with self.assertRaisesRegex(ValueError, "nope"):
            sm.run_scenario(os.path.join(TEST_DATA, "short_curve_baseline.yaml"), controllers=["nope"])

    def test_sweep_runs_the_baseline_and_each_point(self):
        result = sm.sweep(os.path.join(TEST_DATA, "short_offset60.yaml"), wear_weights=[0.1, 1.0])
        self.assertEqual(result["swept"], "wear_weight")
        self.assertEqual(result["baseline"]["type"], "kinematic_baseline")
        self.assertEqual([p["wear_weight"] for p in result["points"]], [0.1, 1.0])
        with self.assertRaisesRegex(ValueError, "exactly one"):
            sm.sweep(os.path.join(TEST_DATA, "short_offset60.yaml"))
        with self.assertRaisesRegex(ValueError, r"sweep point\[0\].wear_weight = -1"):
            sm.sweep(os.path.join(TEST_DATA, "short_offset60.yaml"), wear_weights=[-1.0])


if __name__ == "__main__":
    unittest.main()
