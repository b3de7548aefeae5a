"""mapgauge: the accuracy of LiDAR SLAM point-cloud maps, from surveyed L-shaped targets.

The same Rust core as the ``mapgauge`` command-line tool, with numpy in and out::

    import mapgauge
    ev = mapgauge.evaluate("map.pcd", "survey.csv")
    print(ev.absolute["mean"])          # E_abs, metres
    ev.write("out/")                    # result.json, targets.csv, pairs.csv, report.html

Every number is the CLI's: ``ev.to_dict()`` is exactly the ``result.json`` that
``mapgauge eval`` writes. Bad input raises :class:`MapgaugeError` (a
``ValueError``) with the CLI's one-line message; the failures a caller may
act on raise its subclasses :class:`TooFewFoundError` (``found``,
``need``), :class:`FrameNotFoundError` (``detections``) or
:class:`NotMetresError` (a map in millimetres); a bad file raises
:class:`ParseError` (``path``, ``line``), a value out of range
:class:`ParamError`, a refused read or write :class:`FileError` (``path``,
``errno``). Rust works without the GIL.
"""

from __future__ import annotations

import json
import math
import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _mapgauge
from ._mapgauge import (
    FileError,
    FrameNotFoundError,
    MapgaugeError,
    NotMetresError,
    ParamError,
    ParseError,
    Survey,
    TooFewFoundError,
    read_points,
)
from ._mapgauge import read_survey as _read_survey

__version__: str = _mapgauge.__version__

__all__ = [
    "MapgaugeError",
    "TooFewFoundError",
    "FrameNotFoundError",
    "NotMetresError",
    "ParseError",
    "ParamError",
    "FileError",
    "Survey",
    "Target",
    "Accuracy",
    "Evaluation",
    "Located",
    "Scene",
    "evaluate",
    "errors",
    "locate",
    "read_points",
    "read_survey",
    "survey",
    "synth",
    "table",
    "batch",
    "config",
    "__version__",
]

PathLike = Union[str, "os.PathLike[str]"]
SurveyLike = Union[Survey, PathLike, Mapping[str, Sequence[float]]]
Progress = Callable[[int, int], Any]

_SECTIONS = ("crop", "tight", "locate", "metrics", "frame", "gates")


def _is_path(x: Any) -> bool:
    return isinstance(x, (str, os.PathLike))


def _json(obj: Any, what: str) -> str:
    """JSON of a user dict; NaN is refused here, where the key can be named."""
    try:
        return json.dumps(obj, allow_nan=False)
    except (TypeError, ValueError) as e:
        raise MapgaugeError(f"{what}: {e}") from None


def _merge(base: Dict[str, Any], over: Mapping[str, Any]) -> Dict[str, Any]:
    out = dict(base)
    for k, v in over.items():
        if isinstance(v, Mapping) and isinstance(out.get(k), Mapping):
            out[k] = _merge(dict(out[k]), v)
        else:
            out[k] = v
    return out


def _config_dict(config: Optional[Mapping[str, Any]], sections: Mapping[str, Any], seed: Optional[int]) -> Dict[str, Any]:
    cfg: Dict[str, Any] = {}
    if config is not None:
        if not isinstance(config, Mapping):
            raise ParamError("config: expected a dict with the sections of `mapgauge eval --print-config`")
        cfg = _merge(cfg, config)
    for k, v in sections.items():
        if k not in _SECTIONS:
            raise ParamError(f"unknown configuration section `{k}` (expected one of {', '.join(_SECTIONS)}, seed)")
        if not isinstance(v, Mapping):
            raise ParamError(f"{k}: expected a dict of its keys, as `mapgauge eval --print-config` shows them")
        cfg = _merge(cfg, {k: v})
    if seed is not None:
        # As the CLI's --seed: both random streams.
        cfg = _merge(cfg, {"locate": {"seed": seed}, "tight": {"seed": seed}})
    return cfg


