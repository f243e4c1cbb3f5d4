"""Type stubs for the compiled engine ``lfd._hmmseg`` (checked by ``mypy.stubtest``)."""

__version__: str

# --- segmentation: stage 1, stage 2, templates (crates/hmmseg-py/src/segment.rs) -------------
import numpy as np
import numpy.typing as npt

_SegmentTuple = tuple[int, int, int, int, int, float, float]

def stage1_boundaries(
    values: npt.NDArray[np.float64],
    thresholds: npt.NDArray[np.float64],
    columns: list[int],
    hysteresis: list[float],
    min_section: int,
) -> npt.NDArray[np.int64]: ...
def rising_table(
    z: npt.NDArray[np.float64],
    boundaries: npt.NDArray[np.int64],
    min_rise: float = 0.03,
    dominance: float = 1.0,
) -> npt.NDArray[np.bool_]: ...
def segment_greedy(
    scores: npt.NDArray[np.float64],
    boundaries: npt.NDArray[np.int64],
    skills: list[str],
    grammar_json: str,
    rising: npt.NDArray[np.bool_] | None = None,
    mode: str = "warn",
) -> tuple[list[_SegmentTuple], list[str]]: ...
def segment_dp(
    scores: npt.NDArray[np.float64],
    boundaries: npt.NDArray[np.int64],
    skills: list[str],
    grammar_json: str,
    rising: npt.NDArray[np.bool_] | None = None,
    mode: str = "warn",
    penalty: float = 0.0,
) -> tuple[list[_SegmentTuple], list[str]]: ...
def default_template_params() -> str: ...

class TemplateSet:
    @staticmethod
    def train(
        skills: list[str],
        features: list[tuple[str, int, int]],
        examples: list[tuple[int, npt.NDArray[np.float64]]],
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
    def normalise(self, x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]: ...
    def score_table(
        self, raw: npt.NDArray[np.float64], boundaries: npt.NDArray[np.int64], max_len: int = 0
    ) -> npt.NDArray[np.float64]: ...
