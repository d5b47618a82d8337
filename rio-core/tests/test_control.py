"""rio.control: pose math, filters, interpolators, teleop mappings, and the scripted/keyboard teleop
devices' signal logic (no nodes, no clocks: time is passed in)."""

from __future__ import annotations

import numpy as np
import pytest

from rio.control import (
    ButtonEdges,
    LinearInterpolator,
    LowPassFilter,
    ModeSwitch,
    OneEuroFilter,
    PoseFilter,
    PoseInterpolator,
    TeleopMode,
    Waypoints,
    apply_twist,
    euler_to_quat,
    limit_twist,
    make_teleop_eef_cmd,
    matrix_to_pose,
    matrix_to_quat,
    pose_error,
    pose_inv,
    pose_mul,
    pose_to_matrix,
    quat_angle,
    quat_slerp,
    quat_to_matrix,
    quat_to_rotvec,
    rotvec_to_quat,
    twist_between,
)

RNG = np.random.default_rng(7)


def random_quat():
    q = RNG.normal(size=4)
    return q / np.linalg.norm(q)


def random_pose():
    return np.concatenate([RNG.uniform(-1, 1, 3), random_quat()])


# -- rotations ---------------------------------------------------------------------------------------
def test_quaternion_matrix_round_trip_and_orthonormal():
    for _ in range(200):
        q = random_quat()
        m = quat_to_matrix(q)
        assert np.allclose(m @ m.T, np.eye(3), atol=1e-12) and np.isclose(np.linalg.det(m), 1.0)
        assert quat_angle(matrix_to_quat(m), q) < 1e-7


def test_rotvec_exp_log_round_trip_including_tiny_and_half_turn():
    for rv in [np.zeros(3), np.array([1e-12, 0, 0]), np.array([0, 0, np.pi - 1e-9]), *RNG.uniform(-3, 3, (100, 3))]:
        if np.linalg.norm(rv) > np.pi:
            continue
        assert np.allclose(quat_to_rotvec(rotvec_to_quat(rv)), rv, atol=1e-8)


def test_rotation_about_z_rotates_x_to_y():
    q = rotvec_to_quat([0, 0, np.pi / 2])
    assert np.allclose(quat_to_matrix(q) @ [1, 0, 0], [0, 1, 0], atol=1e-12)
    assert np.allclose(euler_to_quat(0, 0, np.pi / 2), q)


def test_slerp_endpoints_midpoint_and_shorter_arc():
    a, b = rotvec_to_quat([0, 0, 0.2]), rotvec_to_quat([0, 0, 1.0])
    assert quat_angle(quat_slerp(a, b, 0), a) < 1e-9 and quat_angle(quat_slerp(a, b, 1), b) < 1e-9
    assert quat_angle(quat_slerp(a, b, 0.5), rotvec_to_quat([0, 0, 0.6])) < 1e-9
    assert quat_angle(quat_slerp(a, -b, 0.5), rotvec_to_quat([0, 0, 0.6])) < 1e-9  # -b is the same rotation


# -- poses -------------------------------------------------------------------------------------------
def test_pose_compose_inverse_and_matrices_agree():
    for _ in range(100):
        a, b = random_pose(), random_pose()
        ab = pose_mul(a, b)
        assert np.allclose(pose_to_matrix(ab), pose_to_matrix(a) @ pose_to_matrix(b), atol=1e-12)
        pe, re = pose_error(pose_mul(pose_inv(a), a), [0, 0, 0, 1, 0, 0, 0])
        assert pe < 1e-12 and re < 1e-6
        assert sum(pose_error(matrix_to_pose(pose_to_matrix(a)), a)) < 1e-7


def test_twist_integrates_about_the_tool_point():
    start = np.array([0.3, 0.0, 0.2, *euler_to_quat(np.pi, 0, 0)])
    p = start.copy()
    for _ in range(100):  # 1 s of 0.1 m/s along y and 0.5 rad/s about z
        p = apply_twist(p, [0, 0.1, 0, 0, 0, 0.5], 0.01)
    assert np.allclose(p[:3], [0.3, 0.1, 0.2], atol=1e-12)  # rotation did not swing the position
    assert abs(quat_angle(p[3:], start[3:]) - 0.5) < 1e-9
    tw = twist_between(start, p, 2.0)
    assert np.allclose(tw, [0, 0.05, 0, 0, 0, 0.25], atol=1e-9)


