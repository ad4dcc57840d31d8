"""bgc from Python: bond-graph models to ARRs, fault signatures and residuals.

>>> import bondgraph_compiler as bgc
>>> model = bgc.compile("models/backlash_bench.bg")
>>> model.arrs[0].text                      # the ARR as `bgc MODEL` prints it
>>> model.fsm                               # the fault signature matrix (a DataFrame with pandas)
>>> run = model.residuals(df, calibrate=healthy_df)
>>> run.to_pandas()                         # residuals, thresholds, alarms, candidates

The numeric work (compiling, estimating, integrating) runs in Rust with the interpreter's
lock released; this module only moves columns in and results out. Every error is a Python
exception: a model or scenario with errors raises `ModelError` / `ScenarioError` whose
`diagnostics` locate each error (file, line, column) as the CLI does; unusable samples raise
`DataError`.
"""

from __future__ import annotations

import difflib
import json
import os
import pathlib
import re
from dataclasses import dataclass, field
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from ._native import BgcError, DataError, ModelError, ScenarioError, SimulationError

__all__ = [
    "compile",
    "Model",
    "Arr",
    "Residuals",
    "Verification",
    "Identification",
    "BgcError",
    "ModelError",
    "ScenarioError",
    "DataError",
    "SimulationError",
]

__version__: str = _native.VERSION

Source = Union[str, "os.PathLike[str]"]


def _read(source: Source, what: str, default: str) -> "tuple[str, str]":
    """The text of `source` and the name its diagnostics give it.

    A path (``pathlib.Path``), or a one-line string naming an existing file (or ending in
    `what`), is read as UTF-8; any other string is the text itself.
    """
    if isinstance(source, os.PathLike):
        path = pathlib.Path(source)
        return path.read_text(encoding="utf-8"), str(path)
    if not isinstance(source, str):
        raise TypeError(f"expected a path or the text of a {what} file, not {type(source).__name__}")
    one_line = "\n" not in source and "\r" not in source
    if one_line and (source.endswith(what) or os.path.isfile(source)):
        return pathlib.Path(source).read_text(encoding="utf-8"), source
    return source, default


def compile(source: Source, *, residuals: str = "per-sensor", realise: str = "lowest") -> "Model":
    """Compiles a model, as ``bgc MODEL --residuals SET --realise HOW`` does.

    `source` is a path to a ``.bg`` file or the model's text. `residuals` is
    ``"per-sensor"`` (one ARR per detector), ``"best"``, ``"all"``, ``"simulated"``,
    ``"partial"`` or ``"bank"`` (the ARRs and, beside them, the partial copies where the
    model has them); `realise` is
    ``"lowest"`` (integrated once where that lowers the derivatives read) or ``"direct"``.
    Raises `ModelError` when the model has errors.
    """
    text, file = _read(source, ".bg", "<model>")
    return Model(_native.compile(text, file, residuals, realise), residuals, realise)


def _recompile(text: str, file: str, residuals: str, realise: str) -> "Model":
    """A pickled model, compiled again where it is unpickled (a Dask or multiprocessing
    worker): the compiled form is Rust data, its text is what travels."""
    return Model(_native.compile(text, file, residuals, realise), residuals, realise)


@dataclass(frozen=True)
class Arr:
    """One analytical redundancy relation: ``expr = 0`` on a healthy plant."""

    name: str
    #: The relation as `bgc MODEL` prints it (``der(y, n)``: n-th derivative, ``int(y)``:
    #: integral from the start).
    text: str
    #: How a residual generator evaluates it (``relation``, ``integrated``, ``simulated``).
    form: str
    #: The junction and detector it was derived at.
    junction: Optional[str]
    sensor: Optional[str]
    #: The components it is sensitive to.
    components: List[str]
    #: The signals it reads.
    signals: List[str]
    #: Names standing for parameters in `text`.
    parameters: List[str]

    def sympy(self) -> Any:
        """The relation as a SymPy expression in the time ``t`` (requires SymPy).

        Signals are functions of ``t``, parameters symbols; ``der(y, n)`` is the n-th
        derivative and ``int(y)`` the integral from 0 to ``t``.
        """
        return _to_sympy(self.text, self.signals, self.parameters)


