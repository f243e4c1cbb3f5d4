"""Type stubs for the compiled engine ``lfd._hmmseg`` (checked by ``mypy.stubtest``).

Arrays are numpy arrays of the dtype shown, in any memory layout (C, Fortran, strided); a
wrong dtype, a non-array or a wrong number of dimensions raises an ``lfd.errors`` exception
naming the argument. Sizes are refused before anything is allocated when a table would not fit
(``InvalidParameterError``), and so are counts that would make a call run for hours (the
engine's ``hmmseg::limits``: ``max_iter`` at most 10000, filters of at most 1024 coefficients;
``tol`` is a number >= 0, or ``-inf`` for exactly ``max_iter`` iterations); a Rust panic is
``lfd.errors.InternalError``.
"""

import os
from typing import Literal, TypedDict, final

import numpy as np
from numpy.typing import NDArray

__version__: str

# --- option names (the engine's enums; at runtime ``typing.Literal`` objects built from them) ---
CovarianceType = Literal["diag", "full"]
Topology = Literal["ergodic", "left-right"]
GrammarMode = Literal["off", "warn", "enforce"]
EndState = Literal["any", "final"]
SizeMeasure = Literal["max_horizontal", "min_horizontal", "max"]

# --- test hooks (not API): raise an engine error variant by name / panic inside the boundary --
def _raise_engine_error(variant: str) -> None: ...
def _panic(message: str) -> None: ...

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

FEATURE_NAMES: tuple[str, ...]
FEATURE_GROUPS: tuple[tuple[str, int, int], ...]

def default_feature_params() -> str: ...
def check_feature_params(params_json: str) -> str: ...

# --- continuous HMM (crates/hmmseg-py/src/hmm.rs) ----------------------------------------------
_F64 = NDArray[np.float64]

@final
class Hmm:
    """A continuous HMM with Gaussian-mixture emissions (immutable)."""

    @staticmethod
    def fit(
        sequences: list[_F64],
        *,
        n_states: int,
        n_mix: int = 1,
        covariance: CovarianceType = "diag",
        topology: Topology = "left-right",
        seed: int = 0,
        max_iter: int = 100,
        tol: float = 1e-4,
        covariance_floor: float = 1e-3,
    ) -> tuple[Hmm, list[float], int, bool]: ...
    def refit(
        self,
        sequences: list[_F64],
        *,
        max_iter: int,
        tol: float = ...,
        covariance_floor: float = 1e-3,
    ) -> tuple[Hmm, list[float], int, bool]: ...
    @staticmethod
    def from_params(
        startprob: _F64,
        transmat: _F64,
        weights: _F64,
        means: _F64,
        covars: _F64,
        covariance: CovarianceType = "diag",
    ) -> Hmm: ...
    @staticmethod
    def from_json(s: str) -> Hmm: ...
    def to_json(self) -> str: ...
    def log_likelihood(self, x: _F64) -> float: ...
    def log_likelihood_many(self, sequences: list[_F64]) -> _F64: ...
    def prefix_log_likelihoods(self, x: _F64) -> _F64: ...
    def viterbi(self, x: _F64) -> tuple[float, NDArray[np.int64]]: ...
    def posteriors(self, x: _F64) -> _F64: ...
    def sample(self, n_samples: int, *, seed: int = 0) -> tuple[_F64, NDArray[np.int64]]: ...
    @property
    def n_states(self) -> int: ...
    @property
    def n_features(self) -> int: ...
    @property
    def n_mix(self) -> int: ...
    @property
    def covariance(self) -> CovarianceType: ...
    @property
    def startprob(self) -> _F64: ...
    @property
    def transmat(self) -> _F64: ...
    @property
    def weights(self) -> _F64: ...
    @property
    def means(self) -> _F64: ...
    @property
    def covars(self) -> _F64: ...
    def __eq__(self, value: object, /) -> bool: ...

# --- segmentation: stage 1, stage-2 scores, templates (crates/hmmseg-py/src/segment.rs) ------
def stage1_boundaries(
    values: NDArray[np.float64],
    thresholds: NDArray[np.float64],
    columns: list[int],
    hysteresis: list[float],
    min_section: int,
) -> NDArray[np.int64]: ...
def rising_table(
    z: NDArray[np.float64],
    boundaries: NDArray[np.int64],
    min_rise: float = 0.02,
    dominance: float = 0.0,
) -> NDArray[np.bool_]: ...
def rising_band(
    z: NDArray[np.float64],
    boundaries: NDArray[np.int64],
    max_len: int,
    min_rise: float = 0.02,
    dominance: float = 0.0,
) -> NDArray[np.bool_]: ...