def config(config: Optional[Mapping[str, Any]] = None, *, seed: Optional[int] = None, **sections: Mapping[str, Any]) -> Dict[str, Any]:
    """The full configuration: defaults merged with ``config`` and the section keywords.

    Keys are those of ``mapgauge eval --print-config``; an unknown key or a value
    out of range raises :class:`ParamError`. ``mapgauge.config()["locate"]``
    shows every localisation parameter with its default.
    """
    j, _ = _mapgauge._config(_json(_config_dict(config, sections, seed), "config"))
    return json.loads(j)


def config_toml(config: Optional[Mapping[str, Any]] = None, *, seed: Optional[int] = None, **sections: Mapping[str, Any]) -> str:
    """The full configuration as the TOML text ``--print-config`` prints (a ``--config`` file)."""
    _, t = _mapgauge._config(_json(_config_dict(config, sections, seed), "config"))
    return t


def read_survey(path: PathLike, origin: Optional[Sequence[float]] = None) -> Survey:
    """Reads a survey CSV as ``mapgauge eval --survey`` does.

    ``origin`` is the ENU origin ``(lat, lon[, alt])`` for WGS84 surveys (default:
    the first target), like ``--origin``.
    """
    return _read_survey(os.fspath(path), None if origin is None else [float(v) for v in origin])


def survey(targets: Union[Mapping[str, Sequence[float]], Sequence[str]], positions: Optional[Any] = None) -> Survey:
    """A survey in a local metric frame from ``{id: (x, y[, z])}``, or from ids and an (M, 2|3) array.

    Without heights (2 columns) only 2D errors are possible, as with an
    ``id,x,y`` survey file.
    """
    if positions is None:
        if not isinstance(targets, Mapping):
            raise MapgaugeError("survey: give a mapping {id: (x, y[, z])}, or ids and an (M, 2|3) array")
        ids = [str(k) for k in targets.keys()]
        rows = [tuple(v) for v in targets.values()]
        widths = {len(r) for r in rows}
        if len(widths) > 1:
            raise MapgaugeError("survey: every target needs the same coordinates, all (x, y) or all (x, y, z)")
        xyz = np.asarray(rows, dtype=np.float64).reshape(len(rows), widths.pop() if widths else 3)
    else:
        if isinstance(targets, Mapping) or isinstance(targets, (str, bytes)):
            raise MapgaugeError("survey: with positions, give the ids as a sequence")
        ids = [str(i) for i in targets]
        xyz = np.asarray(positions, dtype=np.float64)
    if xyz.ndim != 2 or xyz.shape[1] not in (2, 3):
        raise MapgaugeError(f"survey: expected (M, 2) or (M, 3) positions, got shape {tuple(xyz.shape)}")
    has_z = xyz.shape[1] == 3
    if not has_z:
        xyz = np.column_stack([xyz, np.zeros(len(xyz))])
    return _mapgauge._survey_from_arrays(ids, np.ascontiguousarray(xyz), has_z)


def _as_survey(s: SurveyLike, ids_positions: Optional[Any] = None) -> Survey:
    if isinstance(s, Survey) or _is_path(s):
        if ids_positions is not None:
            raise MapgaugeError("survey: positions go with a sequence of ids, not with a survey file or Survey")
        return s if isinstance(s, Survey) else read_survey(s)  # type: ignore[arg-type]
    return survey(s, ids_positions)  # type: ignore[arg-type]


def _as_points(a: Any, what: str) -> np.ndarray:
    arr = np.asarray(a)
    if arr.dtype not in (np.float64, np.float32):
        arr = arr.astype(np.float64)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise MapgaugeError(f"{what}: expected an (N, 3) array, got shape {tuple(arr.shape)}")
    return np.ascontiguousarray(arr)


def _xyz(d: Optional[Mapping[str, Any]]) -> Optional[np.ndarray]:
    if d is None:
        return None
    z = d.get("z")
    return np.array([d["x"], d["y"], math.nan if z is None else z], dtype=np.float64)


