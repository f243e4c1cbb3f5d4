"""``lfd segment rec.mcap``: cut a recording into skills and print them (with ground truth).

``lfd segment A.mcap B.mcap ... | DIR`` segments many recordings in parallel (``--jobs``,
``--ray``; :func:`lfd.batch.run_batch`): one progress bar, a summary table, one error line per
failed recording, and with ``--json`` a list of the single-file documents (docs/batch.md).

``lfd segment --follow rec.mcap`` follows a recording another process (``lfd record``) is still
writing: every sample as its chunk lands (:func:`lfd.io.follow`), shown live in Rerun with the
``--rerun*`` options (:class:`lfd.viz.live.LiveTimeline`), until the recorder closes the file,
the file stops growing (``--idle-timeout``) or Ctrl+C. The online segmenter plugs in at
:func:`segment_stream`.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from ._options import (
    add_batch_options,
    add_json_argument,
    add_recording_arguments,
    add_segmentation_arguments,
    capped,
    check_json,
    console,
    emit_json,
    load_options,
    segmentation_method,
    sigterm_interrupts,
)
from ._types import positive_float

NAME = "segment"
HELP = "Segment a recording into skills (two-stage HMM template matching)."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "recordings",
        nargs="+",
        metavar="RECORDING",
        help="an lfd MCAP recording or a ROS bag with --map (docs/ros.md); several, or a directory (its *.mcap), run as a batch",
    )
    parser.add_argument(
        "--follow",
        action="store_true",
        help="follow a recording that is still being written (lfd record -o REC.mcap): read "
        "each sample as it lands, until the recorder closes the file, it stops growing, or "
        "Ctrl+C",
    )
    parser.add_argument(
        "--idle-timeout",
        type=positive_float,
        default=10.0,
        metavar="SECONDS",
        help="--follow: stop when the file has not grown for this long without its end marker (10)",
    )
    parser.add_argument("--templates", metavar="FILE", help="template file (default: shipped)")
    add_segmentation_arguments(parser)
    add_recording_arguments(parser)
    add_json_argument(parser, "the segments (and metrics against the ground truth)")
    from ._rerun import add_rerun_arguments

    add_rerun_arguments(parser)
    add_batch_options(parser)


def segment_recording(
    args: argparse.Namespace,
    on_loaded: Callable[[Any], Any] | None = None,
    *,
    keep: bool = False,
) -> tuple[Any, Any, dict[str, Any]]:
    """Load, segment and score: returns (demonstration, segmentation, JSON document).

    ``on_loaded(demo)`` is called as soon as the recording is loaded (e.g. to show it). Unless
    ``keep``, the demonstration is dropped once preprocessed (its samples are not needed for
    the search and the report) and None is returned in its place.
    """
    from ..io import load
    from ..segmentation.files import prepare_recording

    demo = load(
        args.recording,
        images=bool(getattr(args, "rerun_session", None)),
        **load_options(args),
    )
    if on_loaded is not None:
        on_loaded(demo)
    if len(demo.sides) > 1:
        from ..segmentation.files import segment_hands_recording

        hands, doc = segment_hands_recording(
            demo, segmentation_method(args), recording=str(args.recording)
        )
        return (demo if keep else None), hands, doc
    prepared = prepare_recording(demo, segmentation_method(args))
    kept = demo if keep else None
    del demo  # its samples are freed here unless kept
    result, doc = prepared.segment(recording=str(args.recording))
    return kept, result, doc


def _show_demo(demo: Any) -> None:
    """Show the recording as soon as it is loaded (the segmented trajectory follows)."""
    from ..viz.pipeline import log_recorded_demo

    log_recorded_demo(demo, trajectory=False)


def segment_stream(
    messages: Iterator[Any], follower: Any, timeline: Callable[[], Any], args: Any
) -> tuple[Any, list[Any], list[int]]:
    """Segment a followed recording as it lands: returns ``(segmentation or None, ground truth
    (labels, and handovers of two hands), settle times ns)``. ``messages`` yields :class:`lfd.io.LiveMessage` s in file order;
    ``follower`` tells the objects and the hand side (:class:`lfd.io.Follower`); ``timeline()``
    is the :class:`lfd.viz.live.LiveTimeline` once one is open (features, settled spans and
    the provisional one are logged to it). Each skill is printed as it settles."""
    from ..errors import RecordingFormatError
    from ..io.camera_pose import FollowedCamera
    from ..segmentation.live import LiveSegmentation
    from ..segmentation.live_hands import LiveHands

    method = segmentation_method(args)
    con = console(args)
    sides: tuple[str, ...] = ()
    seg: LiveSegmentation | LiveHands | None = None
    labels: list[Any] = []
    posed = FollowedCamera(str(args.recording))  # as lfd.load: the record, else the messages
    shown: Any = None  # the camera the segmenter has
    for msg in messages:
        if msg.kind in ("label", "handover"):  # the ground truth
            labels.append(msg.value)
        _skipped(posed.add(msg.kind, msg.value))
        _skipped(posed.read_record(getattr(follower, "metadata", {})))
        camera = posed.camera
        if seg is not None and camera is not shown:
            seg.set_camera(camera)
        shown = camera
        if seg is None and msg.kind in ("hand", "object"):
            objects = _sized(follower.objects, args)
            if not objects:
                raise RecordingFormatError(
                    f"{args.recording}: the recording declares no objects; cannot segment it live"
                )
            names, sizes, tags = (
                [o[0] for o in objects],
                [o[2] for o in objects],
                [o[1] for o in objects],
            )
            meta = follower.demo_metadata
            sides = follow_sides(follower)  # as declared once the file's first records are read
            seg = (
                LiveHands(names, sizes, method=method, sides=sides, tag_ids=tags, metadata=meta)
                if len(sides) > 1
                else LiveSegmentation(
                    names, sizes, method=method, side=sides[0], tag_ids=tags, metadata=meta
                )
            )
            seg.set_camera(camera)
        if seg is None:
            continue
        side = getattr(msg, "side", None)
        if isinstance(seg, LiveHands):  # each hand's frames to its lane
            up: Any = seg.push_recorded(msg.kind, msg.t_ns, msg.value, side=side)
        elif side not in (None, sides[0]):
            continue  # a hand not segmented (a file whose other hand came later)
        else:
            up = seg.push_recorded(msg.kind, msg.t_ns, msg.value)
        _show_update(seg, up, timeline(), con)
    if seg is None:
        return None, labels, []
    _show_update(seg, seg.finish(), timeline(), con)
    for w in seg.warnings:  # those of the final run (the whole recording)
        print(f"lfd segment: warning: {' '.join(str(w).split())}", file=sys.stderr)
    settled = seg.settled_ns
    if isinstance(settled, dict):  # two hands: every hand's, in time order
        settled = sorted(t for ts in settled.values() for t in ts)
    return seg.result(), labels, list(settled)


def _skipped(problems: list[str]) -> None:
    """Print what the followed camera skipped (:class:`lfd.io.camera_pose.FollowedCamera`)."""
    for problem in problems:
        print(f"lfd segment: warning: skipped {problem}", file=sys.stderr)


def follow_sides(follower: Any) -> tuple[str, ...]:
    """The hands of a followed recording (:attr:`lfd.io.Follower.sides`, else its one
    ``hand_side``)."""
    sides = getattr(follower, "sides", None)
    return tuple(sides) if sides else (follower.hand_side,)


def _sized(objects: list[Any], args: Any) -> list[Any]:
    """The followed recording's ``(name, tag, size)`` with the sizes :func:`lfd.load` would
    give them: ``--object-size``, the sidecar, the file's, else the default cube (warned)."""
    from ..io.sizes import resolve_sizes

    sizes = resolve_sizes(
        args.recording, {n: size for n, _, size in objects}, load_options(args)["object_sizes"]
    )
    return [(n, tag, sizes[n]) for n, tag, _ in objects]


