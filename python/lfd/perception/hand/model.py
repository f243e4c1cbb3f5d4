"""A compact point-cloud network for the 21 hand keypoints (needs torch: the ``perception`` extra).

PointNet-style, in the spirit of the paper's depth estimator [8]: a shared per-point MLP lifts
each crop point (x, y, z relative to the crop centre, divided by the crop radius, and a flag
that is 1 on the image border, where a hand leaving the view is cut off) to 256 features, a
max-pool gives an order-invariant global descriptor, and a small head regresses the
63 keypoint coordinates (same normalised frame). Each point also votes for every keypoint with
an offset and a weight (a softmax over points); the final estimate mixes the voted and the
regressed keypoints, so fingertips near observed points are pinned to the surface while
occluded joints fall back on the global shape. Voting costs ~5x the compute; the shipped model
(trained on a shared 2-core CPU) uses the global regression only (``vote=False``).

The shipped network has about 0.1 M parameters (~0.4 MB of float32 weights).
"""

from __future__ import annotations

from typing import Any

import torch  # type: ignore[import-not-found, unused-ignore]
from torch import nn  # type: ignore[import-not-found, unused-ignore]

N_KEYPOINTS = 21
MODEL_VERSION = 2
"""Version 2 adds ``in_dim`` (4: the border flag); version-1 files (3 values) still load."""


class HandPointNet(nn.Module):  # type: ignore[misc]
    """Point cloud (batch, n_points, 3) -> keypoints (batch, 21, 3), both normalised."""

    def __init__(
        self, width: int = 32, global_dim: int = 256, vote: bool = False, in_dim: int = 4
    ) -> None:
        super().__init__()
        self.config = {"width": width, "global_dim": global_dim, "vote": vote, "in_dim": in_dim}
        self.in_dim = in_dim
        self.local = nn.Sequential(
            nn.Conv1d(in_dim, width, 1),
            nn.BatchNorm1d(width),
            nn.ReLU(),
            nn.Conv1d(width, 2 * width, 1),
            nn.BatchNorm1d(2 * width),
            nn.ReLU(),
        )
        self.lift = nn.Sequential(
            nn.Conv1d(2 * width, global_dim, 1), nn.BatchNorm1d(global_dim), nn.ReLU()
        )
        self.head = nn.Sequential(
            nn.Linear(global_dim, 256), nn.ReLU(), nn.Linear(256, 3 * N_KEYPOINTS)
        )
        # per point: local + global features -> offset to each keypoint (63) + weight (21)
        self.vote = (
            None
            if not vote
            else nn.Sequential(
                nn.Conv1d(2 * width + global_dim, 128, 1),
                nn.BatchNorm1d(128),
                nn.ReLU(),
                nn.Conv1d(128, 4 * N_KEYPOINTS, 1),
            )
        )
        self.mix = nn.Parameter(torch.zeros(N_KEYPOINTS))

    def forward(self, points: Any) -> Any:
        b, n, _ = points.shape
        x = points[:, :, : self.in_dim].transpose(1, 2)  # (b, in_dim, n)
        f_local = self.local(x)
        g = self.lift(f_local).max(dim=2).values  # (b, global_dim)
        direct = self.head(g).view(b, N_KEYPOINTS, 3)
        if self.vote is None:
            return direct
        v = self.vote(torch.cat([f_local, g[:, :, None].expand(-1, -1, n)], dim=1))
        offsets = v[:, : 3 * N_KEYPOINTS].view(b, N_KEYPOINTS, 3, n)
        weights = torch.softmax(v[:, 3 * N_KEYPOINTS :], dim=2)  # (b, 21, n)
        voted = ((x[:, None, :3] + offsets) * weights[:, :, None]).sum(dim=3)  # (b, 21, 3)
        a = torch.sigmoid(self.mix)[None, :, None]
        return a * voted + (1 - a) * direct


def save_model(model: HandPointNet, path: str, **extra: Any) -> None:
    """Save weights (float32) and config to ``path`` (atomically: temporary file + rename)."""
    from ...outputs import atomic_output

    state = {k: v.detach().float().cpu() for k, v in model.state_dict().items()}
    with atomic_output(path) as tmp:
        torch.save({"version": MODEL_VERSION, "config": model.config, "state": state, **extra}, tmp)


def load_model(path: str) -> tuple[HandPointNet, dict[str, Any]]:
    """Load a model saved by :func:`save_model` (eval mode) and its saved extras."""
    from ...errors import LfdError

    try:
        ckpt = torch.load(path, map_location="cpu", weights_only=False)
    except Exception as err:  # torch raises EOFError, UnpicklingError, RuntimeError, ...
        raise LfdError(f"{path}: not a readable model file ({type(err).__name__}: {err})") from err
    if not isinstance(ckpt, dict) or ckpt.get("version") not in (1, MODEL_VERSION):
        raise LfdError(f"{path}: not an lfd hand model (version 1 or {MODEL_VERSION})")
    try:
        model = HandPointNet(**{"in_dim": 3, **ckpt["config"]})
        model.load_state_dict(ckpt["state"])
    except (KeyError, TypeError, RuntimeError) as err:
        raise LfdError(f"{path}: damaged lfd hand model ({err})") from err
    model.eval()
    return model, {k: v for k, v in ckpt.items() if k not in ("state",)}
