"""Type stubs for the compiled engine ``lfd._hmmseg`` (checked by ``mypy.stubtest``)."""

import numpy as np
from numpy.typing import NDArray

__version__: str

# --- DTW and normalisation (crates/hmmseg-py/src/dtw.rs) --------------------------------------
def dtw(
    a: NDArray[np.float64], b: NDArray[np.float64], band: int | None = None
) -> tuple[float, NDArray[np.int64]]: ...
def dtw_distance(
    a: NDArray[np.float64], b: NDArray[np.float64], band: int | None = None
) -> float: ...
def align_to_reference(
    reference: NDArray[np.float64], seqs: list[NDArray[np.float64]], band: int | None = None
) -> list[NDArray[np.float64]]: ...
def minmax(x: NDArray[np.float64]) -> NDArray[np.float64]: ...
def minmax_with(
    x: NDArray[np.float64], lo: NDArray[np.float64], hi: NDArray[np.float64]
) -> NDArray[np.float64]: ...

# --- Table I features (crates/hmmseg-py/src/features.rs) ---------------------------------------
def compute_features(
    tcp: NDArray[np.float64],
    opening: NDArray[np.float64],
    object_position: NDArray[np.float64],
    object_quaternion: NDArray[np.float64],
    object_size: NDArray[np.float64],
    dt: float,
    target: NDArray[np.int64] | None = None,
    params_json: str | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]: ...
def label_targets(
    tcp: NDArray[np.float64],
    object_position: NDArray[np.float64],
    object_size: NDArray[np.float64],
    dt: float,
    params_json: str | None = None,
) -> NDArray[np.int64]: ...
def feature_names() -> list[str]: ...
def default_feature_params() -> str: ...
def check_feature_params(params_json: str) -> str: ...