def test_as_pose_rejects_bad_input():
    with pytest.raises(ValueError, match="7 values"):
        pose_error([0, 0, 0], [0, 0, 0, 1, 0, 0, 0])
    with pytest.raises(ValueError, match="zero norm"):
        pose_inv([0, 0, 0, 0, 0, 0, 0])


# -- filters -----------------------------------------------------------------------------------------
def test_low_pass_step_response_has_the_cutoffs_time_constant():
    f, dt, hz = LowPassFilter(2.0), 0.001, 2.0
    tau = 1 / (2 * np.pi * hz)
    f(0.0, 0.0)
    y, t = 0.0, 0.0
    while t < tau - 1e-9:
        t += dt
        y = float(f(1.0, t))
    assert abs(y - (1 - np.exp(-1))) < 0.01


def test_low_pass_keeps_the_integral_of_a_pulse():
    """What makes filtering a teleop twist safe: the distance travelled is unchanged."""
    f = LowPassFilter(5.0)
    ts = np.arange(0, 3, 1 / 30)
    x = np.where((ts > 0.5) & (ts < 1.0), 0.1, 0.0)
    y = np.array([f(v, t) for v, t in zip(x, ts, strict=True)]).ravel()
    assert abs(y.sum() - x.sum()) / x.sum() < 1e-3
    assert y.max() < x.max()


def test_low_pass_over_irregular_spans_integrates_to_the_same_displacement():
    """A loaded machine's teleop: each cycle integrates the device's twist over a span that varies
    (late cycles catch up). Filtered over those spans the target lands where the device said;
    filtered on the loop's regular tick times it does not (CI: squares ended up to 9 mm open)."""
    rng = np.random.default_rng(3)
    spans = rng.choice([0.02, 0.02, 0.02, 0.005, 0.09, 0.0], size=400)  # late ticks, catch-ups, no new sample
    t = np.cumsum(spans)
    x = np.where((t > 0.2) & (t < 1.5), 0.15 * np.sin(np.pi * (t - 0.2) / 1.3) ** 2, 0.0)  # a smooth move, m/s
    over = LowPassFilter(8.0)
    ticks = LowPassFilter(8.0)
    moved_over = sum(float(over.over(v, h)[()]) * h for v, h in zip(x, spans, strict=True))
    moved_ticks = sum(float(ticks(v, 0.02 * i)[()]) * h for i, (v, h) in enumerate(zip(x, spans, strict=True)))
    moved = float(np.sum(x * spans))
    assert moved > 0.05
    assert abs(moved_over - moved) < 1e-6
    assert abs(moved_ticks - moved) > 1e-4  # the mistake this guards against is measurable


def test_one_euro_smooths_jitter_when_still_and_follows_fast_motion():
    ts = np.arange(0, 2, 0.01)
    still = 0.5 + RNG.normal(0, 0.01, ts.size)
    one = OneEuroFilter(min_cutoff=1.0, beta=2.0)
    out = np.array([one(v, t) for v, t in zip(still, ts, strict=True)]).ravel()
    assert out[50:].std() < 0.3 * still[50:].std()
    ramp = ts * 1.0  # 1 unit/s
    one2, low = OneEuroFilter(min_cutoff=1.0, beta=2.0), LowPassFilter(1.0)
    lag_one = ramp[-1] - float(np.asarray([one2(v, t) for v, t in zip(ramp, ts, strict=True)])[-1])
    lag_low = ramp[-1] - float(np.asarray([low(v, t) for v, t in zip(ramp, ts, strict=True)])[-1])
    assert lag_one < 0.3 * lag_low


def test_pose_filter_orientation_follows_with_the_position_smoothing():
    f = PoseFilter(min_cutoff=5.0)
    a = np.array([0, 0, 0, 1, 0, 0, 0.0])
    b = np.array([0.1, 0, 0, *rotvec_to_quat([0, 0, 0.5])])
    f(a, 0.0)
    out = f(b, 0.01)
    k = out[0] / 0.1
    assert 0 < k < 1
    assert abs(quat_angle(out[3:], a[3:]) - k * 0.5) < 1e-6
    for i in range(2, 300):
        out = f(b, i * 0.01)
    assert sum(pose_error(out, b)) < 1e-6


