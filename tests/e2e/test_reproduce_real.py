"""Reproduction of real human motion: time scaling to the arm's limits, grasps that fit,
and (slow, when ../shared/realmotion exists) real motion-capture crops end to end."""

from __future__ import annotations

import dataclasses

import _paths
import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("mink")


from lfd.errors import UsageError
from lfd.reproduce import check_program, reproduce
from lfd.reproduce.controller import TICK, Plan
from lfd.reproduce.dmp import min_jerk
from lfd.reproduce.timescale import LIMITS, Limits, derivatives, durations, retime
from reproduce_synth import synthetic_demo

ROOT = _paths.ROOT
EXP1 = ROOT / "recordings" / "exp1.mcap"
REAL = ROOT.parent / "shared" / "realmotion"


def _fast_plan() -> Plan:
    """Hold, a 0.5 m move with a half-turn of the wrist in 0.3 s (a person's pace), hold."""
    n = round(0.3 / TICK) + 1
    s = min_jerk(n)[:, None]
    a, b = np.array([0.4, -0.2, 0.15]), np.array([0.6, 0.25, 0.05])
    move = a + s * (b - a)
    pos = np.concatenate([np.repeat(a[None], 20, 0), move, np.repeat(b[None], 20, 0)])
    yaw = np.concatenate([np.zeros(20), 1.5 * s[:, 0], np.full(20, 1.5)])
    opening = np.r_[np.full(20 + n // 2, 0.08), np.zeros(len(pos) - 20 - n // 2)]
    seg = np.r_[np.full(20, 0), np.full(n, 1), np.full(20, -1)]
    return Plan(pos, yaw, opening, seg)


def _distance_to_polyline(p: np.ndarray, line: np.ndarray) -> np.ndarray:
    a, b = line[:-1], line[1:]
    ab = b - a
    t = np.clip(
        np.einsum("kij,ij->ki", p[:, None] - a[None], ab) / np.maximum((ab * ab).sum(1), 1e-18),
        0,
        1,
    )
    near = a[None] + t[..., None] * ab[None]
    return np.asarray(np.linalg.norm(p[:, None] - near, axis=2).min(axis=1))


def test_retime_respects_limits_and_keeps_the_path() -> None:
    plan = _fast_plan()
    v, a = derivatives(plan.position)
    assert np.linalg.norm(v, axis=1).max() > 3 * LIMITS.speed  # the wish is too fast
    out = retime(plan)
    v, a = derivatives(out.position)
    w, al = derivatives(out.yaw[:, None])
    slack = 1.05  # central differences of a re-sampled path
    assert np.linalg.norm(v, axis=1).max() <= LIMITS.speed * slack
    assert np.linalg.norm(a, axis=1).max() <= LIMITS.acceleration * slack
    assert np.abs(w).max() <= LIMITS.yaw_rate * slack
    assert np.abs(al).max() <= LIMITS.yaw_acceleration * slack
    # the same path: same ends, every sample on the planned path, in order, nothing faster
    assert len(out) > 2 * len(plan)
    assert np.allclose(out.position[[0, -1]], plan.position[[0, -1]], atol=1e-9)
    assert np.allclose(out.yaw[[0, -1]], plan.yaw[[0, -1]], atol=1e-9)
    assert _distance_to_polyline(out.position, plan.position).max() < 5e-4
    progress = (out.position - plan.position[0]) @ (plan.position[-1] - plan.position[0])
    assert np.all(np.diff(progress) > -1e-9)
    assert np.all(np.diff(out.yaw) > -1e-9)
    # the gripper command and the segments follow the path: same order, same values
    assert [k for k, _ in _runs(out.segment)] == [0, 1, -1]
    assert [k for k, _ in _runs(out.opening)] == [0.08, 0.0]
    d = durations(out, 2)
    assert d[0] == pytest.approx(20 * TICK, abs=2 * TICK)  # a hold is not slowed down
    assert d[1] > 0.3 * 2


def _runs(x: np.ndarray) -> list[tuple[float, int]]:
    out: list[tuple[float, int]] = []
    for v in x.tolist():
        if out and out[-1][0] == v:
            out[-1] = (v, out[-1][1] + 1)
        else:
            out.append((v, 1))
    return out


def test_retime_leaves_a_slow_plan_alone() -> None:
    plan = _fast_plan()
    slow = retime(plan, Limits(speed=100.0, acceleration=1e4, yaw_rate=100.0, yaw_acceleration=1e4))
    assert len(slow) == len(plan)
    assert np.array_equal(slow.position, plan.position)
    with pytest.raises(ValueError, match="positive"):
        Limits(speed=0.0)


def test_reproduction_reports_the_slowdown() -> None:
    traj, program = synthetic_demo("pick_place")
    r = reproduce(traj, program, "skills")
    assert r.success
    js = r.to_json()
    assert js["slowdown"] == pytest.approx(r.execution_time_s / r.demo_duration_s)
    for s in js["skills"]:
        assert s["robot_s"] > 0 and s["demo_s"] > 0
        assert s["slowdown"] == pytest.approx(s["robot_s"] / s["demo_s"])
    assert sum(s["robot_s"] for s in js["skills"]) == pytest.approx(r.execution_time_s, abs=0.02)


def _widened(traj, name: str, width: float):  # type: ignore[no-untyped-def]
    size = np.array(traj.object_size, dtype=np.float64)
    size[traj.object_names.index(name), :2] = (width, width + 0.01)
    return dataclasses.replace(traj, object_size=size)


def test_too_wide_object_refused_before_running(monkeypatch: pytest.MonkeyPatch) -> None:
    traj, program = synthetic_demo("pick_place")
    wide = _widened(traj, "box_1", 0.12)

    def never(*a: object, **k: object) -> None:
        raise AssertionError("simulated although the grasp cannot fit")

    monkeypatch.setattr("lfd.reproduce.execute", never)
    with pytest.raises(UsageError, match=r"cannot grasp box_1 .*narrowest side is 120 mm"):
        check_program(wide, program)
    for mode in ("skills", "dmp"):
        with pytest.raises(UsageError, match="cannot grasp box_1"):
            reproduce(wide, program, mode)
    check_program(_widened(traj, "box_1", 0.09), program)  # a mug's body still fits


def test_cli_refuses_too_wide_object_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    from lfd.cli import main

    sizes = [f"box_{k}=0.12,0.11,0.05" for k in (1, 2, 3)]
    args = ["reproduce", str(EXP1), "--mode", "skills"]
    for s in sizes:
        args += ["--object-size", s]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("lfd reproduce: error: cannot grasp box_"), err


@pytest.mark.slow
@pytest.mark.skipif(not REAL.is_dir(), reason=f"no real motion capture at {REAL}")
def test_real_crop_reproduced_at_the_arms_pace(capsys: pytest.CaptureFixture[str]) -> None:
    from lfd.cli import main
    from lfd.io import load
    from lfd.preprocessing import preprocess
    from lfd.reproduce import PREPROCESSING, from_labels

    crop = REAL / "manip_cube_med2_12.5-19.2s.mcap"
    demo = load(crop, images=False)
    traj = preprocess(demo, **PREPROCESSING)
    program = from_labels(demo.labels, int(traj.t_ns[0]))
    for mode in ("skills", "dmp"):
        r = reproduce(traj, program, mode)
        assert r.success, r.failures
        # placed where the person placed it (the unfiltered resting pose), within the check
        assert r.objects[0].position_error < 0.005
        track = np.linalg.norm(r.executed_tcp - r.planned_tcp, axis=1)
        assert track.max() < 0.01  # the arm keeps up with the re-timed plan
        assert r.slowdown is not None and r.slowdown > 1.0
    # the teapot's box is wider than the gripper: refused in one line, exit status 2
    teapot = REAL / "manip_teapot2_22.2-27.9s.mcap"
    assert main(["reproduce", str(teapot), "--mode", "dmp"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [err[0]] and "cannot grasp teapot2" in err[0]
