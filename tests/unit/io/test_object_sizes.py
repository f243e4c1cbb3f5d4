"""Recordings in lfd's layout whose objects carry no size (files of other tools): the default
cube with a warning, sizes from ``object_sizes`` / ``--object-size``, the sidecar file or the
metadata record, in that order."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings
from pathlib import Path

import _paths
import lfd
import numpy as np
import pytest
from lfd.errors import DefaultSizeWarning, UsageError
from lfd.io.sizes import DEFAULT_OBJECT_SIZE, sidecar_path
from mcap.reader import make_reader
from mcap.writer import Writer

ROOT = _paths.ROOT
EXP1 = ROOT / "recordings" / "exp1.mcap"
TRUE = {"box_1": (0.05, 0.05, 0.05), "box_2": (0.06, 0.04, 0.04), "box_3": (0.04, 0.04, 0.07)}


def strip_sizes(src: Path, dst: Path, *, keep: tuple[str, ...] = ()) -> Path:
    """``src`` copied record by record with the object sizes removed (but those of ``keep``)
    from the ``demo`` metadata record and the pose channels' metadata."""
    with open(src, "rb") as f, open(dst, "wb") as out:
        reader = make_reader(f)
        w = Writer(out)
        w.start(profile="", library="another tool")
        for md in reader.iter_metadata():
            meta = dict(md.metadata)
            if md.name == "demo":
                objs = json.loads(meta["objects"])
                for o in objs:
                    if o["name"] not in keep:
                        del o["size"]
                meta["objects"] = json.dumps(objs)
            w.add_metadata(md.name, meta)
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        for schema, ch, msg in reader.iter_messages(log_time_order=False):
            assert schema is not None
            if schema.id not in schemas:
                schemas[schema.id] = w.register_schema(schema.name, schema.encoding, schema.data)
            if ch.id not in channels:
                meta = {k: v for k, v in ch.metadata.items() if k != "size"}
                channels[ch.id] = w.register_channel(
                    ch.topic, ch.message_encoding, schemas[schema.id], meta
                )
            w.add_message(channels[ch.id], msg.log_time, msg.data, msg.publish_time)
        w.finish()
    return dst


@pytest.fixture(scope="module")
def reference() -> list[tuple[str, str | None, float, float]]:
    return _skills(lfd.segment(lfd.load(EXP1, images=False)))


def _skills(seg: lfd.Segmentation) -> list[tuple[str, str | None, float, float]]:
    return [(s.skill, s.object, round(s.start_s, 6), round(s.end_s, 6)) for s in seg.segments]


def _sizes(demo: lfd.Demonstration) -> dict[str, tuple[float, ...]]:
    return {n: tuple(o.size.tolist()) for n, o in demo.objects.items()}


def test_no_sizes_default_cube_one_warning_per_object(tmp_path: Path, reference) -> None:
    path = strip_sizes(EXP1, tmp_path / "nosize.mcap")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        demo = lfd.load(path, images=False)
    texts = sorted(str(w.message) for w in caught if w.category is DefaultSizeWarning)
    assert len(texts) == 3, [str(w.message) for w in caught]
    assert texts[0].startswith(
        "object box_1 has no size; using 0.05 m cube, give it with --object-size box_1=X,Y,Z"
    )
    assert _sizes(demo) == dict.fromkeys(TRUE, DEFAULT_OBJECT_SIZE)
    # the tracks themselves are the original's
    orig = lfd.load(EXP1, images=False)
    np.testing.assert_array_equal(demo.hand.keypoints, orig.hand.keypoints)
    for name, o in orig.objects.items():
        np.testing.assert_array_equal(demo.objects[name].position, o.position)
    # exp1 segments to the same skills with the default cubes as with its true sizes (the
    # contact boundaries measured on the boxes within 0.1 s)
    got = _skills(lfd.segment(demo))
    assert [s[:2] for s in got] == [s[:2] for s in reference]
    assert np.allclose([s[2:] for s in got], [s[2:] for s in reference], atol=0.1)


