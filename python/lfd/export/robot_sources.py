"""Where robot data's episodes come from (``lfd export robot-data``, :mod:`.robot_data`): a
one-hand demonstration on a one-arm robot (:class:`OneArm`) or a two-hand demonstration on a
two-arm robot (:class:`TwoArms`, ALOHA).

:func:`robot_source` loads the recording, takes its task program and refuses, in one line, a
recording that does not fit the robot: a two-hand recording on one arm, a one-hand recording (or
a two-hand one with an idle hand) on two arms. A source draws the layouts
(:func:`lfd.reproduce.randomise.iter_layouts`, of two arms
:func:`lfd.reproduce.two_arms_randomise.iter_two_arm_layouts`: the layouts of ``lfd reproduce
--randomise N``), runs one (:func:`lfd.reproduce.reproduce`, of two arms the plan the layout's
check made, :func:`lfd.reproduce.two_arms.run_two_arm_plan`) and makes the episode of a run
(:func:`.robot_episode.robot_episode`, :func:`.robot_episode.two_arm_episode`).
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import DemonstrationError, UsageError
from .episode import subtask_name
from .robot_episode import Camera, RobotEpisode

CAMERA_NAME = "table"
TWO_ARM_DISTANCE = 1.5
"""The camera's distance (m) from the objects' centre with two arms (one arm: 1.1 m): both
arms' bases are 0.4-0.9 m apart around the objects."""


class OneArm:
    """A one-hand demonstration's program on a one-arm robot."""

    def __init__(self, recording: Path, demo: Any, labels: str, arm: Any) -> None:
        self.arm = arm
        self.traj, self.program, self.task = _program(recording, demo, labels)

    def camera(self, size: tuple[int, int]) -> Camera:
        """Looking at the centre of the objects where the program starts."""
        return _camera_at(self.traj, self.program, size, 1.1)

    def check(self, recording: Path, mode: str) -> None:
        """Refuse a demonstration the robot cannot do where it was shown (an object out of
        reach, a goal off the table: :func:`lfd.reproduce.displacement.plan_layout`, as ``lfd
        reproduce``), at once: drawing layouts around it would be refused draw after draw."""
        from ..reproduce import program_start
        from ..reproduce.displacement import plan_layout
        from ..reproduce.goals import DemoFrames

        traj, program = self.traj, self.program
        start = program_start(traj, program)
        frames = DemoFrames(traj, np.zeros(3), self.arm)
        seen = np.isfinite(np.asarray(traj.object_position)[:, start, :]).all(axis=1)
        # every object a layout moves, not moved: checked where it is (reach, table)
        free = [
            n for k, n in enumerate(frames.names) if seen[k] and frames.support_of(n, start) is None
        ]
        try:
            plan_layout(traj, program, mode, {n: (0.0, 0.0, 0.0) for n in free}, robot=self.arm)
        except UsageError as err:
            raise UsageError(
                f"{recording}: the robot cannot do the demonstration as shown: {err}"
            ) from None

    def layouts(self, n: int, settings: dict[str, Any]) -> Iterator[Any]:
        from ..reproduce.randomise import iter_layouts

        return iter_layouts(
            self.traj,
            self.program,
            n,
            seed=settings["seed"],
            max_shift=settings["max_shift_m"],
            max_turn_deg=settings["max_turn_deg"],
            modes=(settings["mode"],),
            robot=self.arm,
        )

    def run(self, displace: dict[str, Any], mode: str) -> Any:
        from ..reproduce import reproduce

        return reproduce(self.traj, self.program, mode, displace=displace, robot=self.arm.name)

    def episode(self, run: Any, fps: int, camera: Camera) -> RobotEpisode:
        from .robot_episode import robot_episode

        return robot_episode(run, fps=fps, camera=camera, task=self.task)

    @staticmethod
    def failures(run: Any) -> list[str]:
        """Why a run failed: its failures, else the objects off target."""
        return list(run.failures) or [f"{o.name} off target" for o in run.objects if not o.success]


