"""``lfd info rec.mcap``: what a recording holds (channels, objects, labels, metadata, damage);
``lfd info default|paper|TEMPLATES.json``: a segmentation method (:class:`lfd.Method`)."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from ._options import (
    add_json_argument,
    add_recording_arguments,
    capped,
    check_json,
    console,
    json_to_stdout,
    load_options,
    write_json,
)

NAME = "info"
HELP = (
    "Summarise a recording (channels, duration, objects, skill labels, metadata, damage) or a "
    "segmentation method (default, paper or a template file)."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "recording",
        help="an lfd MCAP recording, a ROS bag with --map (docs/ros.md), or a method: default, "
        "paper or a template file (.json)",
    )
    parser.add_argument(
        "--check",
        action="store_true",
        help="also read the tracks: how far each object moves, the hand's closest approach to "
        "an object, and what segmenting will meet (without it only the file's summary section "
        "and its label channels are read)",
    )
    add_json_argument(parser, "the summary")
    add_recording_arguments(parser)


def run(args: argparse.Namespace) -> int:
    check_json(args, inputs=[p for p in (args.recording, args.map) if p])
    if args.recording in ("default", "paper") or str(args.recording).endswith(".json"):
        return _method(args)
    from ..io import summarise

    s = summarise(args.recording, **load_options(args), check=args.check)
    if args.json:
        write_json(args.json, s)
    from rich.markup import escape
    from rich.table import Table

    con = console(args)
    state = "[green]complete[/]" if s["complete"] else f"[red]damaged[/] ({escape(s['damage'])})"
    con.print(
        f"[bold]{s['path']}[/]  {s['file_size'] / 1024:.1f} KiB, {s['messages']} messages, "
        f"{s['duration_s']:.2f} s, {state}"
    )
    table = Table(title="channels")
    for col in ("topic", "schema", "messages", "rate Hz", "from s", "to s"):
        table.add_column(col, justify="right" if col not in ("topic", "schema") else "left")
    for c in s["channels"]:
        span = [f"{v:.2f}" if v is not None else "-" for v in (c["first_s"], c["last_s"])]
        table.add_row(c["topic"], c["schema"], str(c["count"]), f"{c['rate_hz']:.2f}", *span)
    con.print(table)
    if s.get("source") == "scan":
        con.print("no summary section (the writer was not closed): every message was read")
    if s.get("objects"):
        ot = Table(title="objects")
        checked = all("travel_m" in o for o in s["objects"])
        for col in ("name", "tag", "size (m)", "samples", *(["moves (m)"] if checked else [])):
            ot.add_column(col)
        for o in s["objects"]:
            size = " x ".join(f"{v:.3f}" for v in o["size"])
            travel = [f"{o['travel_m']:.3f}"] if checked else []
            ot.add_row(o["name"], str(o["tag_id"]), size, str(o["samples"]), *travel)
        con.print(ot)
        near = s.get("hand_approach") or {}
        if near.get("object") is not None:
            who = f"{near['hand']} hand" if len(s.get("hands") or []) > 1 else "hand"
            con.print(
                f"{who}: closest {near['distance_m']:.3f} m to an object ({near['object']} at "
                f"{near['t_s']:.2f} s)"
            )
    two = len(s.get("hands") or []) > 1
    if two:
        con.print(
            "hands: "
            + ", ".join(f"{h['side']} {h['samples']} @ {h['rate_hz']:.1f} Hz" for h in s["hands"])
        )
    for key, title in (("labels", "ground-truth skills"), ("live_segments", "live segments")):
        if s.get(key):
            _labels(con, s[key], title, [h["side"] for h in s["hands"]] if two else [])
    if s.get("handovers"):
        _handovers(con, s["handovers"])
    if s.get("metadata"):
        con.print("metadata: " + ", ".join(_short(k, v) for k, v in s["metadata"].items()))
    if s.get("camera"):
        con.print(f"camera: {s['camera']['width']} x {s['camera']['height']}")
    if args.json and not json_to_stdout(args):
        con.print(f"wrote {args.json}")
    for w in [*s["warnings"], *s["problems"]]:  # loading, then what segmenting will meet
        print(f"lfd info: warning: {' '.join(str(w).split())}", file=sys.stderr)
    if s["error"]:
        print(f"lfd info: error: {' '.join(str(s['error']).split())}", file=sys.stderr)
        return 2
    return 0


def _labels(con: Any, labels: list[dict[str, Any]], title: str, sides: list[str]) -> None:
    """A table of skill labels (a hand column for two hands) and each hand's sequence."""
    from rich.table import Table

    shown, more = capped(labels, (lab["skill"] for lab in labels))
    lt = Table(title=title)
    for col in ("#", *(["hand"] if sides else []), "skill", "object", "start s", "end s"):
        lt.add_column(col)
    for i, lab in enumerate(shown):
        lt.add_row(
            str(i + 1),
            *([lab["hand"] or "-"] if sides else []),
            lab["skill"],
            lab["object"] or "-",
            f"{lab['start_s']:.2f}",
            f"{lab['end_s']:.2f}",
        )
    con.print(lt)
    if more:
        con.print(more)
    elif not sides:
        con.print("sequence: " + " -> ".join(lab["skill"] for lab in labels))
    for side in sides:
        lane = [lab["skill"] for lab in labels if lab["hand"] == side]
        con.print(f"{side} hand: " + (" -> ".join(lane) or "no labels"))


def _handovers(con: Any, handovers: list[dict[str, Any]]) -> None:
    """A table of a two-hand recording's handovers."""
    from rich.table import Table

    ht = Table(title="handovers")
    for col in ("#", "giver", "taker", "object", "start s", "end s"):
        ht.add_column(col)
    for i, h in enumerate(handovers):
        ht.add_row(
            str(i + 1),
            h["giver"],
            h["taker"],
            h["object"] or "-",
            f"{h['start_s']:.2f}",
            f"{h['end_s']:.2f}",
        )
    con.print(ht)


def _short(key: str, value: object) -> str:
    """``key=value`` in JSON, or the size of a long value (``--json`` has it whole)."""
    text = json.dumps(value, default=str)
    if len(text) <= 80:
        return f"{key}={text}"
    if isinstance(value, list):
        return f"{key}=({len(value)} items)"
    if isinstance(value, dict):
        return f"{key}=({len(value)} keys)"
    return f"{key}=({len(text)} characters)"


def _method(args: argparse.Namespace) -> int:
    """Print (and with --json write) a segmentation method: :meth:`lfd.Method.describe`."""
    from rich.table import Table

    from ..segmentation import Method

    doc = Method.load(args.recording).describe()
    if args.json:
        write_json(args.json, doc)
    con = console(args)
    table = Table(title=f"method {doc['name']}")
    table.add_column("setting")
    table.add_column("value")
    table.add_row("search", doc["search"])
    table.add_row("grammar", doc["grammar"])
    table.add_row("skills", ", ".join(doc["templates"]["skills"]))
    table.add_row("features", ", ".join(doc["templates"]["features"]))
    for key, value in doc["preprocessing"].items():
        table.add_row(f"preprocessing.{key}", str(value))
    for key, value in doc["params"].items():
        table.add_row(f"params.{key}", json.dumps(value))
    con.print(table)
    if args.json and not json_to_stdout(args):
        con.print(f"wrote {args.json}")
    return 0