def test_sizes_given_sidecar_metadata_in_that_order(tmp_path: Path, reference) -> None:
    path = strip_sizes(EXP1, tmp_path / "nosize.mcap", keep=("box_3",))
    # the metadata record still sizes box_3; the sidecar box_2 and box_3; the argument box_1
    Path(sidecar_path(path)).write_text(
        "[sizes]\nbox_2 = [0.06, 0.04, 0.04]\nbox_3 = [0.09, 0.09, 0.09]\n", encoding="utf-8"
    )
    assert sidecar_path(path) == f"{path}.sizes.toml"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # every object sized: no warning
        demo = lfd.load(path, images=False, object_sizes={"box_1": (0.05, 0.05, 0.05)})
    assert _sizes(demo) == {**TRUE, "box_3": (0.09, 0.09, 0.09)}  # sidecar over metadata
    demo = lfd.load(path, images=False, object_sizes=TRUE)  # the argument over both
    assert _sizes(demo) == TRUE
    assert _skills(lfd.segment(demo)) == reference
    Path(sidecar_path(path)).unlink()
    with pytest.warns(DefaultSizeWarning) as rec:
        demo = lfd.load(path, images=False)
    assert {str(w.message).split()[1] for w in rec} == {"box_1", "box_2"}
    assert _sizes(demo)["box_3"] == TRUE["box_3"]  # from the metadata record


@pytest.mark.parametrize(
    ("sizes", "sidecar", "match"),
    [
        ({"box_9": (0.1, 0.1, 0.1)}, None, "'box_9'.*its objects are box_1, box_2, box_3"),
        ({"box_1": (0.1, 0.0, 0.1)}, None, "positive finite"),
        ({"box_1": (0.1, float("nan"), 0.1)}, None, "positive finite"),
        ({"box_1": (0.1, 0.1)}, None, "three positive"),
        (None, "[sizes]\nbox_7 = [0.1, 0.1, 0.1]\n", "'box_7'.*its objects are box_1"),
        (None, "[sizes]\nbox_1 = [0.1, -1, 0.1]\n", "sizes.box_1"),
        # longer than any object a hand handles (a hang, a MemoryError or an overflow later)
        ({"box_1": (0.05, 0.05, 1e3)}, None, "each at most 2 m"),
        (None, "[sizes]\nbox_1 = [1e300, 1, 1]\n", "sizes.box_1: .*each at most 2 m"),
        (None, "[sizes\n", "not valid TOML"),
        (None, "box_1 = [0.1, 0.1, 0.1]\n", "unknown key 'box_1'"),
    ],
)
def test_bad_sizes_are_usage_errors(tmp_path: Path, sizes, sidecar, match) -> None:
    path = strip_sizes(EXP1, tmp_path / "nosize.mcap")
    if sidecar is not None:
        Path(sidecar_path(path)).write_text(sidecar, encoding="utf-8")
    with pytest.raises(UsageError, match=match):
        lfd.load(path, images=False, object_sizes=sizes)


def _cli(*argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "lfd.cli", *argv], capture_output=True, text=True, timeout=120
    )


def test_cli_object_size(tmp_path: Path, reference) -> None:
    path = strip_sizes(EXP1, tmp_path / "nosize.mcap")
    out = tmp_path / "seg.json"
    given = [f"--object-size={n}={','.join(map(str, s))}" for n, s in TRUE.items()]
    proc = _cli("segment", str(path), *given[:2], "--json", str(out))
    assert proc.returncode == 0, proc.stderr
    # box_3 is not given: one warning line, for it alone
    assert proc.stderr.splitlines() == [
        line for line in proc.stderr.splitlines() if "box_3 has no size" in line
    ]
    assert len(proc.stderr.splitlines()) == 1
    proc = _cli("segment", str(path), *given, "--json", str(out))
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr
    doc = json.loads(out.read_text())
    got = [(s["skill"], s["object"], round(s["start_s"], 6), round(s["end_s"], 6))
           for s in doc["segments"]]  # fmt: skip
    assert got == reference
    info = _cli("info", str(path), *given, "--json", "-")
    assert info.returncode == 0, info.stderr
    objs = {o["name"]: tuple(o["size"]) for o in json.loads(info.stdout)["objects"]}
    assert objs == TRUE


def test_follow_takes_the_same_sizes(tmp_path: Path) -> None:
    """``lfd segment --follow`` (the live segmenter) sizes the objects as lfd.load does."""
    path = strip_sizes(EXP1, tmp_path / "nosize.mcap")
    given = [f"--object-size={n}={','.join(map(str, s))}" for n, s in TRUE.items()]
    docs = []
    for rec, extra in ((EXP1, []), (path, given)):
        out = tmp_path / "f.json"
        proc = _cli("segment", "--follow", str(rec), *extra, "--json", str(out))
        assert proc.returncode == 0 and proc.stderr.strip() == "", proc.stderr
        docs.append(json.loads(out.read_text())["segments"])
    assert docs[0] == docs[1] and len(docs[0]) > 3
    proc = _cli("segment", "--follow", str(path), "--json", str(tmp_path / "g.json"))
    assert proc.returncode == 0, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert len(lines) == 3  # one default-size warning per object
    assert all("has no size; using 0.05 m cube" in line for line in lines)
