"""Type stubs of the Rust extension module. Use the functions of ``mapgauge``;
the underscored ones here are its internals."""

import os
from typing import Any, Callable, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

class MapgaugeError(ValueError):
    """Bad input or a failed evaluation; the message is the CLI's one-line error."""

class TooFewFoundError(MapgaugeError):
    """Too few targets were located to align the map to the survey."""
    found: int
    need: int

class FrameNotFoundError(MapgaugeError):
    """Map-wide detection could not match the map to the survey: its frame is unknown."""
    detections: int

class NotMetresError(MapgaugeError):
    """The map's points are spread too thin for metres (a map in millimetres?)."""

class ParseError(MapgaugeError):
    """A file's contents do not follow its format, or a table has a bad row."""
    path: str
    line: int  # 1-based; 0 when the problem is not tied to a line

class ParamError(MapgaugeError):
    """A parameter or configuration value is out of range or unknown."""

class FileError(MapgaugeError):
    """The operating system refused a read or write."""
    path: str
    errno: Optional[int]

class Survey:
    """A survey: the ground truth every map is measured against."""

    @property
    def ids(self) -> List[str]:
        """Target ids in survey order."""
    @property
    def positions(self) -> npt.NDArray[np.float64]:
        """(M, 3) reference points (antenna height removed); z = NaN without heights."""
    @property
    def has_z(self) -> bool:
        """True when every target has a height."""
    @property
    def frame(self) -> str:
        """``local`` or ``wgs84_enu``."""
    @property
    def name(self) -> str:
        """The survey as result.json names it: the file as given, or ``<memory>``."""
    def __len__(self) -> int: ...

class EvalCore:
    def to_json(self) -> str: ...
    def crop(self, index: int, kind: str) -> npt.NDArray[np.float64]: ...
    def samples(self, index: int) -> npt.NDArray[np.float64]: ...
    def write(self, out: Union[str, os.PathLike[str]], report: bool) -> None: ...

class ScoreCore:
    def to_json(self) -> str: ...
    def write(self, out: Union[str, os.PathLike[str]]) -> None: ...

def read_survey(path: Union[str, os.PathLike[str]], origin: Optional[Sequence[float]] = None) -> Survey:
    """Reads a survey CSV exactly as ``mapgauge eval --survey`` does."""

def read_points(
    path: Union[str, os.PathLike[str]],
    bounds: Optional[Tuple[Sequence[float], Sequence[float]]] = None,
) -> npt.NDArray[np.float64]:
    """Every point of a map file (PCD, PLY, LAS/LAZ, E57, XYZ) as an (N, 3)
    float64 array, streamed chunk by chunk; with ``bounds=(min, max)``, each
    ``(x, y)`` or ``(x, y, z)``, only the points inside (edges included)."""

def _survey_from_arrays(ids: List[str], xyz: npt.NDArray[np.float64], has_z: bool) -> Survey: ...
def _evaluate(
    map: Union[str, npt.NDArray[np.float64], npt.NDArray[np.float32]],
    survey: Survey,
    config_json: Optional[str] = None,
    crops: Optional[str] = None,
    progress: Optional[Callable[[int, int], Any]] = None,
) -> EvalCore: ...
def _config(config_json: Optional[str] = None) -> Tuple[str, str]: ...
def _errors(survey: Survey, estimates: Any, metrics_json: Optional[str] = None) -> ScoreCore: ...
def _locate(
    points: Union[npt.NDArray[np.float64], npt.NDArray[np.float32]],
    up: Optional[Sequence[float]] = None,
    params_json: Optional[str] = None,
) -> dict: ...
def _synth(params_json: Optional[str] = None) -> Tuple[npt.NDArray[np.float64], Survey, str]: ...
def _table(runs: List[Tuple[str, str, str]], format: str, which: str) -> Tuple[str, List[str]]: ...
def _batch_plan(
    kind: str, payload: str, base: str
) -> Tuple[List[Tuple[str, str]], Optional[str], Optional[str], Optional[int]]: ...
def _batch_run(kind: str, payload: str, base: str, index: int, out: str) -> str: ...
def _batch_summary(kind: str, payload: str, base: str, out: str, records: List[str]) -> str: ...