def _show_update(seg: Any, update: Any, timeline: Any, con: Any) -> None:
    """Print the skills an update settled (of two hands, each with its hand, and the
    handovers); log it to the live timeline if one is open."""
    lanes = getattr(update, "lanes", None)
    two = lanes is not None and len(seg.sides) > 1
    items = [(side, s) for side, u in lanes.items() for s in u.segments] if lanes is not None else [
        (None, s) for s in update.segments
    ]  # fmt: skip
    for side, s in items:
        con.print(
            f"settled: {f'{side:<6}' if two else ''}{s.skill:<10} {s.object or '-':<8} "
            f"{s.start_s:7.2f} - {s.end_s:7.2f} s  confidence {s.confidence:.2f}"
        )
    for h in getattr(update, "handovers", []):
        con.print(
            f"settled: handover of {h.object or '-'} from the {h.giver} to the {h.taker} hand"
        )
    if timeline is not None:
        spans = getattr(seg, "provisional_spans", None)
        timeline.log_update(update, spans() if spans is not None else seg.provisional_span())


def _run_follow(args: argparse.Namespace) -> int:
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    from ..errors import UsageError
    from ..io import follow
    from ._rerun import check_rerun_args, close_from_args, open_from_args, session_from_args

    inputs = [p for p in (args.recording, args.templates) if p]
    check_json(args, inputs)
    check_rerun_args(args, inputs)
    show = open_from_args(args, "lfd_segment")
    follower = follow(args.recording, idle_timeout_s=args.idle_timeout)
    counts = {"hand": 0, "object": 0}
    state: dict[str, Any] = {"live": None, "first": None, "last": None}

    def stream(progress: Any, task: Any) -> Iterator[Any]:
        from ..viz.live import LiveTimeline

        for msg in follower:
            if show and state["live"] is None:
                rec = session_from_args(args)
                state["live"] = LiveTimeline(
                    rec.recording if rec else None,
                    objects=follower.objects,
                    sides=follow_sides(follower),
                )
            if state["live"] is not None:
                state["live"].log_message(msg)
            counts[msg.kind] = counts.get(msg.kind, 0) + 1
            state["first"] = msg.t_ns if state["first"] is None else state["first"]
            state["last"] = msg.t_ns if state["last"] is None else max(state["last"], msg.t_ns)
            span = (state["last"] - state["first"]) * 1e-9
            progress.update(
                task,
                description=f"{follower.message_count} messages, {span:.1f} s: "
                f"{counts['hand']} hand, {counts['object']} object samples",
            )
            yield msg

    from rich.console import Console

    con = console(args)
    err = Console(stderr=True)
    with sigterm_interrupts():
        # off a terminal no progress line at all (a transient one leaves a blank line on stderr)
        with Progress(
            SpinnerColumn(),
            TextColumn("{task.description}"),
            TimeElapsedColumn(),
            console=err,
            disable=not err.is_terminal,
        ) as progress:
            task = progress.add_task(f"waiting for {args.recording}", total=None)
            try:
                result, labels, settled = segment_stream(
                    stream(progress, task), follower, lambda: state["live"], args
                )
            except KeyboardInterrupt:
                follower.stop_reason = "interrupted"
                result, labels, settled = None, [], []
    how = {
        "end": "the recording was closed",
        "idle": f"the file stopped growing for {args.idle_timeout:g} s",
        "damaged": "a damaged record (the messages before it were read)",
        "interrupted": "interrupted",
    }.get(follower.stop_reason or "", str(follower.stop_reason))
    span = 0.0 if state["first"] is None else (state["last"] - state["first"]) * 1e-9
    con.print(
        f"followed {follower.source or args.recording}: {follower.message_count} messages over "
        f"{span:.1f} s ({counts['hand']} hand, {counts['object']} object samples); "
        f"stopped: {how}"
    )
    lanes = getattr(result, "lanes", None) or ({"": result} if result is not None else {})
    for side, lane in lanes.items():  # of two hands, a line per hand
        con.print(
            (f"{side} hand: " if side else "")
            + f"{len(lane.segments)} skills: "
            + " -> ".join(f"{s.skill}({s.object or '-'})" for s in lane.segments)
        )
    if result is None and (args.json or follower.stop_reason != "interrupted"):
        raise UsageError(f"{args.recording}: nothing to segment (no hand or object samples)")
    if args.json and result is not None:
        from ..demo import Handover, SkillLabel

        truth = [x for x in labels if isinstance(x, SkillLabel)]
        if hasattr(result, "lanes"):  # two hands: as lfd segment's, the lanes and handovers
            given = [x for x in labels if isinstance(x, Handover)]
            doc = result.report(truth, given, recording=str(args.recording))
        else:
            doc = result.report(truth, recording=str(args.recording))
        first = state["first"] or 0
        doc["live"] = {
            "settled_s": [(t - first) * 1e-9 for t in settled],
            "stopped": follower.stop_reason,
        }
        emit_json(args, doc, con)
    close_from_args(args)
    return 0