def _to_sympy(text: str, signals: Sequence[str], parameters: Sequence[str]) -> Any:
    try:
        import sympy
        from sympy.parsing.sympy_parser import parse_expr
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("Arr.sympy() needs SymPy: pip install sympy") from e
    t = sympy.Symbol("t", real=True)
    tau = sympy.Symbol("tau", real=True)
    names: Dict[str, Any] = {p: sympy.Symbol(p, real=True) for p in parameters}
    names.update({s: sympy.Function(s, real=True)(t) for s in signals})

    def der(e: Any, n: int = 1) -> Any:
        return sympy.Derivative(e, (t, int(n)))

    def integral(e: Any) -> Any:
        return sympy.Integral(e.subs(t, tau), (tau, 0, t))

    names.update(
        {
            "der": der,
            "int": integral,
            "exp": sympy.exp,
            "log": sympy.log,
            "sqrt": sympy.sqrt,
            "abs": sympy.Abs,
            "sign": sympy.sign,
            "sin": sympy.sin,
            "cos": sympy.cos,
            "tan": sympy.tan,
            "tanh": sympy.tanh,
            "atan": sympy.atan,
            "atanh": sympy.atanh,
            "min": sympy.Min,
            "max": sympy.Max,
            "t": t,
        }
    )
    return parse_expr(text.replace("^", "**"), local_dict=names, evaluate=False)


def _close(name: str, names: Sequence[str]) -> str:
    match = difflib.get_close_matches(name, list(names), n=1)
    return f" (did you mean `{match[0]}`?)" if match else ""


def _column(data: Any, name: str) -> np.ndarray:
    """Column `name` of a dict of arrays, a pandas or a Polars DataFrame, as contiguous,
    aligned float64 (no copy when it already is)."""
    if hasattr(data, "get_column"):  # Polars
        values = data.get_column(name).to_numpy()
    else:
        values = data[name]
        if hasattr(values, "to_numpy"):  # pandas
            values = values.to_numpy()
    values = np.asarray(values)
    if values.ndim != 1:
        raise DataError(f"column `{name}` has shape {values.shape}; expected one value per sample")
    if values.dtype.kind not in "iuf":
        raise DataError(f"column `{name}` holds {values.dtype} values; expected numbers")
    # Contiguous and aligned (Arrow-backed columns moved between processes may not be):
    # copied only when not already so.
    return np.require(values, dtype=np.float64, requirements=["C", "A"])


def _names(data: Any) -> List[str]:
    if isinstance(data, Mapping):
        return [str(k) for k in data.keys()]
    if hasattr(data, "columns"):
        return [str(c) for c in data.columns]
    raise TypeError(
        "data must be a dict of arrays, a pandas DataFrame or a Polars DataFrame, "
        f"not {type(data).__name__}"
    )


def _read_record(path: str, names: List[str]) -> Dict[str, np.ndarray]:
    """The columns `names` of the record file at `path`: a MAT-file, TDMS or MDF 4 read as
    `bgc residuals` reads it (told by its first bytes), Parquet or CSV by pandas."""
    columns = _native.read_columns(path, names)
    if columns is not None:
        return dict(zip(names, columns))
    try:
        import pandas as pd
    except ImportError as e:  # pragma: no cover - pandas is an extra
        raise DataError(f"{path}: reading CSV or Parquet from a path needs pandas") from e
    with open(path, "rb") as f:
        parquet = f.read(4) == b"PAR1"
    frame = pd.read_parquet(path) if parquet else pd.read_csv(path, comment="#")
    return {str(k): frame[k].to_numpy() for k in frame.columns}


def _columns(
    data: Any, wanted: Sequence[str], time: str, mapping: Optional[Mapping[str, str]]
) -> "tuple[np.ndarray, List[np.ndarray], List[str]]":
    """The time, the column of each of `wanted`, and the names the data gives them (which
    the errors about their values use). `data` may be a path to a record file."""
    mapping = dict(mapping or {})
    for signal in mapping:
        if signal not in wanted:
            raise DataError(
                f"columns maps `{signal}`, which the residuals do not read{_close(signal, wanted)}; "
                f"they read {', '.join(wanted)}"
            )
    if isinstance(data, (str, os.PathLike)):
        data = _read_record(os.fspath(data), [time] + [mapping.get(s, s) for s in wanted])
    present = _names(data)

    def get(name: str, what: str) -> np.ndarray:
        if name not in present:
            raise DataError(
                f"no column `{name}` ({what}){_close(name, present)}; the data has {', '.join(present)}"
            )
        return _column(data, name)

    t = get(time, "time")
    labels = [time] + [mapping.get(s, s) for s in wanted]
    columns = [get(label, f"signal `{s}` of the model") for s, label in zip(wanted, labels[1:])]
    return t, columns, labels