# --- the band of runs (crates/hmmseg-py/src/band.rs) -------------------------------------------
@final
class Band:
    """The runs of sections of at most ``max_len`` samples over ``boundaries`` (immutable)."""

    def __new__(cls, boundaries: NDArray[np.int64], max_len: int) -> Band: ...
    @property
    def boundaries(self) -> NDArray[np.int64]: ...
    @property
    def max_len(self) -> int: ...
    @property
    def n_sections(self) -> int: ...
    @property
    def n_runs(self) -> int: ...
    @property
    def offsets(self) -> NDArray[np.int64]: ...
    @property
    def last_ends(self) -> NDArray[np.int64]: ...
    def runs(self) -> tuple[NDArray[np.int64], NDArray[np.int64]]: ...
    def index(self, i: int, j: int) -> int | None: ...
    def __eq__(self, value: object, /) -> bool: ...

# --- the stage-2 search (crates/hmmseg-py/src/search.rs) ---------------------------------------
@final
class Grammar:
    """The skill grammar compiled for a skill order (immutable)."""

    def __new__(cls, rules: str, skills: list[str]) -> Grammar: ...
    @property
    def skills(self) -> list[str]: ...
    def __eq__(self, value: object, /) -> bool: ...

@final
class Cut:
    """One segment chosen by the search (immutable)."""

    @property
    def skill(self) -> int: ...
    @property
    def start_section(self) -> int: ...
    @property
    def end_section(self) -> int: ...
    @property
    def start(self) -> int: ...
    @property
    def end(self) -> int: ...
    @property
    def score(self) -> float: ...
    @property
    def margin(self) -> float: ...
    @property
    def confidence(self) -> float: ...
    def __eq__(self, value: object, /) -> bool: ...

def segment_greedy(
    scores: NDArray[np.float64],
    boundaries: NDArray[np.int64],
    grammar: Grammar,
    rising: NDArray[np.bool_] | None = None,
    mode: GrammarMode = "warn",
    lookahead: bool = False,
    max_len: int = 0,
) -> tuple[list[Cut], list[str]]: ...
def segment_dp(
    scores: NDArray[np.float64],
    boundaries: NDArray[np.int64],
    grammar: Grammar,
    rising: NDArray[np.bool_] | None = None,
    mode: GrammarMode = "warn",
    penalty: float = 0.0,
    max_len: int = 0,
) -> tuple[list[Cut], list[str]]: ...

# --- skill templates (crates/hmmseg-py/src/segment.rs) -----------------------------------------
def default_template_params() -> str: ...
def template_params(overrides_json: str) -> str: ...

@final
class TemplateSet:
    @staticmethod
    def train(
        skills: list[str],
        features: list[tuple[str, int, int]],
        examples: list[tuple[int, NDArray[np.float64]]],
        params_json: str | None = None,
    ) -> TemplateSet: ...
    @staticmethod
    def from_json(text: str) -> TemplateSet: ...
    def to_json(self) -> str: ...
    @property
    def skills(self) -> list[str]: ...
    @property
    def features(self) -> list[tuple[str, int, int]]: ...
    @property
    def ranges(self) -> list[tuple[float, float]]: ...
    @property
    def n_examples(self) -> list[int]: ...
    @property
    def params_json(self) -> str: ...
    def normalise(self, x: NDArray[np.float64]) -> NDArray[np.float64]: ...
    def score_table(
        self,
        raw: NDArray[np.float64],
        boundaries: NDArray[np.int64],
        max_len: int = 0,
        end: EndState = "final",
        features: list[int] | None = None,
    ) -> NDArray[np.float64]: ...
    def score_band(
        self,
        raw: NDArray[np.float64],
        boundaries: NDArray[np.int64],
        max_len: int = 0,
        end: EndState = "final",
        features: list[int] | None = None,
    ) -> NDArray[np.float64]: ...

# --- MCAP recordings (crates/hmmseg-py/src/mcap.rs, crates/lfd-mcap) --------------------------
class _Channel(TypedDict):
    topic: str
    schema: str
    schema_encoding: str
    schema_data: bytes
    encoding: str
    metadata: dict[str, str]
    count: int
    first_ns: int | None
    last_ns: int | None

class _Hand(TypedDict):
    t_ns: NDArray[np.int64]  # (n,) file order
    keypoints: NDArray[np.float64]  # (n, 21, 3); NaN for a message without 21 poses
    bad: str | None

class _Confidence(TypedDict):
    t_ns: NDArray[np.int64]  # (m,) file order
    confidence: NDArray[np.float64]  # (m, 21)
    visible: NDArray[np.bool_]  # (m, 21)
    has_visible: NDArray[np.bool_]  # (m,)
    bad: str | None

class _Poses(TypedDict):
    t_ns: NDArray[np.int64]  # (n,) file order
    position: NDArray[np.float64]  # (n, 3)
    quaternion: NDArray[np.float64]  # (n, 4) x, y, z, w
    bad: str | None