def run(args: argparse.Namespace) -> int:
    from rich.table import Table

    from ._options import batch_options
    from ._rerun import check_rerun_args, close_from_args, open_from_args

    batch_options(args)  # checked with one recording too (--ray may have taken it)
    if is_batch(args.recordings):
        return _run_batch(args)
    args.recording = args.recordings[0]
    if getattr(args, "follow", False):
        if args.map is not None:
            from ..errors import UsageError

            raise UsageError("--follow reads an lfd recording as it is written; drop --map")
        return _run_follow(args)
    inputs = [p for p in (args.recording, args.templates, args.map) if p]
    check_json(args, inputs)
    check_rerun_args(args, inputs)
    load_options(args)  # a bad --map fails before a viewer opens
    show = open_from_args(args, "lfd_segment")
    demo, result, doc = segment_recording(
        args, on_loaded=_show_demo if show else None, keep=bool(show)
    )
    if show:  # one hand or both (lfd.segment_hands: a lane per hand, the handovers)
        from ..viz.pipeline import log_result

        log_result(demo, result, ground_truth=False)  # labels logged with the recording
    con = console(args)
    if doc.get("hands") is not None:  # two hands: each lane and the handovers
        _print_hands(args, result, doc, con)
        close_from_args(args)
        emit_json(args, doc, con)
        return 0
    table = Table(title=f"{Path(args.recording).name}: {result.method} segmentation")
    for col in ("#", "skill", "start s", "end s", "object", "score", "confidence"):
        table.add_column(col, justify="right" if col not in ("skill", "object") else "left")
    shown, more = capped(result.segments, (s.skill for s in result.segments))
    for n, s in enumerate(shown):
        table.add_row(
            str(n),
            s.skill,
            f"{s.start_s:.2f}",
            f"{s.end_s:.2f}",
            s.object or "-",
            f"{s.score:.2f}",
            f"{s.confidence:.2f}",
        )
    con.print(table)
    if more:
        con.print(more)
    if doc["ground_truth"]:
        gt = Table(title="ground truth")
        for col in ("#", "skill", "start s", "end s", "object"):
            gt.add_column(col)
        truth, more = capped(doc["ground_truth"], (g["skill"] for g in doc["ground_truth"]))
        for n, g in enumerate(truth):
            gt.add_row(
                str(n), g["skill"], f"{g['start_s']:.2f}",
                f"{g['end_s']:.2f}", g["object"] or "-",
            )  # fmt: skip
        con.print(gt)
        if more:
            con.print(more)
        mt = Table(title="metrics")
        mt.add_column("metric")
        mt.add_column("value", justify="right")
        for k, v in doc["metrics"].items():
            mt.add_row(k, "-" if v is None else f"{v:.3f}")
        con.print(mt)
    for w in doc["warnings"]:
        print(f"lfd segment: warning: {' '.join(str(w).split())}", file=sys.stderr)
    close_from_args(args)
    emit_json(args, doc, con)
    return 0