# -- interpolators -----------------------------------------------------------------------------------
def test_linear_interpolator_reaches_the_target_at_its_time_and_retargets_smoothly():
    it = LinearInterpolator([0.0, 0.0], t=0.0)
    it.set_target([1.0, 2.0], t_target=1.0, t_now=0.0)
    assert np.allclose(it.sample(0.5), [0.5, 1.0]) and np.allclose(it.sample(5.0), [1.0, 2.0])
    it.set_target([0.0, 0.0], t_target=1.5, t_now=0.5)  # new target mid-way: starts from where it is
    assert np.allclose(it.sample(0.5), [0.5, 1.0]) and np.allclose(it.sample(1.0), [0.25, 0.5])
    it.set_target([3.0, 3.0], t_target=-1.0, t_now=2.0)  # target time in the past: at once
    assert np.allclose(it.sample(2.0), [3.0, 3.0])
    with pytest.raises(ValueError, match="shape"):
        it.set_target([1.0], 3.0, 2.0)


def test_pose_interpolator_slerps():
    a = np.array([0, 0, 0, 1, 0, 0, 0.0])
    b = np.array([0.2, 0, 0, *rotvec_to_quat([0, 0, 1.0])])
    it = PoseInterpolator(a, 0.0)
    it.set_target(b, 2.0, 0.0)
    mid = it.sample(1.0)
    assert np.allclose(mid[:3], [0.1, 0, 0]) and abs(quat_angle(mid[3:], rotvec_to_quat([0, 0, 0.5]))) < 1e-9


def test_waypoints_piecewise_linear_and_clamped():
    w = Waypoints([0.0, 1.0, 3.0], [[0.0], [1.0], [-1.0]])
    assert w.sample(-1)[0] == 0 and w.sample(0.5)[0] == 0.5 and w.sample(2.0)[0] == 0.0 and w.sample(9)[0] == -1
    with pytest.raises(ValueError):
        Waypoints([0.0, 0.0], [[0.0], [1.0]])


# -- teleop mappings ---------------------------------------------------------------------------------
def test_modes_mask_the_twist():
    tw = np.arange(1.0, 7.0)
    start = np.array([0, 0, 0, 1, 0, 0, 0.0])
    for mode, moved, turned in [(TeleopMode.TRANSLATION, [1, 2, 3], False), (TeleopMode.PLANAR, [1, 2, 0], False),
                                (TeleopMode.ROTATION, [0, 0, 0], True),
                                (TeleopMode.TRANSLATION_ROTATION, [1, 2, 3], True)]:
        out = make_teleop_eef_cmd(start, tw * 0.001, 1.0, mode, 10.0, 10.0)
        assert np.allclose(out[:3], np.array(moved) * 0.001)
        assert (quat_angle(out[3:], start[3:]) > 0) == turned


def test_speed_limits_scale_without_changing_direction():
    tw = limit_twist([3.0, 4.0, 0, 0, 0, 2.0], max_pos_speed=0.5, max_rot_speed=1.0)
    assert np.allclose(tw, [0.3, 0.4, 0, 0, 0, 1.0])
    p = np.array([0, 0, 0, 1, 0, 0, 0.0])
    for _ in range(30):  # 1 s at 30 Hz with a device asking for 1 m/s
        p = make_teleop_eef_cmd(p, [1.0, 0, 0, 0, 0, 0], 1 / 30, TeleopMode.TRANSLATION, 0.1, 1.0)
    assert abs(p[0] - 0.1) < 1e-9


def test_workspace_clamps_the_target():
    p = make_teleop_eef_cmd([0, 0, 0.1, 1, 0, 0, 0], [0, 0, -1, 0, 0, 0], 1.0, TeleopMode.TRANSLATION, 10, 1,
                            workspace=([-1, -1, 0.02], [1, 1, 1]))
    assert p[2] == pytest.approx(0.02)


def test_mode_parsing_switching_and_debounce():
    assert TeleopMode.parse("2d") is TeleopMode.PLANAR and TeleopMode.parse("translation+rotation") is \
        TeleopMode.TRANSLATION_ROTATION
    with pytest.raises(ValueError, match="modes:"):
        TeleopMode.parse("sideways")
    sw = ModeSwitch(TeleopMode.TRANSLATION, debounce_s=0.3)
    assert sw.update(True, 1.0) is TeleopMode.TRANSLATION_ROTATION
    assert sw.update(True, 1.1) is TeleopMode.TRANSLATION_ROTATION  # bounce ignored
    assert sw.update(True, 1.5) is TeleopMode.PLANAR
    assert sw.update(False, 3.0) is TeleopMode.PLANAR


