"""``lfd reproduce rec.mcap --mode replay|skills|dmp``: execute a demonstration on the robot.

Exit status: 0 = the task was achieved in every requested mode (with ``--randomise N``: on
every layout); 1 = the reproduction ran but the task was not achieved in some mode (the failed
skills and their reasons are printed, and listed in the table's "failed" column and the JSON);
2 = bad input (e.g. a ``--displace`` out of reach or whose re-grounded task would put an object
into another, an unwritable ``--video``, no valid layout for ``--randomise``). With ``--mode all`` the
replay runs as the reference of the path-length ratio: its outcome is reported, and the exit
status judges skills and dmp.
"""

from __future__ import annotations

import argparse
from typing import Any

from ._options import (
    add_json_argument,
    add_recording_arguments,
    add_segmentation_arguments,
    check_json,
    console,
    load_options,
    make_console,
    read_files,
    segmentation_method,
    write_json,
)
from ._types import float_range, layout_count, seed

NAME = "reproduce"
HELP = "Reproduce a demonstration on a simulated 7-DoF arm (replay, skills or DMP) and measure it."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "recording", help="an lfd MCAP recording, or a ROS bag with --map (docs/ros.md)"
    )
    parser.add_argument(
        "other",
        nargs="?",
        metavar="OTHER_HAND",
        help="the other hand's recording of the same take (one file per hand on one clock, e.g. "
        "take.right.mcap take.left.mcap): the two are joined into one two-hand recording "
        "(lfd.io.merge_hands)",
    )
    parser.add_argument(
        "--mode",
        choices=("replay", "skills", "dmp", "all"),
        default="skills",
        help="reproduction method ('all' runs the three and prints a path-length table)",
    )
    parser.add_argument(
        "--displace",
        action="append",
        metavar="NAME:DX,DY[,DEG]",
        help="shift (metres) and optionally turn (degrees) an object's initial pose in the robot "
        "scene (e.g. box_2:0.08,-0.05); every skill's goal follows the objects it is relative to; "
        "refused when it or the re-grounded task puts an object out of reach or into another; "
        "repeatable",
    )
    parser.add_argument(
        "--task",
        metavar="PROGRAM.json",
        help="task program (segments) to execute; default: the recording's ground-truth labels",
    )
    parser.add_argument(
        "--segment",
        action="store_true",
        help="segment the recording with lfd.segment instead of using its ground-truth labels",
    )
    parser.add_argument(
        "--hand",
        choices=("right", "left"),
        help="a two-hand recording: reproduce this hand's part alone (default: the hand that "
        "does all of the task, refused when both hands handle objects)",
    )
    parser.add_argument(
        "--robot",
        default="kuka_lwr4",
        metavar="NAME",
        help="the simulated robot: kuka_lwr4 (default; a KUKA LWR 4+ with a parallel-jaw gripper), "
        "another arm of lfd.reproduce.ROBOTS, e.g. panda (a Franka Panda from robosuite's "
        "models), or two arms, each hand of a two-hand recording to the arm of its side: aloha "
        "(two ViperX 300s arms; needs gym-aloha) or two_pandas (two Pandas, whose hands take "
        "objects up to 72 mm wide); docs/reproduce.md",
    )
    parser.add_argument(
        "--program",
        action="store_true",
        help="print the task program (each hand's skills and, with two hands, where one waits "
        "for the other) and exit without simulating; with --json, its document",
    )
    rnd = parser.add_argument_group("randomised layouts")
    rnd.add_argument(
        "--randomise",
        type=layout_count,
        metavar="N",
        help="run the mode(s) on N layouts (1 to 100000) with every object shifted and turned "
        "(reachable, collision-free), each drawn as it runs, and print the success per mode "
        "and per skill and the failure reasons (with --robot aloha: of a two-hand recording, "
        "on both arms, with each arm's success)",
    )
    rnd.add_argument("--seed", type=seed, default=0, help="--randomise: random seed (default 0)")
    rnd.add_argument(
        "--max-shift",
        type=float_range(0.0, 0.5),
        default=0.10,
        metavar="M",
        help="--randomise: largest shift of an object, metres (default 0.10)",
    )
    rnd.add_argument(
        "--max-turn",
        type=float_range(0.0, 180.0),
        default=45.0,
        metavar="DEG",
        help="--randomise: largest turn of an object, degrees (default 45)",
    )
    add_segmentation_arguments(parser, used_with="with --segment")
    add_recording_arguments(parser)
    add_json_argument(parser, "the task program and the measurements")
    parser.add_argument(
        "--video",
        metavar="OUT.mp4",
        help="render a video of the (last) mode (.mp4 or .avi, written with OpenCV)",
    )
    from ._rerun import add_rerun_arguments

    add_rerun_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from ..reproduce.robots import TWO_ARM_ROBOTS, any_robot, robot

    any_robot(args.robot)  # an unknown robot, or one whose package is missing: one line, first
    if args.program:
        return _print_program(args)
    from .._extras import require

    # every module of the sim extra, before any work: the QP solver (daqp) and the DMPs
    # (movement_primitives) would otherwise be found missing only when a mode runs
    require("sim")
    from rich.progress import Progress

    from ..outputs import check_output
    from ..reproduce import (
        check_displacement,
        check_program,
        parse_displacement,
        program_start,
        reproduce,
        reproduction_report,
    )
    from ..reproduce.video import VIDEO_SUFFIXES, write_video
    from ._rerun import check_rerun_args, close_from_args, open_from_args

    inputs = [p for p in (args.recording, args.other, args.task, args.map) if p]
    if args.randomise:
        from ..errors import UsageError

        clash = [
            opt for opt, used in (("--displace", args.displace), ("--video", args.video)) if used
        ]
        from ._rerun import wants_rerun

        if clash or wants_rerun(args):
            raise UsageError(f"--randomise cannot be combined with {(clash or ['--rerun'])[0]}")
    check_json(args, inputs)
    check_rerun_args(args, inputs)
    err = make_console(stderr=True)  # progress, failures: stderr
    displace = parse_displacement(args.displace)
    loading = load_options(args)
    if args.video:
        reads = read_files(args, *inputs)
        check_output(args.video, inputs=reads, what="--video", suffixes=VIDEO_SUFFIXES)
    show = open_from_args(args, "lfd_reproduce")
    demo = _load_take(args, loading)
    if args.robot in TWO_ARM_ROBOTS:  # two arms (cli/_two_arms.py)
        from ._two_arms import run_two_arms

        return run_two_arms(args, demo, err)
    traj, program, hands = _trajectory_and_program(demo, args)
    if hands is not None:  # the two-hand program, and which hand the one arm does
        for line in [*hands.lines(), f"reproduced: the {_side(hands, args)} hand's part"]:
            err.print(line, highlight=False, markup=False)
    modes = ("replay", "skills", "dmp") if args.mode == "all" else (args.mode,)
    if args.randomise:
        return _run_randomised(args, traj, program, modes, err)
    # refused here, before the progress bar starts, so the error stays one line on stderr
    arm = robot(args.robot)
    check_displacement(traj, displace, program_start(traj, program), robot=arm)
    if any(m != "replay" for m in modes):
        check_program(traj, program, arm)
    results = {}
    # a bar only on a terminal: piped, it would leave an empty line before an error's one line
    with Progress(console=err, transient=True, disable=not err.is_terminal) as bar:
        for mode in modes:
            task = bar.add_task(f"{mode}", total=1.0)

            def tick(i: int, n: int, task: object = task) -> None:
                bar.update(task, completed=i / max(n, 1))  # type: ignore[arg-type]

            fps = 30.0 if args.video and mode == modes[-1] else 0.0
            results[mode] = reproduce(
                traj,
                program,
                mode,
                displace=displace,
                video_fps=fps,
                progress=tick,
                robot=args.robot,
            )
    if show:
        from ..viz import log_demonstration, log_reproduction

        # of two hands, both shown, the trajectory the arm followed as its hand's
        log_demonstration(demo, trajectory=traj if hands is None else {_side(hands, args): traj})
        sizes = {n: o.size for n, o in demo.objects.items()}
        for r in results.values():
            log_reproduction(r, skills=program.skills, object_sizes=sizes)
    close_from_args(args)
    console(args).print(_table(args.recording, program, results))  # stderr under --json -
    for mode, r in results.items():
        if not r.success:
            err.print(f"{mode}: the task was not achieved:", highlight=False)
            for line in r.failures or ["no skill reported a failure"]:
                err.print(f"  {line}", highlight=False, markup=False)
    if args.json:
        doc = reproduction_report(program, results, recording=args.recording)
        if hands is not None:
            doc["hands"] = hands.to_json() | {"reproduced": _side(hands, args)}
        write_json(args.json, doc)
    if args.video:
        ex = results[modes[-1]].execution
        frames = ex.frames if ex is not None else []
        write_video(args.video, frames, fps=30.0, what="--video")
        err.print(f"video: {args.video} ({len(frames)} frames, mode {modes[-1]})")
    # with --mode all, replay is the reference of the path-length ratio, reported but not
    # judged: the exit status says whether the learned task (skills, dmp) was achieved
    judged = [m for m in results if not (args.mode == "all" and m == "replay")]
    return 0 if all(results[m].success for m in judged) else 1