@dataclass(frozen=True)
class Target:
    """One survey target's outcome, from result.json's ``targets`` (and ``eval.targets``).

    Positions are (3,) float64 arrays with z = NaN where unknown; ``map`` is in
    the map frame, ``survey`` and ``aligned`` in the survey frame.
    """

    id: str
    status: str
    """``ok``, ``not_found``, ``excluded`` or ``ambiguous`` (mapped twice)."""
    reason: Optional[str]
    role: Optional[str]
    survey: np.ndarray
    map: Optional[np.ndarray]
    aligned: Optional[np.ndarray]
    abs_error: Optional[float]
    """Absolute error (m) in the result's dimension."""
    loo_error: Optional[float]
    """Error under an alignment fitted without this target."""
    detail: Optional[Dict[str, Any]]
    """The pipeline's record of the target (``eval.targets``: crops, samples,
    spread, failed stage; for a sphere its fit under ``sphere``, for a board
    under ``board``); ``None``
    for :func:`errors`."""
    model: str = "l"
    """What the target is: ``l``, ``sphere`` or ``board`` (the survey's
    ``model`` column; ``l`` for :func:`errors`, which locates nothing)."""


class Accuracy:
    """Errors of positions against a survey: the content of a ``result.json``."""

    def __init__(self, core: Any) -> None:
        self._core = core
        self._dict: Optional[Dict[str, Any]] = None

    def to_json(self) -> str:
        """result.json's exact text (pretty JSON, ending in a newline)."""
        return self._core.to_json()

    def to_dict(self) -> Dict[str, Any]:
        """result.json's content as plain Python objects (a fresh copy)."""
        return json.loads(self.to_json())

    def _d(self) -> Dict[str, Any]:
        if self._dict is None:
            self._dict = self.to_dict()
        return self._dict

    @property
    def absolute(self) -> Dict[str, Any]:
        """Absolute error statistics: ``n, mean (E_abs), std (σ_abs), rmse, median, max``."""
        return dict(self._d()["absolute"])

    @property
    def relative(self) -> Dict[str, Any]:
        """Relative error statistics (``mean`` = E_rel, ``std`` = σ_rel) and every ``pairs`` entry."""
        return json.loads(json.dumps(self._d()["relative"]))

    @property
    def alignment(self) -> Dict[str, Any]:
        """The fitted map → survey transform (method, rotation, translation, scale, ...)."""
        return json.loads(json.dumps(self._d()["alignment"]))

    @property
    def gates(self) -> List[Dict[str, Any]]:
        """Each quality gate's verdict (``result.json``'s ``gates``): empty without gates."""
        return list(self._d().get("gates", []))

    @property
    def gate_outcome(self) -> Optional[Dict[str, Any]]:
        """What the gates decided under their policy (``policy``, ``outcome``,
        ``exit_code``, ``counts``), or ``None`` without gates."""
        return self._d().get("gate_outcome")

    @property
    def iso19157(self) -> Optional[Dict[str, Any]]:
        """ISO 19157 measures of the checkpoints (``result.json``'s ``iso19157``):
        ``bias`` per axis with ``ci95``, ``ce90``/``ce95``/``le90``/``le95`` with
        the bias accounted for, the count and rate beyond ``threshold_m``."""
        return json.loads(json.dumps(self._d().get("iso19157")))

    @property
    def scores(self) -> Dict[str, Dict[str, Any]]:
        """Benchmark scores asked for with ``metrics={"scores": ["hilti2023"]}``
        (``result.json``'s ``scores``): by rule, each with ``total`` (0-100),
        ``range95``, ``targets``, ``located`` and ``per_target``; empty when none."""
        return json.loads(json.dumps(self._d().get("scores", {})))

    @property
    def warnings(self) -> List[str]:
        """Caveats for the reader, as result.json's ``warnings``."""
        return list(self._d()["warnings"])

    @property
    def targets(self) -> List[Target]:
        """Every survey target, in survey order."""
        d = self._d()
        details = {t["id"]: t for t in (d.get("eval") or {}).get("targets", [])}
        return [
            Target(
                id=t["id"],
                status=t["status"],
                reason=t.get("reason"),
                role=t.get("role"),
                survey=_xyz(t["survey"]),  # type: ignore[arg-type]
                map=_xyz(t.get("map")),
                aligned=_xyz(t.get("aligned")),
                abs_error=t.get("abs_error"),
                loo_error=t.get("loo_error"),
                detail=details.get(t["id"]),
                model=(details.get(t["id"]) or {}).get("model", "l"),
            )
            for t in d["targets"]
        ]

    def write(self, out_dir: PathLike) -> None:
        """Writes result.json, targets.csv and pairs.csv into ``out_dir`` (created if needed)."""
        self._core.write(os.fspath(out_dir))

    def write_checkpoints(self, path: PathLike, crs: Optional[str] = None) -> str:
        """Writes every target as a checkpoint to ``path`` (.gpkg, .geojson for
        WGS84 surveys, or .csv), as ``--checkpoints`` does: surveyed and measured
        positions in the survey's CRS, dx/dy/dz, error, σ, status and role.
        ``crs`` names a projected survey's EPSG code (``"EPSG:32633"``).
        Returns the CRS the positions are written in."""
        return self._core.write_checkpoints(os.fspath(path), crs)

    def __repr__(self) -> str:
        a, r = self._d()["absolute"], self._d()["relative"]
        return f"<{type(self).__name__} E_abs={a['mean']:.4f} m σ_abs={a['std']:.4f} m E_rel={r['mean']:.4f} m, {a['n']} targets scored>"