class Residuals:
    """The residuals of a record, with their thresholds, alarms and candidates.

    Every array has a row per estimate (the estimators start once their window is full):
    `time` its instant, `values` and `thresholds` a column per ARR (``NaN`` where a residual
    is not a number, or has no threshold; `thresholds` is a read-only view of one row unless
    they are adaptive), `alarms` booleans likewise; `candidates`,
    `suspects` and `episode` the components the alarms point to, per estimate.
    """

    def __init__(self, names: List[str], out: Dict[str, Any]):
        self.names: List[str] = names
        self.time: np.ndarray = out["time"]
        self.values: np.ndarray = out["residuals"]
        # A residual without a threshold: its column is missing (NaN, as pandas marks it).
        missing = ~np.asarray(out["has_threshold"], dtype=bool)
        levels = out["thresholds"]
        if levels.ndim == 1:
            # Fixed levels: one row, broadcast (read-only) to every estimate.
            levels[missing] = np.nan
            self.thresholds: np.ndarray = np.broadcast_to(levels, (len(self.time), len(names)))
        else:
            # Marked in place: the array is this object's own, and a copy costs a pass.
            levels[:, missing] = np.nan
            self.thresholds = levels
        self.alarms: np.ndarray = out["alarms"]
        self._pattern: np.ndarray = out["pattern"]
        self._candidates: List[str] = out["candidates"]
        self._suspects: List[str] = out["suspects"]
        self._episode: np.ndarray = out["episode"]
        self._episodes: List[str] = out["episodes"]
        self._unsolved: np.ndarray = out["unsolved"]
        self._roots: List[str] = out["roots"]
        # Each held residual's hold and its threshold, two columns each (a calibration's).
        self._holds: np.ndarray = out.get("holds", np.zeros((len(self.time), 0)))
        self._held: List[str] = list(out.get("held", []))
        # With a calibration: per estimate, the signals outside the healthy record's range.
        self._beyond: Optional[np.ndarray] = out.get("beyond")
        self._beyond_names: List[str] = list(out.get("beyond_names", []))
        #: The fault's size once some residual alarms: per candidate component, the parameter
        #: whose change alone best explains the residuals over the span after the first alarm
        #: (dicts: component, parameter, value, half_width, model, cost, determined_with: the
        #: parameters calibration's record holds it only together with, whose values its
        #: own rests on: then only the ratio to `model` is determined), best fit first.
        self.sizes: List[Dict[str, Any]] = list(out.get("sizes", []))
        #: What a calibration chose and why (`calibrate`), a sentence each, as
        #: ``bgc residuals --calibrate`` says them on standard error.
        self.notes: List[str] = list(out.get("notes", []))

    def __len__(self) -> int:
        return len(self.time)

    def __repr__(self) -> str:
        raised = [n for n, a in zip(self.names, self.alarms.any(axis=0)) if a]
        return (
            f"<Residuals: {len(self)} estimates of {', '.join(self.names)}; "
            f"in alarm at some point: {', '.join(raised) or 'none'}>"
        )

    def __getitem__(self, name: str) -> np.ndarray:
        """The residual `name` over time."""
        try:
            return self.values[:, self.names.index(name)]
        except ValueError:
            raise KeyError(f"no residual `{name}`{_close(name, self.names)}") from None

    @property
    def candidates(self) -> np.ndarray:
        """Per estimate, the components whose signature the alarms match (space-separated)."""
        return np.asarray(self._candidates, dtype=object)[self._pattern]

    @property
    def suspects(self) -> np.ndarray:
        """Per estimate, the components whose signature holds every alarm."""
        return np.asarray(self._suspects, dtype=object)[self._pattern]

    @property
    def episode(self) -> np.ndarray:
        """Per estimate, the candidates from every alarm seen since the first."""
        return np.asarray(self._episodes, dtype=object)[self._episode]

    @property
    def beyond(self) -> Optional[np.ndarray]:
        """With a calibration, per estimate, the raw signals whose sample lies outside the
        range the healthy record covered (space-separated; empty inside): an alarm there may
        be the plant driven where calibration never saw it rather than a fault. ``None``
        without a calibration."""
        if self._beyond is None:
            return None
        return np.asarray(self._beyond_names, dtype=object)[self._beyond]

    def to_dict(self) -> Dict[str, np.ndarray]:
        """The columns of ``bgc residuals``'s CSV, as arrays."""
        out: Dict[str, np.ndarray] = {"t": self.time}
        for k, n in enumerate(self.names):
            out[n] = self.values[:, k]
        for k, n in enumerate(self.names):
            out[f"threshold_{n}"] = self.thresholds[:, k]
        for k, n in enumerate(self.names):
            out[f"alarm_{n}"] = self.alarms[:, k]
        for k, n in enumerate(self._held):
            out[f"hold_{n}"] = self._holds[:, 2 * k]
            out[f"hold_threshold_{n}"] = self._holds[:, 2 * k + 1]
        out["candidates"] = self.candidates
        out["suspects"] = self.suspects
        out["episode"] = self.episode
        beyond = self.beyond
        if beyond is not None:
            out["beyond"] = beyond
        if self._roots:
            roots = np.asarray([""] + self._roots, dtype=object)
            out["unsolved"] = roots[self._unsolved]
        return out

    def to_pandas(self) -> Any:
        """The columns of ``bgc residuals``'s CSV as a pandas DataFrame (the components'
        names as categoricals)."""
        import pandas as pd

        columns: Dict[str, Any] = dict(self.to_dict())
        columns["candidates"] = _categorical(pd, self._candidates, self._pattern)
        columns["suspects"] = _categorical(pd, self._suspects, self._pattern)
        columns["episode"] = _categorical(pd, self._episodes, self._episode)
        if self._beyond is not None:
            columns["beyond"] = _categorical(pd, self._beyond_names, self._beyond)
        return pd.DataFrame(columns)

    def to_polars(self) -> Any:
        """The columns of ``bgc residuals``'s CSV as a Polars DataFrame."""
        import polars as pl

        return pl.DataFrame({k: (v.tolist() if v.dtype == object else v) for k, v in self.to_dict().items()})