def _trajectory_and_program(demo: Any, args: argparse.Namespace) -> tuple[Any, Any, Any]:
    """What the robot follows: with ``--segment`` the trajectory that was segmented and the
    program of its skills; otherwise the recording preprocessed with ``PREPROCESSING`` and
    the program of ``--task`` or of the ground-truth labels. Of a two-hand recording, the
    part of ``--hand`` or of the hand that does all of the task (else refused, one line), and
    the two-hand program (None for one hand)."""
    from ..preprocessing import preprocess
    from ..reproduce import PREPROCESSING, from_labels, from_segmentation

    if args.segment and args.task:
        from ..errors import UsageError

        raise UsageError("--task PROGRAM and --segment both say what to run; give one")
    _check_hand(demo, args)
    if args.segment:
        result, hands = _segment_checked(demo, args)
        traj = result.run.trajectory
        return traj, from_segmentation(result, int(traj.t_ns[0])), hands
    hands = None
    if len(demo.sides) > 1 and not args.task:
        hands = _hands_program(demo, args)
        demo = demo.one_hand(_side(hands, args))
    elif args.hand or len(demo.sides) > 1:  # --task: the arm follows --hand, else the right
        demo = demo.one_hand(args.hand or demo.sides[0])
    traj = preprocess(demo, **PREPROCESSING)
    t0 = int(traj.t_ns[0])
    program = _task_program(args.task, demo) if args.task else from_labels(demo.labels, t0)
    return traj, program, hands