class _Damage(TypedDict):
    offset: int
    end: int
    chunks: list[int] | None
    messages: int | None
    why: str

class _Recording(TypedDict):
    library: str
    file_size: int
    complete: bool
    error: str | None
    damage: list[_Damage]
    chunks: int
    raw_truncated: bool
    channels: list[_Channel]
    metadata: dict[str, dict[str, str]]
    hands: dict[str, _Hand]
    confidence: dict[str, _Confidence]
    poses: dict[str, _Poses]
    raw: dict[str, list[tuple[int, bytes]]]

class _Attachment(TypedDict):
    name: str
    media_type: str
    log_time: int
    size: int

class _Summary(TypedDict):
    library: str
    file_size: int
    channels: list[_Channel]
    metadata: dict[str, dict[str, str]]
    attachments: list[_Attachment]
    messages: int
    chunks: int
    damage: list[_Damage]
    raw_truncated: bool
    raw: dict[str, list[tuple[int, bytes]]]

def read_recording(
    path: str | os.PathLike[str],
    images: bool = True,
    raw_topics: list[str] | None = None,
    raw_limit: int | None = None,
) -> _Recording:
    """Every complete chunk of a (possibly truncated) MCAP recording, one sequential pass; the
    hand keypoints, confidences and object poses decoded, every other topic raw (the image
    topics' payloads dropped with ``images=False``; with ``raw_topics``, only those topics'
    payloads kept, every topic still counted in ``channels``). A damaged region (a chunk that
    fails its CRC, a bad length) is stepped over and listed in ``damage``: every chunk outside
    it is read. At most ``raw_limit`` bytes of raw payloads are kept (``raw_truncated``: some
    were dropped). ``RecordingFormatError`` if it cannot be read (as
    ``lfd.io.mcapfile.scan``)."""

def read_summary(path: str | os.PathLike[str], topics: list[str] = ...) -> _Summary | None:
    """A finished recording's summary section (channels, metadata, attachments, message count),
    checked against its chunk and message indexes, every chunk CRC-checked (``damage``: the
    chunks that fail), and the raw messages of ``topics`` (at most 64 MiB: ``raw_truncated``);
    None without a usable summary."""

# --- preprocessing: signal processing and rotations (scipy-equivalent; crates/hmmseg-py/src/
# signal.rs and rotation.rs). A quaternion is (x, y, z, w); a row with a NaN gives a NaN row. ---

def butter_lowpass(
    order: int, cutoff: float, fs: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...
def lfilter_zi(b: NDArray[np.float64], a: NDArray[np.float64]) -> NDArray[np.float64]: ...
def filtfilt(
    b: NDArray[np.float64], a: NDArray[np.float64], x: NDArray[np.float64], padlen: int
) -> NDArray[np.float64]: ...
def filtfilt_runs(
    b: NDArray[np.float64],
    a: NDArray[np.float64],
    x: NDArray[np.float64],
    ok: NDArray[np.bool_],
    padlen: int,
) -> tuple[NDArray[np.float64], list[tuple[int, int]]]: ...
def solve_tridiagonal(
    dl: NDArray[np.float64],
    d: NDArray[np.float64],
    du: NDArray[np.float64],
    rhs: NDArray[np.float64],
) -> NDArray[np.float64]: ...
def cubic_spline(
    t: NDArray[np.float64], y: NDArray[np.float64], at: NDArray[np.float64]
) -> NDArray[np.float64]: ...
def resample_columns(
    ts: NDArray[np.float64],
    x: NDArray[np.float64],
    weights: NDArray[np.float64] | None,
    td: NDArray[np.float64],
    max_gap: float,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]: ...
def quat_normalize(q: NDArray[np.float64]) -> NDArray[np.float64]: ...
def quat_to_matrix(q: NDArray[np.float64]) -> NDArray[np.float64]: ...
def quat_from_matrix(m: NDArray[np.float64]) -> NDArray[np.float64]: ...
def euler_xyz_from_matrix(m: NDArray[np.float64]) -> NDArray[np.float64]: ...
def matrix_from_euler_xyz(e: NDArray[np.float64]) -> NDArray[np.float64]: ...
def euler_xyz_from_quat(q: NDArray[np.float64]) -> NDArray[np.float64]: ...
def quat_from_euler_xyz(e: NDArray[np.float64]) -> NDArray[np.float64]: ...
def quat_make_continuous(q: NDArray[np.float64]) -> NDArray[np.float64]: ...
def quat_multiply(p: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.float64]: ...
def quat_apply(
    q: NDArray[np.float64], v: NDArray[np.float64], inverse: bool = False
) -> NDArray[np.float64]: ...
def quat_slerp(
    times: NDArray[np.float64], q: NDArray[np.float64], at: NDArray[np.float64]
) -> NDArray[np.float64]: ...
