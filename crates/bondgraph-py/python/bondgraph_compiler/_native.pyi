"""Types of the Rust extension module (see the package's docstrings for what each does)."""

from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

VERSION: str

class BgcError(ValueError):
    diagnostics: List[Dict[str, Any]]

class ModelError(BgcError): ...
class ScenarioError(BgcError): ...
class DataError(BgcError): ...
class SimulationError(BgcError): ...

class Model:
    @property
    def text(self) -> str: ...
    @property
    def file(self) -> str: ...
    def json(self, sparse: bool = False) -> str: ...
    def emit(self, target: str, standalone: bool = False) -> str: ...
    def diagnostics(self) -> List[Dict[str, Any]]: ...
    def signals(self) -> List[str]: ...
    def arr_names(self) -> List[str]: ...

def compile(text: str, file: str, residuals: str = "per-sensor", realisation: str = "lowest") -> Model: ...
def residuals(
    model: Model,
    time: npt.NDArray[np.float64],
    columns: Sequence[npt.NDArray[np.float64]],
    *,
    thresholds: Sequence[Optional[float]],
    labels: Optional[Sequence[str]] = None,
    window: Optional[int] = None,
    estimator: Optional[str] = None,
    degree: Optional[int] = None,
    integration: Optional[str] = None,
    debounce: int = 1,
    adaptive: bool = False,
    size_span: Optional[float] = 5.0,
    calibration: Optional[Tuple[str, str, Tuple[str, str]]] = None,
    calibrate: Optional[
        Tuple[
            npt.NDArray[np.float64],
            Sequence[npt.NDArray[np.float64]],
            Optional[Sequence[str]],
            str,
            float,
            bool,
            Optional[float],
        ]
    ] = None,
) -> Dict[str, Any]: ...
def identify(
    model: Model,
    time: npt.NDArray[np.float64],
    columns: Sequence[npt.NDArray[np.float64]],
    *,
    labels: Optional[Sequence[str]] = None,
    window: int = 51,
    integration: int = 250,
    only: Optional[Sequence[str]] = None,
    fix: Optional[Sequence[str]] = None,
    span: Optional[Tuple[float, float]] = None,
    criterion: str = "evidence",
) -> Dict[str, Any]: ...
def with_values(text: str, values: Sequence[Tuple[str, float]]) -> str: ...
def simulate(model: Model, text: str, file: str = "<scenario>") -> Tuple[List[str], npt.NDArray[np.float64]]: ...
def verify(
    model: Model, *, input_scale: float = 1.0, state_scale: float = 0.5, runs: int = 3
) -> Dict[str, Any]: ...
def sensors(model: Model, targets: Sequence[str], goal: str = "isolable") -> Dict[str, Any]: ...
def read_columns(path: str, names: Sequence[str]) -> Optional[List[npt.NDArray[np.float64]]]: ...