def _task_program(path: str, demo: Any) -> Any:
    """The ``--task`` program, checked (one line, exit 2) before any work: its layout and
    size (:meth:`~lfd.reproduce.TaskProgram.from_json`) and its times, within ``demo``."""
    from ..reproduce import TaskProgram

    program = TaskProgram.load(path)
    program.check_within((demo.end_ns - demo.start_ns) * 1e-9, f"--task {path}")
    return program


def _check_hand(demo: Any, args: argparse.Namespace) -> None:
    """``--hand`` must name a hand of the recording."""
    if args.hand and args.hand not in demo.sides:
        from ..errors import UsageError

        raise UsageError(
            f"--hand {args.hand}: {args.recording} has no {args.hand} hand "
            f"(it has the {' and '.join(demo.sides)})"
        )


def _hands_program(demo: Any, args: argparse.Namespace) -> Any:
    """The two-hand program of the recording's ground truth (times from the first sample)."""
    from ..reproduce import from_hand_labels

    if not demo.labels:
        from ..errors import DemonstrationError

        raise DemonstrationError("the recording has no skill labels; pass --task program.json")
    return from_hand_labels(
        demo.labels,
        demo.start_ns,
        sides=demo.sides,
        handovers=demo.handovers,
        objects=demo.objects,
    )


def _side(hands: Any, args: argparse.Namespace) -> str:
    """The hand the one arm reproduces: ``--hand``, else the one that does all of the task."""
    return str(args.hand or hands.one_arm_side())


def _load_take(args: argparse.Namespace, loading: dict[str, Any]) -> Any:
    """The recording, joined with the other hand's (``OTHER_HAND``) when given."""
    from ..io import load, merge_hands

    demo = load(args.recording, images=False, **loading)
    if args.other:
        demo = merge_hands(demo, load(args.other, images=False, **loading))
    return demo


def _print_program(args: argparse.Namespace) -> int:
    """``--program``: the task program (per hand with two), printed (and ``--json``), nothing
    simulated."""
    from ..errors import UsageError
    from ..reproduce import from_hands, from_labels
    from ._rerun import wants_rerun

    used = (
        ("--randomise", args.randomise),
        ("--video", args.video),
        ("--rerun", wants_rerun(args)),
    )
    clash = [opt for opt, on in used if on]
    if clash:
        raise UsageError(f"--program prints the program and runs nothing; drop {clash[0]}")
    if args.segment and args.task:
        raise UsageError("--task PROGRAM and --segment both say what to run; give one")
    inputs = [p for p in (args.recording, args.other, args.task, args.map) if p]
    check_json(args, inputs)
    demo = _load_take(args, load_options(args))
    _check_hand(demo, args)
    if args.hand:
        demo = demo.one_hand(args.hand)
    if args.task:
        program = _task_program(args.task, demo)
        doc, lines = program.to_json(), _program_lines(program)
    elif args.segment:
        from ..segmentation import segment_hands

        both = segment_hands(demo, method=segmentation_method(args))
        hands = from_hands(both, demo.start_ns, demo.objects)
        doc, lines = hands.to_json(), hands.lines()
    elif len(demo.sides) > 1:
        hands = _hands_program(demo, args)
        doc, lines = hands.to_json(), hands.lines()
    else:
        program = from_labels(demo.labels, demo.start_ns)
        doc, lines = program.to_json(), _program_lines(program)
    con = console(args)
    for line in lines:
        con.print(line, highlight=False, markup=False)
    if args.json:
        write_json(args.json, {"recording": args.recording, "program": doc})
    return 0