def _print_hands(args: argparse.Namespace, result: Any, doc: dict[str, Any], con: Any) -> None:
    """A two-hand recording: a table per hand's lane, the handovers, the metrics per hand and
    of the handovers, the warnings (stderr)."""
    from rich.table import Table

    name = Path(args.recording).name
    for side, seg in result.lanes.items():
        table = Table(title=f"{name}: {side} hand, {seg.method} segmentation")
        for col in ("#", "skill", "start s", "end s", "object", "confidence"):
            table.add_column(col, justify="right" if col not in ("skill", "object") else "left")
        shown, more = capped(seg.segments, (s.skill for s in seg.segments))
        for n, s in enumerate(shown):
            table.add_row(
                str(n), s.skill, f"{s.start_s:.2f}", f"{s.end_s:.2f}", s.object or "-",
                f"{s.confidence:.2f}",
            )  # fmt: skip
        con.print(table)
        if more:
            con.print(more)
    ho = Table(title="handovers")
    for col in ("giver", "taker", "object", "start s", "end s"):
        ho.add_column(col)
    for h in doc["handovers"]:
        ho.add_row(
            h["giver"], h["taker"], h["object"] or "-", f"{h['start_s']:.2f}", f"{h['end_s']:.2f}"
        )
    con.print(ho)
    if doc["metrics"]:
        mt = Table(title="metrics")
        mt.add_column("metric")
        for side in result.lanes:
            mt.add_column(side, justify="right")
        keys = next(iter(doc["metrics"].values())).keys()
        for k in keys:
            mt.add_row(k, *(_num(doc["metrics"][side].get(k)) for side in result.lanes))
        con.print(mt)
        h = doc["metrics"]["handovers"]
        con.print(
            f"handovers: {int(h['found'])}/{int(h['true'])} found within 0.3 s, "
            f"{int(h['false'])} false",
            highlight=False,
        )
    warnings = [w for seg in result.lanes.values() for w in seg.warnings] + doc["warnings"]
    for w in warnings:
        print(f"lfd segment: warning: {' '.join(str(w).split())}", file=sys.stderr)


