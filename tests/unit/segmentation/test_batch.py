"""Many recordings at once: lfd.batch.run_batch and the batch modes of lfd segment / eval /
templates train (--jobs, --ray): results in input order, per-file errors, exit status 2."""

from __future__ import annotations

import json
import os
import warnings
from pathlib import Path

import _paths
import pytest
from _signals import ctrl_c_as_from_a_terminal
from lfd.batch import WORKER_DIED, ItemResult, run_batch
from lfd.cli import main
from lfd.errors import RecoveredFileWarning, UsageError

ROOT = _paths.ROOT
REC = ROOT / "recordings"
EXP = [str(REC / f"exp{i}.mcap") for i in (1, 2, 3)]


def _tenfold_or_crash(x: int) -> int:
    """A worker task: x * 10; 2 kills its worker process (a crash in native code); 3 raises."""
    if x == 2:
        os._exit(3)
    if x == 3:
        raise UsageError("three is refused")
    return 10 * x


@pytest.fixture
def broken(tmp_path: Path) -> str:
    """A truncated recording: the first 3000 bytes of exp2.mcap."""
    path = tmp_path / "broken.mcap"
    path.write_bytes((REC / "exp2.mcap").read_bytes()[:3000])
    return str(path)


def _single(path: str, tmp_path: Path) -> dict:
    out = tmp_path / f"single-{Path(path).stem}.json"
    assert main(["segment", path, "--json", str(out)]) == 0
    return json.loads(out.read_text())


def _batch(args: list[str], tmp_path: Path, name: str) -> tuple[int, list[dict]]:
    out = tmp_path / name
    status = main(["segment", *args, "--json", str(out)])
    return status, json.loads(out.read_text())


def test_run_batch_keeps_order_and_isolates_failures() -> None:
    items = [1, 2, 3, 4, 5]
    for jobs in (1, 2):
        got = run_batch(_tenfold_or_crash, [i for i in items if jobs > 1 or i != 2], jobs=jobs)
        by_item = {r.item: r for r in got}
        assert [r.item for r in got] == [i for i in items if jobs > 1 or i != 2]
        assert [by_item[i].value for i in (1, 4, 5)] == [10, 40, 50]
        assert by_item[3].error == "three is refused" and by_item[3].value is None
        if jobs > 1:  # the crash is that item's error, not the batch's
            assert by_item[2].error is not None and by_item[2].error.startswith(WORKER_DIED)
    seen: list[ItemResult[int]] = []
    run_batch(_tenfold_or_crash, [1, 4], jobs=1, progress=seen.append)
    assert [r.value for r in seen] == [10, 40]
    from rich.progress import Progress

    with Progress(disable=True) as bar:  # a rich progress gets a task advanced per item
        run_batch(_tenfold_or_crash, [1, 3, 4], jobs=1, progress=bar)
        assert bar.tasks[0].completed == 3 and "1 failed" in bar.tasks[0].description
    with pytest.raises(UsageError, match="--jobs"):
        run_batch(_tenfold_or_crash, [1], jobs=0)


def test_segment_batch_json_list(tmp_path: Path, broken: str, capsys) -> None:
    single = {p: _single(p, tmp_path) for p in EXP[:2]}
    capsys.readouterr()
    inputs = [EXP[0], broken, EXP[1]]
    status, docs = _batch([*inputs, "--jobs", "2"], tmp_path, "jobs2.json")
    err = capsys.readouterr().err
    assert status == 2  # some file failed
    assert [d["recording"] for d in docs] == inputs
    assert docs[0] == single[EXP[0]] and docs[2] == single[EXP[1]]
    assert (
        set(docs[1]) == {"recording", "error"} and "not a usable lfd recording" in docs[1]["error"]
    )
    errors = [line for line in err.splitlines() if ": error: " in line]
    assert errors == [f"lfd segment: error: {broken}: {docs[1]['error']}"]
    status1, docs1 = _batch([*inputs, "--jobs", "1"], tmp_path, "jobs1.json")
    assert status1 == 2 and docs1 == docs


def test_segment_batch_directory_all_good(tmp_path: Path) -> None:
    folder = tmp_path / "recs"
    folder.mkdir()
    for p in reversed(EXP[:2]):
        (folder / Path(p).name).write_bytes(Path(p).read_bytes())
    (folder / "notes.txt").write_text("not a recording")
    status, docs = _batch([str(folder), "--jobs", "2"], tmp_path, "dir.json")
    assert status == 0
    assert [Path(d["recording"]).name for d in docs] == ["exp1.mcap", "exp2.mcap"]  # sorted
    assert all("error" not in d and d["segments"] for d in docs)