def _table(recording: str, program: Any, results: dict[str, Any]) -> Any:
    """The per-mode result table: path, time, slowdown, success, object errors, failures."""
    from rich.table import Table

    table = Table(title=f"{recording}: {' '.join(program.skills)}")
    cols = (
        "mode",
        "path length (m)",
        "ratio",
        "time (s)",
        "slower",
        "success",
        "objects",
        "failed",
    )
    for col in cols:
        table.add_column(col)
    ref = results["replay"].path_length if "replay" in results else None
    for mode, r in results.items():
        objs = ", ".join(
            f"{o.name} {o.position_error * 1000:.1f} mm/{o.rotation_error_deg:.1f}°"
            + ("" if o.success else " ✗")
            for o in r.objects
        )
        ratio = f"{100 * r.path_length / ref:.1f}%" if ref else "-"
        table.add_row(
            mode,
            f"{r.path_length:.4f}",
            ratio,
            f"{r.execution_time_s:.1f}",
            # robot time / demonstrated time (the plan is slowed to the arm's limits)
            f"{r.slowdown:.1f}x" if r.slowdown else "-",
            "yes" if r.success else "no",
            objs,
            # which skill failed and its first reason (all of them below and in --json)
            "; ".join(f"{sk.label()}: {sk.reasons[0]}" for sk in r.skills if not sk.ok) or "-",
        )
    return table


def _run_randomised(
    args: argparse.Namespace, traj: Any, program: Any, modes: tuple[str, ...], err: Any
) -> int:
    """``--randomise N``: every mode on N layouts; a success table per mode and skill."""
    from rich.progress import Progress

    from ..reproduce import random_layouts, reproduce_randomised
    from ..reproduce.robots import robot

    # drawn (and refused, one line) before the progress bar starts
    random_layouts(
        traj,
        program,
        1,
        seed=args.seed,
        max_shift=args.max_shift,
        max_turn_deg=args.max_turn,
        modes=modes,
        robot=robot(args.robot),
    )
    with Progress(console=err, transient=True, disable=not err.is_terminal) as bar:
        task = bar.add_task("layouts", total=1.0)

        def tick(i: int, n: int) -> None:
            bar.update(task, completed=i / max(n, 1))

        res = reproduce_randomised(
            traj,
            program,
            args.randomise,
            modes=modes,
            seed=args.seed,
            max_shift=args.max_shift,
            max_turn_deg=args.max_turn,
            progress=tick,
            robot=args.robot,
        )
    from ._randomised import randomised_report

    skills = list(dict.fromkeys(program.skills))
    return randomised_report(args, res, skills, program.to_json(), err)


def _program_lines(program: Any) -> list[str]:
    """A one-arm task program as text, a line per step (as a hand's steps are printed)."""
    return [
        f"{i:>2} {s.skill:<10} {s.object or '-':<10} {s.start_s:7.2f} - {s.end_s:7.2f} s"
        for i, s in enumerate(program.segments)
    ]


def _segment_checked(demo: Any, args: argparse.Namespace) -> tuple[Any, Any]:
    """``lfd.segment`` of the recording (of two hands: :func:`lfd.segment_hands`, the lane of
    ``--hand`` or of the hand that does all of the task, and the two-hand program), refused
    (one error line, exit 2) when the hand reaches no object or when no object moves but the
    skills found move one (:mod:`lfd.io.checks`): the robot would act on objects the
    demonstrator did not."""
    from ..errors import DemonstrationError
    from ..io.checks import check_hand_reaches, unmoved_objects_message
    from ..reproduce import from_hands
    from ..segmentation import segment, segment_hands

    hands = None
    if len(demo.sides) > 1:
        both = segment_hands(demo, method=segmentation_method(args))
        hands = from_hands(both, demo.start_ns, demo.objects)
        side = _side(hands, args)
        demo, result = demo.one_hand(side), both.lanes[side]
        check_hand_reaches(demo)
    else:
        check_hand_reaches(demo)
        result = segment(demo, method=segmentation_method(args))
    unmoved = unmoved_objects_message(demo, result.skill_sequence)
    if unmoved is not None:
        raise DemonstrationError(
            f"not reproduced: {unmoved} (the robot would move objects the demonstrator did "
            "not; --task PROGRAM runs a program anyway)"
        )
    return result, hands