def _categorical(pd: Any, labels: List[str], codes: np.ndarray) -> Any:
    """`labels[codes]` as a categorical, without a string per row (two codes may carry the
    same label)."""
    unique, inverse = np.unique(np.asarray(labels, dtype=object), return_inverse=True)
    return pd.Categorical.from_codes(inverse[codes], list(unique))


@dataclass(frozen=True)
class Verification:
    """What ``bgc verify`` prints: each ARR on the healthy plant, each FSM entry under a
    fault of its component."""

    #: Rows (arr, worst relative residual, passed).
    arrs: List["tuple[str, float, bool]"]
    #: Rows (component, arr, marked in the FSM, worst relative residual, passed).
    entries: List["tuple[str, str, bool, float, bool]"]
    #: Components that cannot be faulted from the model (their entries are not checked).
    unchecked: List[str]
    #: The integration step and scale of the initial states used.
    step: float
    state_scale: float
    #: Each ARR realised by integration, when a run crossed a zero where `sign`, `abs`,
    #: `min` or `max` switch: the largest jump of its level across one, relative to its
    #: size (a relation differentiated through a dry friction jumps; its row then fails).
    jumps: Dict[str, float] = field(default_factory=dict)
    #: The zero crossings the runs went through.
    crossings: int = 0

    @property
    def passed(self) -> bool:
        """Whether every ARR and every entry behaved as derived."""
        return all(a[2] for a in self.arrs) and all(e[4] for e in self.entries)

    def to_pandas(self) -> "tuple[Any, Any]":
        """The two tables as pandas DataFrames."""
        import pandas as pd

        return (
            pd.DataFrame(self.arrs, columns=["arr", "worst", "pass"]),
            pd.DataFrame(self.entries, columns=["component", "arr", "marked", "worst", "pass"]),
        )


