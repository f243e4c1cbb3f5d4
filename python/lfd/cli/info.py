"""``lfd info rec.mcap``: what a recording holds (channels, objects, labels, metadata, damage)."""

from __future__ import annotations

import argparse
import json
import sys
import warnings

from ._options import add_json_argument, check_json, console, json_to_stdout, write_json

NAME = "info"
HELP = "Summarise a recording: channels, duration, objects, skill labels, metadata, damage."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("recording", help="an lfd MCAP recording")
    add_json_argument(parser, "the summary")


def _fmt_t(t_ns: int, t0: int) -> str:
    return f"{(t_ns - t0) * 1e-9:7.2f}"


def summarise(path: str) -> dict:
    """A JSON-able summary of a recording (used by ``lfd info``)."""
    from ..errors import LfdError
    from ..io import load, scan

    raw = scan(path)
    firsts = [c.first_ns for c in raw.channels.values() if c.first_ns is not None]
    t0 = min(firsts) if firsts else 0
    summary: dict = {
        "path": raw.path,
        "file_size": raw.file_size,
        "library": raw.library,
        "complete": raw.complete,
        "damage": raw.error,
        "messages": raw.message_count,
        "duration_s": raw.span_s,
        "start_ns": t0,
        "channels": [
            {
                "topic": c.topic,
                "schema": c.schema,
                "count": c.count,
                "rate_hz": round(c.rate_hz, 3),
                "first_s": None if c.first_ns is None else (c.first_ns - t0) * 1e-9,
                "last_s": None if c.last_ns is None else (c.last_ns - t0) * 1e-9,
            }
            for c in sorted(raw.channels.values(), key=lambda c: c.topic)
        ],
        "metadata_records": raw.metadata,
        "warnings": [],
        "error": None,
    }
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            demo = load(path, images=False)
        except LfdError as err:
            summary["error"] = str(err)
            demo = None
    summary["warnings"] = [str(w.message) for w in caught]
    if demo is not None:
        summary["objects"] = [
            {"name": o.name, "tag_id": o.tag_id, "size": o.size.tolist(), "samples": len(o)}
            for o in demo.objects.values()
        ]
        summary["labels"] = [
            {
                "skill": lab.skill,
                "object": lab.object,
                "start_s": (lab.start_ns - t0) * 1e-9,
                "end_s": (lab.end_ns - t0) * 1e-9,
            }
            for lab in demo.labels
        ]
        summary["metadata"] = {k: v for k, v in demo.metadata.items() if k != "load_report"}
        summary["camera"] = (
            None
            if demo.camera is None
            else {"width": demo.camera.width, "height": demo.camera.height}
        )
    return summary


def run(args: argparse.Namespace) -> int:
    check_json(args, inputs=[args.recording])
    s = summarise(args.recording)
    if args.json:
        write_json(args.json, s)
    from rich.table import Table

    con = console(args)
    state = "[green]complete[/]" if s["complete"] else f"[red]damaged[/] ({s['damage']})"
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
    if s.get("objects"):
        ot = Table(title="objects")
        for col in ("name", "tag", "size (m)", "samples"):
            ot.add_column(col)
        for o in s["objects"]:
            size = " x ".join(f"{v:.3f}" for v in o["size"])
            ot.add_row(o["name"], str(o["tag_id"]), size, str(o["samples"]))
        con.print(ot)
    if s.get("labels"):
        lt = Table(title="ground-truth skills")
        for col in ("#", "skill", "object", "start s", "end s"):
            lt.add_column(col)
        for i, lab in enumerate(s["labels"]):
            lt.add_row(
                str(i + 1),
                lab["skill"],
                lab["object"] or "-",
                f"{lab['start_s']:.2f}",
                f"{lab['end_s']:.2f}",
            )
        con.print(lt)
        con.print("sequence: " + " -> ".join(lab["skill"] for lab in s["labels"]))
    if s.get("metadata"):
        con.print("metadata: " + json.dumps(s["metadata"], default=str))
    if s.get("camera"):
        con.print(f"camera: {s['camera']['width']} x {s['camera']['height']}")
    if args.json and not json_to_stdout(args):
        con.print(f"wrote {args.json}")
    for w in s["warnings"]:
        print(f"lfd info: warning: {' '.join(str(w).split())}", file=sys.stderr)
    if s["error"]:
        print(f"lfd info: error: {' '.join(str(s['error']).split())}", file=sys.stderr)
        return 2
    return 0
