"""Train the hand keypoint network on depth crops rendered by the simulated demonstrator.

``lfd perception train -o model.pt`` renders (or loads, ``--data``) the training set, trains
with Adam and a cosine schedule, shows progress with rich, and writes a checkpoint
(``<out>.ckpt``: weights, optimiser, epoch) after every epoch so ``--resume`` continues an
interrupted run. The loss is the mean Euclidean keypoint error.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np


def load_arrays(paths: Sequence[str | os.PathLike[str]]) -> dict[str, np.ndarray]:
    """Concatenate training sets saved with ``numpy.savez`` (points, keypoints, centre)."""
    parts = [np.load(p) for p in paths]
    return {k: np.concatenate([p[k] for p in parts]) for k in ("points", "keypoints", "centre")}


def heldout_error_mm(estimator: Any, n: int, seed: int = 99) -> np.ndarray:
    """Per-frame mean 3-D keypoint error (mm) of a whole ``HandEstimator`` (crop, point
    subsets) on ``n`` freshly rendered randomised frames, shape (n,)."""
    from .dataset import randomised_views

    out = []
    for pts, kp, _ in randomised_views(n, seed=seed):
        found = estimator.estimate_points(pts)
        if found is not None:
            out.append(np.linalg.norm(found[0] - kp, axis=1).mean() * 1000.0)
    return np.asarray(out)


def keypoint_error_mm(model: Any, data: dict[str, np.ndarray], batch: int = 256) -> np.ndarray:
    """Per-sample mean 3-D keypoint error (mm) on stored crops, shape (n,)."""
    import torch

    from .dataset import CROP_RADIUS, N_POINTS

    model.eval()
    out = []
    with torch.no_grad():
        for i in range(0, len(data["points"]), batch):
            crops = np.ascontiguousarray(data["points"][i : i + batch, :N_POINTS])
            pred = model(torch.from_numpy(crops)).numpy()
            err = np.linalg.norm(pred - data["keypoints"][i : i + batch], axis=2).mean(axis=1)
            out.append(err * CROP_RADIUS * 1000.0)
    return np.concatenate(out) if out else np.zeros(0)


def _augment(points: Any, keypoints: Any, gen: Any) -> tuple[Any, Any]:
    """Random rotation about the vertical axis and jitter of the xyz values (points and
    keypoints alike); the border flag is kept."""
    import torch

    b = points.shape[0]
    a = (torch.rand(b, generator=gen) - 0.5) * 0.6
    c, s = torch.cos(a), torch.sin(a)
    R = torch.zeros(b, 3, 3)
    R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = c, -s, s, c, 1.0
    shift = (torch.rand(b, 1, 3, generator=gen) - 0.5) * 0.1
    xyz = points[:, :, :3] @ R.transpose(1, 2) + shift
    k = keypoints @ R.transpose(1, 2) + shift
    xyz = xyz + torch.randn(xyz.shape, generator=gen) * 0.004
    return torch.cat([xyz, points[:, :, 3:]], dim=2), k


def train(
    data: dict[str, np.ndarray],
    out: str | os.PathLike[str],
    *,
    epochs: int = 40,
    batch: int = 64,
    lr: float = 2e-3,
    resume: bool = False,
    validation: dict[str, np.ndarray] | None = None,
    threads: int | None = None,
    seed: int = 0,
    init: str | os.PathLike[str] | None = None,
) -> dict[str, Any]:
    """Train (or continue training) and save the model to ``out``; returns a summary.

    ``init`` starts from the weights of a saved model (fine-tuning) instead of random ones.

    Creating the optimiser imports ``torch._dynamo`` and with it triton, whose native library
    crashes the process if MuJoCo's EGL context was created first: import ``torch._dynamo``
    before rendering (as ``lfd perception train`` does) or render in another process.
    """
    import torch
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    from ...outputs import atomic_output
    from .dataset import N_POINTS
    from .model import HandPointNet, save_model

    if threads:
        torch.set_num_threads(threads)
    torch.manual_seed(seed)
    gen = torch.Generator().manual_seed(seed)
    pts = torch.from_numpy(np.ascontiguousarray(data["points"], np.float32))
    kps = torch.from_numpy(np.ascontiguousarray(data["keypoints"], np.float32))
    n = pts.shape[0]
    if n < batch:
        from ...errors import LfdError

        raise LfdError(f"need at least {batch} training samples, got {n}")
    if init is not None:
        from .model import load_model

        model = load_model(os.fspath(init))[0]
    else:
        model = HandPointNet()
    opt = torch.optim.AdamW(model.parameters(), lr=lr, weight_decay=1e-4)
    sched = torch.optim.lr_scheduler.OneCycleLR(
        opt, max_lr=lr, total_steps=epochs * (n // batch), pct_start=0.1
    )
    ckpt_path = Path(f"{os.fspath(out)}.ckpt")
    start = 0
    if resume and ckpt_path.exists():
        ck = torch.load(ckpt_path, map_location="cpu", weights_only=False)
        if ck.get("epochs", epochs) != epochs or ck.get("samples", n) != n:
            from ...errors import LfdError

            raise LfdError(
                f"{ckpt_path} belongs to a run of {ck.get('epochs')} epochs on "
                f"{ck.get('samples')} samples: resume with the same --epochs and data"
            )
        model.load_state_dict(ck["model"])
        opt.load_state_dict(ck["opt"])
        start = int(ck["epoch"])
        with warnings.catch_warnings():  # fast-forward the schedule to the saved epoch
            warnings.simplefilter("ignore")
            for _ in range(start * (n // batch)):
                sched.step()
    history: list[float] = []
    cols = (TextColumn("{task.description}"), BarColumn(), TimeRemainingColumn())
    with Progress(*cols, TextColumn("{task.fields[info]}")) as progress:
        task = progress.add_task("training", total=epochs, completed=start, info="")
        for epoch in range(start, epochs):
            model.train()
            perm = torch.randperm(n, generator=gen)
            total = 0.0
            for i in range(n // batch):
                idx = perm[i * batch : (i + 1) * batch]
                sub = torch.randint(0, pts.shape[1], (N_POINTS,), generator=gen)
                p, k = _augment(pts[idx][:, sub], kps[idx], gen)
                loss = torch.linalg.norm(model(p) - k, dim=2).mean()
                opt.zero_grad()
                loss.backward()
                opt.step()
                sched.step()
                total += float(loss.detach())
            from .dataset import CROP_RADIUS

            train_mm = total / (n // batch) * CROP_RADIUS * 1000.0
            info = f"train {train_mm:.1f} mm"
            if validation is not None:
                val = float(keypoint_error_mm(model, validation).mean())
                history.append(val)
                info += f", held-out {val:.1f} mm"
            progress.update(task, advance=1, info=info)
            with atomic_output(ckpt_path) as tmp:  # an interrupted save keeps the last one
                torch.save(
                    {
                        "model": model.state_dict(),
                        "opt": opt.state_dict(),
                        "sched": sched.state_dict(),
                        "epoch": epoch + 1,
                        "epochs": epochs,
                        "samples": n,
                    },
                    tmp,
                )
    summary: dict[str, Any] = {"samples": int(n), "epochs": int(epochs)}
    if init is not None:
        summary["init"] = os.path.basename(os.fspath(init))
    if validation is not None:
        summary["held_out_mm"] = float(keypoint_error_mm(model, validation).mean())
    save_model(model, os.fspath(out), training=summary)
    return summary