class TwoArms:
    """A two-hand demonstration's program (ground-truth labels, each hand's lane) on a two-arm
    robot: each hand's lane to the arm of its side (:mod:`lfd.reproduce.two_arms`)."""

    def __init__(self, recording: Path, demo: Any, robot: Any) -> None:
        from ..preprocessing import preprocess
        from ..reproduce import PREPROCESSING, from_hand_labels
        from ..reproduce.two_arms_randomise import check_busy

        if not demo.labels:
            raise DemonstrationError(f"{recording} has no ground-truth labels")
        self.robot = robot
        self.hands = from_hand_labels(
            demo.labels,
            demo.start_ns,
            sides=demo.sides,
            handovers=demo.handovers,
            objects=demo.objects,
        )
        check_busy(self.hands, robot.name)
        self.trajs = {s: preprocess(demo.one_hand(s), **PREPROCESSING) for s in self.hands.sides}
        lanes = [
            f"{s}: " + ", ".join(subtask_name(g.skill, g.object) for g in self.hands.lanes[s])
            for s in self.hands.sides
        ]
        self.task = f"{recording.stem}: {' | '.join(lanes)}"
        self._planned: dict[str, Any] = {}

    def _first(self) -> str:
        return min(
            (s for s in self.hands.sides if self.hands.lanes[s]),
            key=lambda s: self.hands.lanes[s][0].start_s,
        )

    def camera(self, size: tuple[int, int]) -> Camera:
        """Looking at the centre of the objects where the first lane starts, from further
        away than one arm's (both arms in view)."""
        first = self._first()
        return _camera_at(self.trajs[first], self.hands.program(first), size, TWO_ARM_DISTANCE)

    def check(self, recording: Path, mode: str) -> None:
        """Nothing more: the layouts' iterator checks the program on the call (a
        synchronisation the arms do not run, objects that cannot be displaced yet)."""

    def layouts(self, n: int, settings: dict[str, Any]) -> Iterator[Any]:
        from ..reproduce.two_arms_randomise import iter_two_arm_layouts

        return iter_two_arm_layouts(
            self.trajs,
            self.hands,
            n,
            modes=(settings["mode"],),
            seed=settings["seed"],
            max_shift=settings["max_shift_m"],
            max_turn_deg=settings["max_turn_deg"],
            robot=self.robot,
            planned=self._planned,
        )

    def run(self, displace: dict[str, Any], mode: str) -> Any:
        """The plan the layout's check made (the same as planning it again), run."""
        from ..reproduce.two_arms import reproduce_two_arms, run_two_arm_plan

        plan = self._planned.pop(mode, None)
        if plan is None:
            return reproduce_two_arms(
                self.trajs, self.hands, mode, robot=self.robot, displace=displace
            )
        return run_two_arm_plan(plan, self.robot)

    def episode(self, run: Any, fps: int, camera: Camera) -> RobotEpisode:
        from .robot_episode import two_arm_episode

        return two_arm_episode(run, fps=fps, camera=camera, task=self.task)

    @staticmethod
    def failures(run: Any) -> list[str]:
        return list(run.failures)


def robot_source(recording: Path, labels: str, robot: Any) -> OneArm | TwoArms:
    """The source of ``recording``'s episodes on ``robot`` (a :class:`~lfd.reproduce.robots.
    Robot` or :class:`~lfd.reproduce.aloha.TwoArmRobot`).

    Raises
    ------
    UsageError
        A two-hand recording on one arm, a one-hand recording (or an idle hand) on two arms,
        ``labels`` ``segment`` on two arms.
    DemonstrationError
        No labels, or a program with no skills.
    """
    from ..io import load
    from ..reproduce.aloha import TwoArmRobot

    two = isinstance(robot, TwoArmRobot)
    if two and labels != "ground-truth":
        raise UsageError(
            f"--labels {labels} with --robot {robot.name}: two arms run a two-hand recording's "
            "ground-truth labels"
        )
    demo = load(recording, images=False)
    hands = " and ".join(demo.sides)
    if two and len(demo.sides) < 2:
        raise UsageError(
            f"{recording}: a one-hand demonstration (the {hands} hand); --robot {robot.name} "
            "has two arms and takes a two-hand recording (one arm: --robot kuka_lwr4 or panda)"
        )
    if not two and len(demo.sides) > 1:
        raise UsageError(
            f"{recording}: a two-hand demonstration ({hands} hands); robot data is made on a "
            "one-arm robot from one hand's program, or on two arms with --robot aloha"
        )
    return TwoArms(recording, demo, robot) if two else OneArm(recording, demo, labels, robot)


def _program(recording: Path, demo: Any, labels: str) -> tuple[Any, Any, str]:
    """The trajectory the robot follows, its one-arm task program and the task's sentence."""
    from ..preprocessing import preprocess
    from ..reproduce import PREPROCESSING, from_labels, from_segmentation

    if labels == "segment":
        from ..segmentation import segment

        result = segment(demo)
        if result.run is None:
            raise DemonstrationError(f"{recording}: the segmentation kept no trajectory")
        traj = result.run.trajectory
        program = from_segmentation(result, int(traj.t_ns[0]))
    else:
        if not demo.labels:
            raise DemonstrationError(
                f"{recording} has no ground-truth labels; use --labels segment"
            )
        traj = preprocess(demo, **PREPROCESSING)
        program = from_labels(demo.labels, int(traj.t_ns[0]))
    if not program.segments:
        raise DemonstrationError(f"{recording}: the task program has no skills")
    steps = ", ".join(subtask_name(s.skill, s.object) for s in program.segments)
    return traj, program, f"{recording.stem}: {steps}"


def _camera_at(traj: Any, program: Any, size: tuple[int, int], distance: float) -> Camera:
    """The dataset's camera: looking at the centre of the objects where ``program`` starts."""
    from ..reproduce import program_start

    start = program_start(traj, program)
    pos = np.asarray(traj.object_position)[:, start, :]
    centre = np.nanmean(pos[np.isfinite(pos).all(axis=1)], axis=0)
    lookat = (float(centre[0]), float(centre[1]), 0.05)
    return Camera(CAMERA_NAME, lookat, *size, distance=distance)