@dataclass(frozen=True)
class Identification:
    """The model's parameters fitted to a healthy record, as ``bgc identify`` fits them.

    `values` maps every parameter to its fitted value (the model's where the record does not
    determine it); `estimates` has a row per parameter (``name``, ``model``, ``value``,
    ``half_width`` of its 95 % interval (the noise's and the model error's, widened by twice
    the move of the fit made again with the estimators' windows halved, whose value is
    ``halved_windows``: the estimators' bias), ``std_error`` (before that widening),
    ``determined``: ``"yes"``,
    ``"weakly"``, ``"combination"``, ``"unread"``, ``"held"`` or ``"lost"``); `undetermined` the
    combinations the record does not separate (``scalings``: parameter → exponent, scaling
    each by ``s**exponent`` leaves every residual as it is; ``structural``: no record of
    these sensors could separate them); `model` the model with the fitted values;
    `criterion` the error minimised (``"equation"`` or ``"simulation"``); `cost` the
    residuals' mean square over their noise before and after the fit (never higher after);
    `lost` the parameters the fit ran away with, held at their starts (name, where it was
    going).
    """

    values: Dict[str, float]
    estimates: List[Dict[str, Any]]
    undetermined: List[Dict[str, Any]]
    rms: List["tuple[float, float]"]
    condition: float
    converged: bool
    model: "Model"
    criterion: str = "equation"
    cost: "tuple[float, float]" = (0.0, 0.0)
    lost: List["tuple[str, float]"] = field(default_factory=list)

    def to_pandas(self) -> Any:
        """The estimates as a DataFrame indexed by parameter."""
        import pandas as pd

        return pd.DataFrame(self.estimates).set_index("name")