def _num(v: Any) -> str:
    return "-" if v is None else f"{v:.3f}"


def is_batch(inputs: list[str]) -> bool:
    """Several inputs, or a folder of recordings: a batch (a JSON list); one file or one ROS 2
    bag directory: the single-file run."""
    from ..batch import is_recording_folder

    return len(inputs) > 1 or any(is_recording_folder(p) for p in inputs)


def _run_batch(args: argparse.Namespace) -> int:
    from functools import partial

    from ..batch import recording_paths, run_batch
    from ..errors import UsageError
    from ..segmentation.files import segment_file
    from ._options import batch_options, batch_progress, report_batch_errors

    if args.follow:
        raise UsageError("--follow follows one recording while it is written; give only one")
    rerun = ("rerun", "rerun_save", "rerun_connect", "rerun_serve")
    if any(getattr(args, a, None) for a in rerun):
        raise UsageError(
            "--rerun* shows one recording; give one recording, or drop --rerun* for a batch"
        )
    paths = recording_paths(args.recordings)
    check_json(args, [*paths, *([args.templates] if args.templates else [])])
    method = segmentation_method(args)
    how = batch_options(args)
    task = partial(segment_file, method=method, load_options=load_options(args))
    with batch_progress(len(paths), "segmenting") as step:
        results = run_batch(task, paths, progress=step, **how)
    con = console(args)
    con.print(batch_table(results, title=f"{len(paths)} recordings"))
    for res in results:  # the segmentation's own warnings, as the single-file run prints them
        if res.value is not None:
            res.warnings = list(dict.fromkeys([*res.warnings, *res.value["warnings"]]))
    status = report_batch_errors("segment", results)
    if args.json:
        emit_json(args, batch_document(results), con)
    return status


def batch_document(results: list[Any]) -> list[dict[str, Any]]:
    """``lfd segment --json`` of a batch: per recording, in input order, its single-file
    document (which names it in ``"recording"``) or ``{"recording", "error"}``."""
    return [r.value if r.ok else {"recording": str(r.item), "error": r.error} for r in results]


def batch_table(results: list[Any], *, title: str) -> Any:
    """The summary of a segmented batch: recording, skills found, exact sequence, seconds,
    error (cut to the width left; the full message follows as an error line)."""
    from rich.table import Table

    table = Table(title=title)
    table.add_column("recording", overflow="fold")
    table.add_column("skills", justify="right", no_wrap=True)
    table.add_column("exact", no_wrap=True)
    table.add_column("seconds", justify="right", no_wrap=True)
    table.add_column("error", overflow="fold")
    for r in results:
        if r.ok:
            docs = list(r.value["hands"].values()) if "hands" in r.value else [r.value]
            matches = [d["metrics"].get("sequence_match") for d in docs]
            exact = "/".join("-" if m is None else ("yes" if m else "no") for m in matches)
            skills = "/".join(str(len(d["segments"])) for d in docs)
            table.add_row(str(r.item), skills, exact, f"{r.seconds:.2f}", "")
        else:
            error = r.error if len(r.error) <= 30 else r.error[:29] + "…"
            table.add_row(str(r.item), "-", "-", f"{r.seconds:.2f}", error)
    ok = sum(r.ok for r in results)
    table.caption = f"{ok} of {len(results)} segmented" + (
        f", {len(results) - ok} failed" if ok < len(results) else ""
    )
    return table
