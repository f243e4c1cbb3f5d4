"""Every numeric option value, template file and ``--params`` a user can get wrong is refused
before any work starts: exit status 2, the reason on stderr, no traceback, no output file.

One table of ``(args, expected text on stderr)``; ``{out}`` is an output path that must not be
created, ``{binary}``, ``{badjson}`` and ``{inverted}`` are bad template files made per test.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]
EXP1 = str(ROOT / "recordings" / "exp1.mcap")
TEMPLATE_RECORDINGS = str(ROOT / "recordings" / "templates")

SIM = ["simulate", "exp1", "-o", "{out}"]
RECORD = ["record", "--source", "sim:exp1", "-o", "{out}"]
TRAIN = ["templates", "train", TEMPLATE_RECORDINGS, "-o", "{out}"]
PTRAIN = ["perception", "train", "--out", "{out}"]

CASES: list[tuple[list[str], str]] = [
    # simulate: seed, durations, rates, variability factors, NaN / inf
    ([*SIM, "--seed", "-1"], "argument --seed: must be an integer in [0, 2**63 - 1], got '-1'"),
    ([*SIM, "--seed", "1.5"], "argument --seed: must be an integer, got '1.5'"),
    ([*SIM, "--duration", "-1"], "argument --duration: must be a number > 0, got '-1'"),
    ([*SIM, "--duration", "0"], "argument --duration: must be a number > 0, got '0'"),
    ([*SIM, "--duration", "nan"], "argument --duration: must be a finite number, got 'nan'"),
    ([*SIM, "--hand-rate", "0"], "argument --hand-rate: must be a number in [0.5, 30]"),
    ([*SIM, "--hand-rate", "inf"], "argument --hand-rate: must be a finite number"),
    ([*SIM, "--render", "--render-rate", "0"], "argument --render-rate: must be a number in (0"),
    ([*SIM, "--render-rate", "500"], "argument --render-rate: must be a number in (0, 30]"),
    ([*SIM, "--speed", "0"], "argument --speed: speed must be in [0.2, 5], got 0.0"),
    ([*SIM, "--hand-scale", "-1"], "argument --hand-scale: variability hand_scale must be"),
    ([*SIM, "--dropout", "2"], "argument --dropout: dropout must be a probability <= 0.9"),
    ([*SIM, "--pauses", "nan"], "argument --pauses: must be a finite number, got 'nan'"),
    ([*SIM, "--noise-mm", "-3"], "argument --noise-mm: variability noise_mm must be"),
    ([*SIM, "--tremor-mm", "inf"], "argument --tremor-mm: must be a finite number"),
    ([*SIM, "--outliers", "1"], "argument --outliers: outlier_rate must be a probability"),
    ([*SIM, "--hand-miss", "-0.1"], "argument --hand-miss: variability hand_miss must be"),
    ([*SIM, "--approach-deg", "270"], "argument --approach-deg: approach_deg must be in [0, 180]"),
    ([*SIM, "--detour", "x"], "argument --detour: must be a number, got 'x'"),
    # record
    ([*RECORD, "--duration", "nan"], "argument --duration: must be a finite number, got 'nan'"),
    ([*RECORD, "--duration", "-2"], "argument --duration: must be a number > 0"),
    ([*RECORD, "--fps", "0"], "argument --fps: must be a number in [0.5, 120], got '0'"),
    ([*RECORD, "--fps", "inf"], "argument --fps: must be a finite number"),
    ([*RECORD, "--hand-rate", "0"], "argument --hand-rate: must be a number > 0"),
    ([*RECORD, "--seed", "-1"], "argument --seed: must be an integer in [0, 2**63 - 1]"),
    ([*RECORD, "--reference-size", "0"], "argument --reference-size: must be a number > 0"),
    # perception
    ([*PTRAIN, "--epochs", "0"], "argument --epochs: must be an integer >= 1, got '0'"),
    ([*PTRAIN, "--samples", "-5"], "argument --samples: must be an integer >= 1"),
    ([*PTRAIN, "--batch", "0"], "argument --batch: must be an integer >= 1"),
    ([*PTRAIN, "--lr", "nan"], "argument --lr: must be a finite number"),
    ([*PTRAIN, "--lr", "0"], "argument --lr: must be a number > 0"),
    ([*PTRAIN, "--threads", "0"], "argument --threads: must be an integer >= 1"),
    ([*PTRAIN, "--val-samples", "0"], "argument --val-samples: must be an integer >= 1"),
    ([*PTRAIN, "--seed", "-3"], "argument --seed: must be an integer in [0, 2**63 - 1]"),
    (["perception", "eval", "--samples", "0"], "argument --samples: must be an integer >= 1"),
    # templates train --params: checked by the engine before any recording is read
    ([*TRAIN, "--params", '{"fit": {"n_states": 0}}'], "n_states must be >= 1"),
    ([*TRAIN, "--params", '{"fit": {"n_states": -2}}'], "template parameter `fit.n_states`"),
    ([*TRAIN, "--params", '{"fit": {"n_states": "4"}}'], "template parameter `fit.n_states`"),
    ([*TRAIN, "--params", '{"fit": {"nstates": 4}}'], "unknown template parameter `fit.nstates`"),
    ([*TRAIN, "--params", '{"allign": false}'], "unknown template parameter `allign`"),
    ([*TRAIN, "--params", '{"fit": {"tol": NaN}}'], "template parameters are not plain JSON"),
    ([*TRAIN, "--params", '{"range_percentiles": [99, 1]}'], "range_percentiles must be"),
    ([*TRAIN, "--params", '{"dtw_band": 0}'], "dtw_band must be >= 1"),
    ([*TRAIN, "--params", "[1, 2]"], "must be a dict"),
    ([*TRAIN, "--params", "{fit: 1}"], "--params is not valid JSON"),
    # template files
    (["templates", "show", "{binary}"], "is not a template file (binary"),
    (["templates", "show", "{badjson}"], "template file is not valid JSON"),
    (
        ["templates", "show", "{inverted}"],
        "range of column 0 is [1, 0], which is empty or inverted",
    ),
    (["segment", EXP1, "--templates", "{binary}", "--json", "{out}"], "is not a template file"),
    (["segment", EXP1, "--templates", "{inverted}", "--json", "{out}"], "empty or inverted"),
]


@pytest.fixture(scope="module")
def bad_files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    from lfd.segmentation import Templates

    d = tmp_path_factory.mktemp("bad_templates")
    (d / "binary.json").write_bytes(bytes(range(256)) * 4)
    (d / "bad.json").write_text('{"format_version": 1, "skills": [', encoding="utf-8")
    doc = json.loads(Templates.default().to_json())
    doc["ranges"][0] = [1.0, 0.0]
    (d / "inverted.json").write_text(json.dumps(doc), encoding="utf-8")
    return {
        "binary": str(d / "binary.json"),
        "badjson": str(d / "bad.json"),
        "inverted": str(d / "inverted.json"),
    }


@pytest.mark.parametrize(
    ("args", "expected"), CASES, ids=[" ".join(c[0][:1] + c[0][-2:]) for c in CASES]
)
def test_bad_input_is_refused(
    args: list[str], expected: str, bad_files: dict[str, str], tmp_path: Path
) -> None:
    out = tmp_path / "out.mcap"
    files = {"{out}": str(out), **{f"{{{k}}}": v for k, v in bad_files.items()}}
    argv = [files.get(a, a) for a in args]
    proc = subprocess.run(
        [sys.executable, "-m", "lfd.cli", *argv], capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    assert "Traceback" not in proc.stderr, proc.stderr
    assert expected in proc.stderr, proc.stderr
    assert not out.exists()