class Evaluation(Accuracy):
    """A map evaluated against a survey: what ``mapgauge eval`` computes and writes."""

    def crop(self, target_id: str, kind: str = "tight") -> np.ndarray:
        """The ``loose`` or ``tight`` crop of a target, (K, 3) float64, map frame."""
        return self._core.crop(self._index(target_id), kind)

    def samples(self, target_id: str) -> np.ndarray:
        """The accepted sample corners whose mean is the located corner, (S, 3), map frame."""
        return self._core.samples(self._index(target_id))

    def _index(self, target_id: str) -> int:
        ids = [t["id"] for t in self._d()["targets"]]
        try:
            return ids.index(str(target_id))
        except ValueError:
            raise MapgaugeError(f"no target `{target_id}` in the survey") from None

    def write(self, out_dir: PathLike, report: bool = True) -> None:  # type: ignore[override]
        """Writes result.json, targets.csv, pairs.csv and (unless ``report=False``)
        report.html into ``out_dir``, as ``mapgauge eval --out`` does. The report
        hashes the input files with BLAKE3 (about 0.3 s per GB of map)."""
        self._core.write(os.fspath(out_dir), report)


def evaluate(
    map: Union[PathLike, np.ndarray],
    survey: SurveyLike,
    positions: Optional[Any] = None,
    *,
    config: Optional[Mapping[str, Any]] = None,
    seed: Optional[int] = None,
    crops: Optional[PathLike] = None,
    progress: Optional[Progress] = None,
    **sections: Mapping[str, Any],
) -> Evaluation:
    """Evaluates a map against a survey: crop, locate every target, align, score.

    ``map`` is a map file (PCD, PLY, LAS/LAZ, E57, XYZ) or an (N, 3) float64 or
    float32 array in the map frame (non-finite rows are skipped and counted).
    ``survey`` is a survey CSV path, a :class:`Survey`, a mapping
    ``{id: (x, y[, z])}``, or ids with their (M, 2|3) ``positions``.

    Configuration keys are those of ``mapgauge eval --print-config``: a nested
    ``config`` dict and/or one keyword per section, e.g.
    ``evaluate(m, s, metrics={"align": "rigid3d", "dim": "3d"}, crop={"radius": 3})``;
    ``seed`` sets both random streams as ``--seed`` does; quality gates go in
    ``gates={"checks": ["E_abs<=0.05", "found>=0.9"], "policy": "strict"}``
    and come back as ``Evaluation.gates`` and ``.gate_outcome``; benchmark
    scores in ``metrics={"scores": ["hilti2022", "hilti2026"]}`` come back as
    ``Evaluation.scores``. ``crops`` is a
    directory of hand-made tight crops (``--crops``). ``progress(bytes_read,
    total_bytes)`` is called at most every 0.1 s while a map file streams.
    """
    s = _as_survey(survey, positions)
    cfg = _config_dict(config, sections, seed)
    m: Any = os.fspath(map) if isinstance(map, (str, os.PathLike)) else _as_points(map, "map")
    core = _mapgauge._evaluate(
        m,
        s,
        _json(cfg, "config") if cfg else None,
        None if crops is None else os.fspath(crops),
        progress,
    )
    return Evaluation(core)