def test_button_edges_fire_once_per_press():
    e = ButtonEdges()
    seq = [[0, 0], [1, 0], [1, 0], [0, 1], [1, 1]]
    got = [e(b).tolist() for b in seq]
    assert got == [[False, False], [True, False], [False, False], [False, True], [True, False]]


# -- the hardware-free devices' signal logic ----------------------------------------------------------
def test_scripted_moves_sum_to_the_plan_at_any_loop_rate():
    from rio.teleop.scripted import ScriptedTeleopConfig, build_script, bump

    moves = build_script(ScriptedTeleopConfig())
    total = np.sum([m.delta for m in moves], axis=0)
    assert np.allclose(total, 0.0)  # pick and place returns to the start
    grips = [m.gripper for m in moves]
    assert 0.0 in grips and grips[0] == 1.0 and grips[-1] == 1.0
    for m in moves:  # peak speed within the configured speed
        assert np.linalg.norm(m.delta) * 2 / m.seconds <= 0.08 + 1e-9
    # the loop's trapezoid rule over a 100 Hz device's jittery timestamps lands on the displacement
    seconds, delta = 1.3, 0.1
    ts = np.clip(np.arange(0.0, seconds + 0.01, 0.01) + RNG.uniform(-0.002, 0.002, 131), 0, seconds)
    ts = np.unique(np.concatenate([[0.0, seconds], ts]))
    v = np.array([delta * bump(t, seconds) for t in ts])
    area = float(np.sum(0.5 * (v[1:] + v[:-1]) * np.diff(ts)))
    assert abs(area - delta) < 1e-3 * delta


def test_keyboard_keys_to_twist_gripper_and_buttons():
    from rio.teleop.keyboard import KeyTwist

    k = KeyTwist(speed=0.05, rot_speed=0.5, hold_s=0.15)
    k.press("w", 0.0)
    k.press("j", 0.0)
    s = k.state(0.1)
    assert np.allclose(s["twist"], [0.05, 0, 0, 0, 0, 0.5]) and s["gripper"] == 1.0
    assert np.allclose(k.state(0.2)["twist"], 0)  # released (no repeat within hold_s)
    k.press(" ", 0.3)
    k.press("m", 0.3)
    s = k.state(0.35)
    assert s["gripper"] == 0.0 and s["buttons"].tolist() == [True, False]
    k.press("q", 0.4)
    assert k.state(0.5)["buttons"].tolist() == [False, True]


def test_linear_interpolator_elements_take_targets_separately():
    """One interpolator carries values whose targets arrive on their own (the sim world's actuators)."""
    li = LinearInterpolator([0.0, 0.0, 0.0], t=0.0)
    li.set_target([1.0, 9.0, 2.0], t_target=[1.0, 9.0, 2.0], t_now=0.0, where=[True, False, True])
    assert np.allclose(li.sample(0.5), [0.5, 0.0, 0.5])
    li.set_target([0.0, 4.0, 0.0], t_target=1.5, t_now=0.5, where=[False, True, False])  # the others keep moving
    assert np.allclose(li.sample(1.0), [1.0, 2.0, 1.0])
    assert np.allclose(li.sample(3.0), [1.0, 4.0, 2.0]) and li.t_goal == 2.0
    with pytest.raises(ValueError, match="shape"):
        li.set_target([1.0], 1.0, 0.0)


def test_quat_to_euler_inverts_euler_to_quat():
    from rio.control import quat_to_euler

    rng = np.random.default_rng(3)
    for rpy in [*rng.uniform([-3, -1.5, -3], [3, 1.5, 3], size=(50, 3)), (np.pi, 0.0, 0.0), (0.3, -0.2, 2.9)]:
        back = quat_to_euler(euler_to_quat(*rpy))
        assert np.allclose(euler_to_quat(*back), euler_to_quat(*rpy)) or np.allclose(
            euler_to_quat(*back), -euler_to_quat(*rpy))
        assert abs(back[1] - rpy[1]) < 1e-9
    lock = quat_to_euler(euler_to_quat(0.4, np.pi / 2, 0.1))  # gimbal lock: one rotation about z remains
    assert np.allclose(np.abs(euler_to_quat(*lock) @ euler_to_quat(0.4, np.pi / 2, 0.1)), 1.0)