class Model:
    """A compiled model: its parameters, signals, state equations, ARRs, fault signature
    matrix and fault classes, and what can be computed from it."""

    def __init__(self, native: Any, residuals: str = "per-sensor", realise: str = "lowest"):
        self._native = native
        self._options = (residuals, realise)
        self._json: Dict[str, Any] = json.loads(native.json())
        self._written: Optional["Model"] = None

    def _as_written(self) -> "Model":
        """This model with its ARRs realised as written (``realise="direct"``), the form
        their bounds from parameter uncertainty are derived for; compiled once."""
        if self._options[1] == "direct":
            return self
        if self._written is None:
            self._written = _recompile(self._native.text, self._native.file, self._options[0], "direct")
        return self._written

    def __reduce__(self) -> Any:
        return (_recompile, (self._native.text, self._native.file, *self._options))

    def __repr__(self) -> str:
        return (
            f"<Model {self.name}: {len(self.arrs)} ARRs over {', '.join(self.detectors)}; "
            f"{len(self.fault_classes)} fault classes>"
        )

    # What the model is.
    @property
    def name(self) -> str:
        """The model's name."""
        return self._json["model"]

    @property
    def parameters(self) -> Dict[str, float]:
        """Each parameter's nominal value."""
        return dict(self._json["parameters"])

    @property
    def inputs(self) -> List[str]:
        """The known inputs."""
        return list(self._json["inputs"])

    @property
    def detectors(self) -> List[str]:
        """The measured signals (the model's detectors, `De` and `Df`)."""
        return [s["name"] for s in self._json["sensors"]]

    @property
    def state_equations(self) -> List[Dict[str, str]]:
        """Each state's derivative (``state``, ``rhs``), as `bgc MODEL` prints it."""
        return list(self._json["state_equations"] or [])

    @property
    def arrs(self) -> List[Arr]:
        """The ARRs."""
        parameters = list(self._json["parameters"])
        return [
            Arr(
                name=a["name"],
                text=a["expr"],
                form=a["form"],
                junction=a.get("junction"),
                sensor=a.get("sensor"),
                components=list(a["components"]),
                signals=[r["signal"] for r in a["reads"]],
                parameters=parameters,
            )
            for a in self._json["arrs"]
        ]

    @property
    def fsm(self) -> Any:
        """The fault signature matrix: a row per component (kind, a 0/1 column per ARR,
        detectability ``Db`` and isolability ``Ib``); a pandas DataFrame when pandas is
        installed, else a list of dicts."""
        fsm = self._json["fsm"]
        rows = [
            {
                "component": r["component"],
                "kind": r["kind"],
                **dict(zip(fsm["residuals"], r["signature"])),
                "Db": r["Db"],
                "Ib": r["Ib"],
            }
            for r in fsm["rows"]
        ]
        try:
            import pandas as pd
        except ImportError:
            return rows
        return pd.DataFrame(rows).set_index("component")

    @property
    def fault_classes(self) -> List[List[str]]:
        """The components the ARRs cannot tell apart, class by class."""
        return [list(c) for c in self._json["isolability"]["selected"]["classes"]]

    @property
    def undetectable(self) -> List[str]:
        """Components whose faults no ARR shows."""
        return list(self._json["isolability"]["selected"]["undetectable"])

    @property
    def diagnostics(self) -> List[Dict[str, Any]]:
        """The warnings the model compiled with, each located (file, line, column)."""
        return list(self._native.diagnostics())

    @property
    def signals(self) -> List[str]:
        """The signals the residuals read, in order."""
        return list(self._native.signals())

    # What bgc writes.
    def to_dict(self) -> Dict[str, Any]:
        """The model as ``bgc MODEL --emit json`` writes it."""
        return json.loads(self._native.json())

    def text(self) -> str:
        """The summary ``bgc MODEL`` prints."""
        return self._native.emit("text")

    def latex(self, standalone: bool = False) -> str:
        """The ARRs and the FSM in LaTeX, as ``bgc MODEL --emit latex``."""
        return self._native.emit("latex", standalone)

    def dot(self) -> str:
        """The bond graph in Graphviz DOT, causal strokes drawn and components filled by
        fault class (as ``bgc MODEL --emit dot --residuals best`` draws them)."""
        return self._native.emit("dot")

    def rust(self) -> str:
        """The Rust residual generator, as ``bgc MODEL --emit rust``."""
        return self._native.emit("rust")

    def _repr_latex_(self) -> str:
        latex = self.latex()
        found = re.search(r"\\begin\{align\*?\}.*?\\end\{align\*?\}", latex, re.S)
        return f"$${found.group(0)}$$" if found else ""

    def _repr_html_(self) -> str:
        import html

        names = self._json["fsm"]["residuals"]
        head = "".join(f"<th>{html.escape(n)}</th>" for n in names)
        body = "".join(
            "<tr><th>{}</th><td>{}</td>{}<td>{}</td><td>{}</td></tr>".format(
                html.escape(r["component"]),
                html.escape(r["kind"]),
                "".join(f"<td>{'●' if s else ''}</td>" for s in r["signature"]),
                r["Db"],
                r["Ib"],
            )
            for r in self._json["fsm"]["rows"]
        )
        arrs = "".join(
            f"<li><b>{html.escape(a.name)}</b>: <code>{html.escape(a.text)} = 0</code></li>" for a in self.arrs
        )
        return (
            f"<h4>{html.escape(self.name)}</h4><ul>{arrs}</ul>"
            f"<table><thead><tr><th>component</th><th>kind</th>{head}<th>Db</th><th>Ib</th></tr></thead>"
            f"<tbody>{body}</tbody></table>"
        )

    # What can be computed.
    def residuals(
        self,
        data: Any,
        *,
        time: str = "t",
        columns: Optional[Mapping[str, str]] = None,
        thresholds: Optional[Union[float, Mapping[str, float]]] = None,
        calibrate: Any = None,
        false_alarm_rate: Union[float, str] = 0.0,
        margin: float = 0.2,
        window: Optional[int] = None,
        estimator: Optional[str] = None,
        degree: Optional[int] = None,
        integration: Union[int, str, None] = None,
        debounce: int = 1,
        adaptive: bool = False,
        size_span: Optional[float] = 5.0,
        calibration: Any = None,
        keep_model: bool = False,
        cusum: Union[bool, float] = False,
        within: Optional[float] = None,
    ) -> Residuals:
        """The residuals of a record, as ``bgc residuals`` computes them.

        `data`: a dict of arrays, a pandas or a Polars DataFrame, with a time column `time`
        at a uniform step and a column per signal the residuals read (`signals`), named as in
        the model or as `columns` maps them (``{"y1": "motor_speed"}``).

        Thresholds: `thresholds` gives levels (one for all, or by ARR name). `calibrate`, a
        healthy record with the same columns, calibrates everything else on it exactly as
        ``bgc residuals --calibrate`` does (one implementation, in Rust): the model fitted to
        it (unless `keep_model`), the estimator's window and kind, each integrated residual's
        integration, and each threshold for the false alarms stated: `false_alarm_rate` 0
        (the default) for thresholds a healthy record as long as this one crosses with
        probability 1e-3, a rate in time (``"1/h"``, ``"0.5/min"``, ``"2/d"``), or a share
        of healthy samples allowed above them (``0.01``); every threshold at least the healthy
        record's largest |residual| times 1 + `margin`. What it chose and why is in
        `Residuals.notes`. With `cusum` (``True``, or the drift K in deviations, 0.5 by
        default), a CUSUM beside each threshold for small persistent faults, as ``bgc
        residuals --cusum K``. `within`: the seconds after a fault by which it should show
        (``--within``): each integrated residual's hold is chosen by the margin a fault
        gets then (``None``: the window under which a fault that persists gets the most
        margin over the healthy record's length, so that it stays in alarm while it lasts). A residual without a threshold raises no alarm. `adaptive` adds
        the bound from the parameters' stated uncertainties (`+- 5%`) at each sample; as
        ``bgc residuals --adaptive``, it evaluates the ARRs as written (``realise="direct"``),
        the form those bounds are derived for, whatever the model was compiled with.

        Estimation: `window`, `estimator` (``"savitzky-golay"`` or ``"modulating"``),
        `degree` and `integration` (the last N samples, or ``"start"``) fix what calibration
        would choose; without `calibrate`, polynomial fits over 11 samples (101 for
        ``"modulating"``) of degree 3 or the highest derivative read, integrated residuals
        over the last 250 samples.

        Kept calibration: `calibration`, the path of a file ``bgc residuals MODEL RECORD
        --calibrate HEALTHY --save-calibration FILE`` wrote for this model, decides as the CLI
        does with ``--calibration FILE``: its parameters, estimator, integrations and thresholds
        (a level in `thresholds` still wins); refused (`DataError`) for another model's text,
        other residuals or another step, and with `calibrate`, `window`, `degree` or
        `adaptive`.

        Size: once some residual alarms, each candidate of the episode has each of its
        parameters fitted alone over `size_span` seconds from the first alarm's samples on
        (``None``: not sized; at least 102 samples, twice the sizes' estimator window, where
        the record's step leaves fewer), as ``bgc residuals`` does: `Residuals.sizes`, best
        fit first.
        """
        # The bounds are derived for the relations as written: the CLI switches too.
        native = (self._as_written() if adaptive else self)._native
        names = self.arrs
        arr_names = [a.name for a in names]
        levels: List[Optional[float]] = [None] * len(arr_names)
        if isinstance(thresholds, Mapping):
            for name, level in thresholds.items():
                if name not in arr_names:
                    raise KeyError(f"thresholds names `{name}`, not an ARR{_close(name, arr_names)}")
                levels[arr_names.index(name)] = float(level)
        elif thresholds is not None:
            levels = [float(thresholds)] * len(arr_names)
        options = dict(
            window=window,
            estimator=estimator,
            degree=degree,
            integration=None if integration is None else str(integration),
            debounce=debounce,
        )
        kept = None
        if calibration is not None:
            if calibrate is not None or window is not None or degree is not None or adaptive:
                raise ValueError(
                    "calibration decides the estimator, the integrations and the thresholds: "
                    "not with calibrate, window, degree or adaptive"
                )
            with open(calibration, encoding="utf-8") as f:
                kept = (f.read(), str(calibration), tuple(self._options))
        healthy = None
        if calibrate is not None:
            ht, hcols, hlabels = _columns(calibrate, self.signals, time, columns)
            drift = None if cusum is False else (0.5 if cusum is True else float(cusum))
            healthy = (
                ht, hcols, hlabels, str(false_alarm_rate), float(margin), bool(keep_model), drift,
                None if within is None else float(within),
            )
        if adaptive:
            levels = [0.0 if level is None else level for level in levels]
        t, cols, labels = _columns(data, self.signals, time, columns)
        out = _native.residuals(
            native, t, cols, thresholds=levels, labels=labels, adaptive=adaptive,
            size_span=size_span, calibration=kept, calibrate=healthy, **options
        )
        return Residuals(arr_names, out)

    def simulate(self, scenario: Source) -> Any:
        """The model run under a scenario (a path or the text, in the language of ``bgc
        simulate``): ``t``, the inputs, the states and the measured signals, a column each;
        a pandas DataFrame when pandas is installed, else a dict of arrays."""
        text, file = _read(scenario, ".scn", "<scenario>")
        columns, samples = _native.simulate(self._native, text, file)
        try:
            import pandas as pd
        except ImportError:
            return {c: samples[:, k] for k, c in enumerate(columns)}
        return pd.DataFrame(samples, columns=columns)

    def with_parameters(self, values: Mapping[str, float]) -> "Model":
        """This model with `values` (name → value) in place of its parameters' values, as
        ``--params`` gives them to the CLI; raises `ValueError` for a name it does not
        declare."""
        text = _native.with_values(self._native.text, [(k, float(v)) for k, v in values.items()])
        return _recompile(text, self._native.file, *self._options)

    def identify(
        self,
        data: Any,
        *,
        time: str = "t",
        columns: Optional[Mapping[str, str]] = None,
        window: int = 51,
        integration_window: int = 250,
        only: Optional[Sequence[str]] = None,
        fix: Optional[Sequence[str]] = None,
        span: Optional[Tuple[float, float]] = None,
        criterion: str = "evidence",
    ) -> Identification:
        """Fits the parameters to a healthy record (a dict of arrays, a pandas or Polars
        DataFrame), as ``bgc identify`` does (see docs/identification.md): least squares on
        the residuals as they are evaluated, each over the noise it carries; 95 % intervals;
        the combinations the record does not determine. `only` and `fix` choose what is
        fitted; `window` is the Savitzky–Golay window, `integration_window` the window the
        integrated residuals are taken over. `criterion` is the error minimised, as
        ``bgc identify --criterion``: ``"equation"`` (the ARRs' residuals), ``"simulation"``
        (each sensor against a copy of the model the recorded inputs drive from rest) or
        ``"evidence"`` (whichever predicts the record's held-out last 30 % better); the one
        used is the result's `criterion`.

        With `span=(from, to)` (seconds), only the residuals over that span are fitted, those
        integrated from the start taken from its start, as ``bgc residuals`` sizes a fault:
        ``model.identify(record, only=["fe"], span=(31.0, 36.0))`` after a first alarm at
        31 s gives the friction's new value with its interval."""
        t, cols, labels = _columns(data, self.signals, time, columns)
        out = _native.identify(
            self._native, t, cols, labels=labels, window=window, integration=integration_window,
            only=list(only) if only else None, fix=list(fix) if fix else None,
            span=tuple(span) if span is not None else None, criterion=criterion,
        )
        values = {e["name"]: e["value"] for e in out["estimates"]}
        return Identification(
            values=values,
            estimates=list(out["estimates"]),
            undetermined=list(out["undetermined"]),
            rms=[tuple(r) for r in out["rms"]],
            condition=out["condition"],
            converged=out["converged"],
            model=self.with_parameters(values),
            criterion=out["criterion"],
            cost=tuple(out["cost"]),
            lost=[tuple(x) for x in out["lost"]],
        )

    def sensors(self, components: Optional[Sequence[str]] = None, goal: str = "isolable") -> Dict[str, Any]:
        """Where to add detectors so that `components` (every one by default) become
        ``"detectable"`` or as ``"isolable"`` as detectors can make them, as ``bgc sensors``
        answers: the classes now (``now``) and with every junction measured (``most``), and
        the smallest sets of detectors found (``proposals``, each with its ``detectors`` as
        (kind, junction) and the ``classes`` they give)."""
        return _native.sensors(self._native, list(components or []), goal)

    def verify(self, *, input_scale: float = 1.0, state_scale: float = 0.5, runs: int = 3) -> Verification:
        """Checks every ARR and FSM entry on simulated trajectories, as ``bgc verify``."""
        out = _native.verify(self._native, input_scale=input_scale, state_scale=state_scale, runs=runs)
        return Verification(
            arrs=list(out["arrs"]),
            entries=list(out["entries"]),
            unchecked=list(out["unchecked"]),
            step=out["step"],
            state_scale=out["state_scale"],
            jumps=dict(out["jumps"]),
            crossings=out["crossings"],
        )