def errors(
    survey: SurveyLike,
    estimates: Union[PathLike, Mapping[str, Optional[Sequence[float]]]],
    *,
    align: str = "rigid2d",
    dim: str = "2d",
    survey_sigma: Union[None, float, Tuple[float, Optional[float]]] = None,
    threshold: Optional[float] = None,
    scores: Sequence[str] = (),
) -> Accuracy:
    """Scores map positions of the targets against a survey, as ``mapgauge errors`` does.

    ``estimates`` is an estimates CSV or ``{id: (x, y[, z]) or None}`` in the map
    frame (``None``: not found). ``align`` is none, rigid2d, rigid2d+z, rigid3d,
    similarity2d, similarity3d or robust2d; ``dim`` 2d or 3d; ``survey_sigma`` the
    survey's own 1-σ error ``(h, v)`` folded into the ASPRS figures; ``threshold``
    (m) ISO 19157's count of checkpoints beyond it; ``scores`` benchmark rules
    (``"hilti2022"``, ``"hilti2023"``, ``"hilti2026"``), as ``--score``.
    """
    s = _as_survey(survey)
    metrics: Dict[str, Any] = {"align": align, "dim": dim, "scores": list(scores)}
    if threshold is not None:
        metrics["threshold_m"] = float(threshold)
    if survey_sigma is not None:
        if isinstance(survey_sigma, (int, float)):
            metrics["survey_sigma_h"] = float(survey_sigma)
        else:
            metrics["survey_sigma_h"], metrics["survey_sigma_v"] = survey_sigma
    if _is_path(estimates):
        est: Any = os.fspath(estimates)  # type: ignore[arg-type]
    else:
        if not isinstance(estimates, Mapping):
            raise MapgaugeError("estimates: give a CSV path or a mapping {id: (x, y[, z]) or None}")
        ids = [str(k) for k in estimates]
        found = [tuple(v) for v in estimates.values() if v is not None]
        widths = {len(r) for r in found}
        if len(widths) > 1 or (widths and widths.pop() not in (2, 3)):
            raise MapgaugeError("estimates: every position needs the same coordinates, all (x, y) or all (x, y, z)")
        has_z = bool(found) and len(found[0]) == 3
        rows: List[Tuple[float, ...]] = []
        reasons: List[Optional[str]] = []
        for v in estimates.values():
            if v is None:
                rows.append((0.0, 0.0, 0.0))
                reasons.append("not found")
            else:
                t = tuple(float(c) for c in v)
                rows.append(t if has_z else t + (0.0,))
                reasons.append(None)
        xyz = np.asarray(rows, dtype=np.float64).reshape(len(rows), 3)
        est = (ids, xyz, has_z, reasons)
    return Accuracy(_mapgauge._errors(s, est, _json(metrics, "metrics")))


@dataclass(frozen=True)
class Located:
    """A target located in a tight crop by the paper's k-means → RANSAC → SVD method."""

    corner: np.ndarray
    """(3,) the corner: mean of the accepted samples, in the crop's frame."""
    std: np.ndarray
    """(3,) population standard deviation of the samples per axis (m)."""
    spread: float
    """Norm of ``std`` (m)."""
    accepted: int
    attempts: int
    plate_angle_deg: float
    normals: np.ndarray
    """(2, 3) plate normals of the reference sample."""
    inliers: Tuple[int, int]
    samples: np.ndarray
    """(S, 3) every accepted sample corner."""