def test_eval_jobs_agree(tmp_path: Path, broken: str) -> None:
    inputs = [EXP[0], broken, EXP[2]]
    outs = []
    for jobs in ("1", "2"):
        out = tmp_path / f"eval{jobs}.json"
        argv = ["eval", *inputs, "--methods", "dp,gripper", "--jobs", jobs, "--json", str(out)]
        with warnings.catch_warnings():
            # the broken file's recovery warning (re-emitted with --jobs 1, not with --jobs 2)
            warnings.simplefilter("ignore", RecoveredFileWarning)
            assert main(argv) == 2  # the broken file failed, the others were evaluated
        outs.append(json.loads(out.read_text()))
    assert outs[0] == outs[1]
    assert [r["name"] for r in outs[0]["recordings"]] == ["exp1.mcap", "exp3.mcap"]
    assert [f["recording"] for f in outs[0]["failed"]] == [broken]


@pytest.mark.slow  # trains the templates twice
def test_templates_train_jobs_agree(tmp_path: Path, broken: str, capsys) -> None:
    # two recordings of every skill: the examples are read in parallel, training is one step
    files = [
        str(p)
        for p in sorted((REC / "templates").glob("*.mcap"))
        if p.stem.rsplit("_", 1)[-1] in ("0", "1")
    ]
    fast = ["--params", '{"fit": {"max_iter": 2}}']
    made = []
    for jobs, extra in (("1", []), ("2", []), ("2", [broken])):
        out = tmp_path / f"t{jobs}{len(extra)}.json"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RecoveredFileWarning)  # the broken file's, re-emitted
            status = main(
                ["templates", "train", *files, *extra, "-o", str(out), *fast, "--jobs", jobs]
            )
        assert status == (2 if extra else 0)
        made.append(json.loads(out.read_text()))
    assert made[0] == made[1]
    # with a broken file among them: reported, and the templates trained on the others
    assert made[2] == made[0]
    assert f"lfd templates: error: {broken}: " in capsys.readouterr().err


@pytest.mark.slow  # starts a local Ray instance
def test_segment_batch_on_local_ray_equals_local(tmp_path: Path, broken: str) -> None:
    # a local Ray instance with 2 CPUs (--ray without an address): about 10 s, mostly start-up
    pytest.importorskip("ray")
    inputs = [EXP[0], broken, EXP[2]]
    local_status, local = _batch([*inputs, "--jobs", "1"], tmp_path, "local.json")
    ray_status, on_ray = _batch([*inputs, "--jobs", "2", "--ray"], tmp_path, "ray.json")
    assert (ray_status, on_ray) == (local_status, local) == (2, local)


def test_ray_missing_says_which_extra(tmp_path: Path) -> None:
    import subprocess
    import sys

    code = (
        "import sys\n"
        "class Block:  # ray is not installed\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] == 'ray':\n"
        "            raise ModuleNotFoundError(f'blocked: {name}', name=name)\n"
        "sys.meta_path.insert(0, Block())\n"
        "from lfd.cli import main\n"
        f"sys.exit(main(['segment', {EXP[0]!r}, {EXP[1]!r}, '--ray']))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 2
    assert out.stderr.strip() == "lfd segment: error: --ray needs Ray: pip install 'lfd[ray]'"


def test_ctrl_c_stops_a_batch_at_once() -> None:
    """Ctrl+C (SIGINT to the process group) ends a running batch with 130, without finishing
    the queued recordings first, and leaves no worker behind."""
    import signal
    import subprocess
    import sys
    import time

    argv = [sys.executable, "-m", "lfd.cli", "segment", *(EXP * 300), "--jobs", "2"]
    proc = subprocess.Popen(
        argv,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=ctrl_c_as_from_a_terminal,
    )
    time.sleep(4)  # the pool is up and segmenting (900 recordings take far longer)
    assert proc.poll() is None
    t0 = time.perf_counter()
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and err.strip().endswith("lfd segment: interrupted")
    assert time.perf_counter() - t0 < 5
    for _ in range(50):  # no worker left in the command's process group
        left = subprocess.run(
            ["pgrep", "-g", str(proc.pid), "-f", "spawn_main"], capture_output=True
        )
        if not left.stdout:
            break
        time.sleep(0.1)
    assert not left.stdout, left.stdout