def locate(points: np.ndarray, up: Optional[Sequence[float]] = None, **params: Any) -> Located:
    """Locates the corner of an L-target in a tight crop ((N, 3) array), as ``mapgauge locate``.

    ``up`` is the local vertical (default +z); ``params`` are the ``locate``
    keys of ``--print-config`` (``samples``, ``inlier_threshold``, ``seed``, ...).
    Raises :class:`MapgaugeError` when the crop cannot be located.
    """
    pts = _as_points(points, "points")
    u = None if up is None else [float(v) for v in up]
    if u is not None and len(u) != 3:
        raise MapgaugeError("up: expected (x, y, z)")
    d = _mapgauge._locate(pts, u, _json(params, "locate") if params else None)
    return Located(
        corner=np.asarray(d["corner"]),
        std=np.asarray(d["std"]),
        spread=d["spread"],
        accepted=d["accepted"],
        attempts=d["attempts"],
        plate_angle_deg=d["plate_angle_deg"],
        normals=np.asarray(d["normals"]),
        inliers=tuple(d["inliers"]),  # type: ignore[arg-type]
        samples=d["samples"],
    )


@dataclass(frozen=True)
class Scene:
    """A synthetic scene: the map's points, its exact survey and the ground truth."""

    points: np.ndarray
    """(N, 3) float64 map points."""
    survey: Survey
    truth: Dict[str, Any]
    """What ``mapgauge synth`` writes as truth.json (targets' true map positions, distortion, ...)."""


def synth(**params: Any) -> Scene:
    """A LiDAR-like synthetic scene with surveyed L-targets, in memory (``mapgauge synth``).

    ``params`` are those of ``mapgauge synth`` (``seed``, ``points``,
    ``targets``, ``distortion={...}``, ...); the default is 2 M points and 5 targets.
    """
    pts, s, truth = _mapgauge._synth(_json(params, "synth") if params else None)
    return Scene(points=pts, survey=s, truth=json.loads(truth))


def table(
    results: Sequence[Union[Accuracy, PathLike, Mapping[str, Any]]],
    names: Optional[Sequence[str]] = None,
    format: str = "markdown",
    which: str = "both",
) -> str:
    """The paper's Tables I (relative) and II (absolute) over several results, as ``mapgauge table`` prints them.

    ``results`` are :class:`Evaluation` / :class:`Accuracy` objects, result.json
    paths or their dicts; ``names`` label the rows (default: a result.json's
    directory name as ``mapgauge table`` uses, an evaluation's map file name
    without extension, else ``run 1``, ``run 2``, ...). ``format`` is markdown,
    latex, csv, html, json or text; ``which`` relative, absolute or both.

    Runs scored against different surveys (a target surveyed elsewhere, or
    other targets) do not compare: each such pair raises a ``UserWarning``
    with the message ``mapgauge table`` prints.
    """
    results = list(results)
    if names is not None:
        names = [str(n) for n in names]
        if len(names) != len(results):
            raise MapgaugeError(f"names has {len(names)} names for {len(results)} results")
    runs = []
    for i, r in enumerate(results):
        if isinstance(r, Accuracy):
            kind, payload = "json", r.to_json()
            src = (r._d().get("eval") or {}).get("map", "<memory>")
            default = Path(src).stem if src != "<memory>" else f"run {i + 1}"
        elif _is_path(r):
            p = Path(os.fspath(r))  # type: ignore[arg-type]
            kind, payload, default = "path", str(p), p.parent.name or str(p)
        elif isinstance(r, Mapping):
            kind, payload, default = "json", _json(r, "result"), f"run {i + 1}"
        else:
            raise MapgaugeError(f"result {i + 1}: expected an Evaluation, a result.json path or its dict")
        runs.append((names[i] if names is not None else default, kind, payload))
    text, cautions = _mapgauge._table(runs, format, which)
    for c in cautions:
        warnings.warn(c, UserWarning, stacklevel=2)
    return text


def _batch_worker(kind: str, payload: str, base: str, index: int, out: str) -> str:
    """One run of a batch, in whatever process the executor chose (module
    level, so process pools and clusters can pickle it)."""
    return _mapgauge._batch_run(kind, payload, base, index, out)


def batch(
    manifest: Union[PathLike, Sequence[Mapping[str, Any]]],
    *,
    out: Optional[PathLike] = None,
    executor: Optional[Any] = None,
    jobs: Optional[int] = None,
    baseline: Optional[str] = None,
    config: Optional[PathLike] = None,
    overrides: Optional[Mapping[str, Any]] = None,
) -> Dict[str, Any]:
    """Evaluates many maps, as ``mapgauge batch`` does, on any executor.

    ``manifest`` is a batch manifest (TOML, as for ``mapgauge batch``) or a
    list of runs, each a dict with ``method``, ``sequence``, ``map``,
    ``survey`` and optionally ``config`` (a TOML file) and ``overrides``
    (dicts of config sections); with a list, ``baseline``, ``config`` and
    ``overrides`` apply to every run and relative paths are from the current
    directory. Each run's files go to ``out/<sequence>/<method>/``; a run
    whose inputs, settings and version are those of its last finished run
    is reused; a failed run leaves ``error.txt`` and stops nothing.

    ``executor`` is any :class:`concurrent.futures.Executor`: by default a
    process pool of ``jobs`` workers (the manifest's ``jobs``, else the
    cores; "spawn" processes), or e.g. a Dask cluster's
    ``distributed.Client(...).get_executor()`` to spread the runs over many
    machines (the paths must be readable where the runs execute). The
    summary is written into ``out`` (``batch.json``, ``leaderboard.csv``,
    ``index.html``...) and returned as a dict: ``runs``, ``leaderboard``,
    ``comparisons`` and ``exit_code`` (``mapgauge batch``'s). With the default
    process pool, call it under ``if __name__ == "__main__":`` in a script
    ("spawn" workers import the script).
    """
    if _is_path(manifest):
        if baseline is not None or config is not None or overrides is not None:
            raise ParamError("batch: baseline, config and overrides go in the manifest file")
        # Absolute: the runs may execute in other processes, other directories.
        kind, payload, base = "path", os.path.abspath(os.fspath(manifest)), ""
    else:
        raw: Dict[str, Any] = {"run": [dict(r) for r in manifest]}
        for r in raw["run"]:
            for k in ("map", "survey", "config"):
                if k in r and r[k] is not None:
                    r[k] = os.fspath(r[k])
        if baseline is not None:
            raw["baseline"] = baseline
        if config is not None:
            raw["config"] = os.fspath(config)
        if overrides is not None:
            raw["overrides"] = dict(overrides)
        kind, payload, base = "json", _json(raw, "batch runs"), os.getcwd()
    runs, m_out, _, m_jobs = _mapgauge._batch_plan(kind, payload, base)
    target = os.fspath(out) if out is not None else m_out
    if target is None:
        raise ParamError("batch: give out= (or `out` in the manifest)")
    target = os.path.abspath(target)
    if jobs is not None and jobs < 1:
        raise ParamError("batch: jobs must be 1 or more")
    own = executor is None
    if own:
        import concurrent.futures
        import multiprocessing

        # "spawn": a forked child would inherit the parent's thread pools mid-state.
        executor = concurrent.futures.ProcessPoolExecutor(
            max_workers=min(jobs or m_jobs or os.cpu_count() or 2, len(runs)),
            mp_context=multiprocessing.get_context("spawn"),
        )
    try:
        futures = [executor.submit(_batch_worker, kind, payload, base, i, target) for i in range(len(runs))]
        records = []
        for (seq, method), f in zip(runs, futures):
            # A worker lost (killed, out of memory) fails its run, not the batch.
            try:
                records.append(f.result())
            except Exception as e:  # noqa: BLE001 - any executor's failure
                error = f"the executor lost the run: {type(e).__name__}: {e}"
                records.append(json.dumps({"sequence": seq, "method": method, "status": "failed",
                                           "error": error, "seconds": 0.0}))
    finally:
        if own:
            executor.shutdown()
    return json.loads(_mapgauge._batch_summary(kind, payload, base, target, records))
