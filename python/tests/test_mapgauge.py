"""The Python package against the CLI: same numbers, same errors, same files."""

import json
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

import mapgauge
from conftest import run_cli


def cli_eval(cli, scene, out: Path, *flags: str) -> str:
    run_cli(cli, "eval", "--map", str(scene / "map.ply"), "--survey", str(scene / "survey.csv"),
            "--out", str(out), "--no-report", *flags)
    return (out / "result.json").read_text()


def without_source(d: dict) -> dict:
    """A result dict with the fields that name the map's source taken out."""
    d = json.loads(json.dumps(d))
    del d["eval"]["map"], d["eval"]["map_bytes"]
    # What each pass read: the same passes and points, but an array has no bytes.
    for r in d["eval"]["reads"]:
        del r["bytes"]
    return d


# --- same numbers -----------------------------------------------------------


def test_file_gives_the_cli_result_json_byte_for_byte(cli, scene, tmp_path):
    want = cli_eval(cli, scene, tmp_path / "cli")
    ev = mapgauge.evaluate(str(scene / "map.ply"), str(scene / "survey.csv"))
    assert ev.to_json() == want
    assert ev.to_dict() == json.loads(want)


def test_a_levelled_map_keeps_the_pipeline_caveats_as_the_cli_does(cli, tmp_path):
    """Issue 32: the pipeline's warnings (here: the map was levelled) are in
    Python's result.json exactly as in the CLI's, once each."""
    d = tmp_path / "tilted"
    run_cli(cli, "synth", "--out", str(d), "--points", "1000000", "--seed", "3", "--tilt-deg", "6")
    want = json.loads(cli_eval(cli, d, tmp_path / "cli"))
    ev = mapgauge.evaluate(str(d / "map.ply"), str(d / "survey.csv"))
    assert any("levelled" in w for w in want["warnings"]), want["warnings"]
    assert ev.to_dict()["warnings"] == want["warnings"]
    assert ev.warnings == want["warnings"]


def test_array_gives_the_cli_numbers_bit_for_bit(cli, scene, tmp_path):
    want = json.loads(cli_eval(cli, scene, tmp_path / "cli"))
    pts = mapgauge.read_points(scene / "map.ply")
    assert pts.dtype == np.float64 and pts.shape == (want["eval"]["map_points"], 3)
    got = mapgauge.evaluate(pts, str(scene / "survey.csv")).to_dict()
    # Only the source's name and size differ: the array is `<memory>` of 0 bytes.
    assert got["eval"]["map"] == "<memory>" and got["eval"]["map_bytes"] == 0
    assert want["eval"]["map"] == str(scene / "map.ply")
    assert want["eval"]["map_bytes"] == (scene / "map.ply").stat().st_size
    assert [r["bytes"] for r in got["eval"]["reads"]] == [0] * len(want["eval"]["reads"])
    assert want["eval"]["reads"][0] == {"pass": "ground", "points": want["eval"]["map_points"],
                                        "bytes": want["eval"]["map_bytes"]}
    assert without_source(got) == without_source(want)  # float == float: bit for bit
    # The scene is not trivial: something was found, something was not.
    statuses = {t["status"] for t in got["targets"]}
    assert statuses == {"ok", "not_found"}


def test_flags_and_config_keys_agree(cli, scene, tmp_path):
    want = cli_eval(cli, scene, tmp_path / "cli", "--align", "rigid3d", "--dim", "3d",
                    "--radius", "4", "--seed", "7")
    ev = mapgauge.evaluate(str(scene / "map.ply"), str(scene / "survey.csv"),
                           metrics={"align": "rigid3d", "dim": "3d"}, crop={"radius": 4}, seed=7)
    assert ev.to_json() == want
    nested = mapgauge.evaluate(str(scene / "map.ply"), str(scene / "survey.csv"),
                               config={"metrics": {"align": "rigid3d", "dim": "3d"},
                                       "crop": {"radius": 4},
                                       "locate": {"seed": 7}, "tight": {"seed": 7}})
    assert nested.to_json() == want


def test_float32_is_its_float64_upcast(scene):
    pts = mapgauge.read_points(scene / "map.ply")
    survey = mapgauge.read_survey(scene / "survey.csv")
    f32 = pts.astype(np.float32)
    a = mapgauge.evaluate(f32, survey).to_dict()
    b = mapgauge.evaluate(f32.astype(np.float64), survey).to_dict()
    assert a == b
    # Rounding to float32 moves a 100 m map by micrometres, not millimetres.
    full = mapgauge.evaluate(pts, survey)
    assert abs(a["absolute"]["mean"] - full.absolute["mean"]) < 1e-3


def test_non_finite_rows_are_skipped_and_counted(scene):
    pts = mapgauge.read_points(scene / "map.ply")
    survey = mapgauge.read_survey(scene / "survey.csv")
    bad = np.vstack([pts, [[np.nan, 0, 0], [0, np.inf, 0]]])
    a = mapgauge.evaluate(bad, survey).to_dict()
    b = mapgauge.evaluate(pts, survey).to_dict()
    assert a["eval"]["skipped_nonfinite"] == 2
    a["eval"]["skipped_nonfinite"] = 0
    assert a == b


# --- surveys ----------------------------------------------------------------


def test_dict_and_array_surveys_equal_the_csv(scene):
    pts = mapgauge.read_points(scene / "map.ply")
    s = mapgauge.read_survey(scene / "survey.csv")
    want = mapgauge.evaluate(pts, s).to_dict()
    # The survey's reference points (antenna height removed) as a dict and as an array.
    d = {i: tuple(p) for i, p in zip(s.ids, s.positions)}
    for survey in (mapgauge.survey(d), mapgauge.survey(s.ids, s.positions)):
        got = mapgauge.evaluate(pts, survey).to_dict()
        assert got["eval"]["survey"] == "<memory>"
        got["eval"]["survey"] = want["eval"]["survey"]
        assert got == want
    # A plain dict works in evaluate() directly.
    assert mapgauge.evaluate(pts, d).absolute == want["absolute"]


def test_two_dimensional_survey(scene):
    s = mapgauge.read_survey(scene / "survey.csv")
    d2 = {i: (p[0], p[1]) for i, p in zip(s.ids, s.positions)}
    ev = mapgauge.evaluate(mapgauge.read_points(scene / "map.ply"), d2)
    d = ev.to_dict()
    assert d["dim"] == "2d"
    assert all(t["survey"]["z"] is None for t in d["targets"])
    assert not mapgauge.survey(d2).has_z and np.isnan(mapgauge.survey(d2).positions[:, 2]).all()


def test_survey_errors():
    with pytest.raises(mapgauge.MapgaugeError, match="survey: expected .M, 2. or .M, 3. positions"):
        mapgauge.survey(["a", "b"], np.zeros((2, 4)))
    with pytest.raises(mapgauge.MapgaugeError, match="duplicate target id `a`"):
        mapgauge.survey(["a", "a"], np.zeros((2, 3)))
    with pytest.raises(mapgauge.MapgaugeError, match="non-finite"):
        mapgauge.survey({"a": (0, np.nan, 0)})
    with pytest.raises(mapgauge.MapgaugeError, match="same coordinates"):
        mapgauge.survey({"a": (0, 0, 0), "b": (1, 1)})
    with pytest.raises(mapgauge.MapgaugeError, match="positions go with a sequence of ids"):
        mapgauge.evaluate(np.zeros((10, 3)), "survey.csv", np.zeros((2, 3)))


# --- errors -----------------------------------------------------------------


def cli_error(cli, *args: str) -> str:
    r = run_cli(cli, *args, check=False)
    assert r.returncode != 0
    lines = [l for l in r.stderr.splitlines() if l.startswith("error: ")]
    assert len(lines) == 1, r.stderr
    return lines[0][len("error: "):]


def test_errors_are_the_cli_messages(cli, scene, tmp_path):
    assert issubclass(mapgauge.MapgaugeError, ValueError)
    missing = str(tmp_path / "nope.pcd")
    want = cli_error(cli, "eval", "--map", missing, "--survey", str(scene / "survey.csv"))
    with pytest.raises(mapgauge.MapgaugeError) as e:
        mapgauge.evaluate(missing, str(scene / "survey.csv"))
    assert str(e.value) == want

    want = cli_error(cli, "eval", "--map", str(scene / "map.ply"), "--survey", str(scene / "survey.csv"),
                     "--radius=-1")
    with pytest.raises(mapgauge.MapgaugeError) as e:
        mapgauge.evaluate(str(scene / "map.ply"), str(scene / "survey.csv"), crop={"radius": -1})
    assert str(e.value) == want

    bad = tmp_path / "bad.csv"
    bad.write_text("id,x,y\n1,2,oops\n")
    want = cli_error(cli, "eval", "--map", str(scene / "map.ply"), "--survey", str(bad))
    with pytest.raises(mapgauge.MapgaugeError) as e:
        mapgauge.read_survey(bad)
    assert str(e.value) == want


def test_unknown_config_keys_are_errors(scene):
    with pytest.raises(mapgauge.MapgaugeError, match="unknown field `radiuss`"):
        mapgauge.evaluate(np.zeros((10, 3)), {"a": (0, 0)}, crop={"radiuss": 3})
    with pytest.raises(mapgauge.MapgaugeError, match="unknown configuration section `cropp`"):
        mapgauge.evaluate(np.zeros((10, 3)), {"a": (0, 0)}, cropp={"radius": 3})
    with pytest.raises(mapgauge.MapgaugeError, match="unknown field `nope`"):
        mapgauge.evaluate(np.zeros((10, 3)), {"a": (0, 0)}, config={"nope": {}})
    with pytest.raises(mapgauge.MapgaugeError, match="map: expected an .N, 3. array"):
        mapgauge.evaluate(np.zeros((10, 2)), {"a": (0, 0)})


def test_too_few_targets_found_is_an_error():
    # A patch of bare ground (a map of fewer than 100 points is refused as
    # not a map, before any target is looked for).
    g = np.arange(40) * 0.5
    ground = np.c_[np.repeat(g, 40), np.tile(g, 40), np.zeros(1600)]
    with pytest.raises(mapgauge.MapgaugeError, match="only 0 of 2 targets found") as e:
        mapgauge.evaluate(ground, {"a": (100, 100), "b": (200, 200)})
    # Typed (issue 32): a caller can tell it from bad input without parsing.
    assert isinstance(e.value, mapgauge.TooFewFoundError)
    assert (e.value.found, e.value.need) == (0, 2)
    # Three places: nothing there, and nothing target-shaped map-wide.
    with pytest.raises(mapgauge.FrameNotFoundError, match="none anywhere else") as e:
        mapgauge.evaluate(ground, {"a": (5, 5), "b": (15, 15), "c": (18, 3)})
    assert e.value.detections == 0
    assert issubclass(mapgauge.FrameNotFoundError, mapgauge.MapgaugeError)
    assert issubclass(mapgauge.NotMetresError, mapgauge.MapgaugeError)
    with pytest.raises(mapgauge.MapgaugeError, match="only 10 finite points.*is this the map"):
        mapgauge.evaluate(np.zeros((10, 3)), {"a": (100, 100), "b": (200, 200)})


def test_print_config_is_the_cli(cli):
    assert mapgauge.config_toml() == run_cli(cli, "eval", "--print-config").stdout
    assert mapgauge.config_toml(seed=3, crop={"radius": 2.5}) == run_cli(
        cli, "eval", "--print-config", "--seed", "3", "--radius", "2.5").stdout
    assert mapgauge.config()["locate"]["samples"] == 100


# --- results: dict, files, tables ---------------------------------------------


def test_write_round_trips_to_dict(cli, scene, tmp_path):
    ev = mapgauge.evaluate(str(scene / "map.ply"), str(scene / "survey.csv"))
    ev.write(tmp_path / "py")
    assert json.loads((tmp_path / "py" / "result.json").read_text()) == ev.to_dict()
    assert (tmp_path / "py" / "result.json").read_text() == ev.to_json()
    cli_eval(cli, scene, tmp_path / "cli")
    for f in ("targets.csv", "pairs.csv"):
        assert (tmp_path / "py" / f).read_text() == (tmp_path / "cli" / f).read_text()
    html = (tmp_path / "py" / "report.html").read_text()
    assert "<svg" in html and "map.ply" in html


def test_write_over_input_is_refused(scene, tmp_path):
    (tmp_path / "result.json").write_bytes((scene / "map.ply").read_bytes())
    ev = mapgauge.evaluate(str(tmp_path / "result.json"), str(scene / "survey.csv"))
    with pytest.raises(mapgauge.MapgaugeError):
        ev.write(tmp_path)
    assert (tmp_path / "result.json").read_bytes() == (scene / "map.ply").read_bytes()


def test_properties_and_targets(scene):
    ev = mapgauge.evaluate(str(scene / "map.ply"), str(scene / "survey.csv"))
    d = ev.to_dict()
    assert ev.absolute == d["absolute"] and ev.relative == d["relative"]
    assert ev.alignment == d["alignment"]
    assert ev.warnings == d["warnings"]
    assert [t.id for t in ev.targets] == ["1", "2", "3", "4", "5"]
    for t, r in zip(ev.targets, d["targets"]):
        assert t.status == r["status"] and t.abs_error == r["abs_error"]
        if t.status == "ok":
            assert t.map.shape == (3,) and t.map[0] == r["map"]["x"]
            assert t.aligned[1] == r["aligned"]["y"]
            assert t.detail["accepted"] == len(ev.samples(t.id))
            # The corner is the mean of the samples.
            assert np.allclose(ev.samples(t.id).mean(axis=0), t.map, atol=1e-9)
            assert len(ev.crop(t.id, "tight")) == t.detail["tight_points"]
        else:
            assert t.map is None and t.reason
    # The fixture promises a failure to exercise.
    assert any(t.status != "ok" for t in ev.targets)
    ev.to_dict()["absolute"]["mean"] = -1.0  # a copy: the evaluation is unchanged
    assert ev.to_dict() == d


def test_table_is_the_cli_table(cli, scene, tmp_path):
    runs = []
    for k, align in enumerate(["rigid2d", "similarity2d"]):
        out = tmp_path / f"run{k}"
        cli_eval(cli, scene, out, "--align", align)
        runs.append(out / "result.json")
    for fmt in ("markdown", "latex", "csv", "json", "html", "text"):
        want = run_cli(cli, "table", *map(str, runs), "--format", fmt).stdout
        if fmt != "html":  # the CLI prints the HTML page without a final newline... either way:
            assert mapgauge.table(runs, format=fmt) == want
        else:
            assert mapgauge.table(runs, format=fmt).strip() == want.strip()
    evs = [mapgauge.evaluate(str(scene / "map.ply"), str(scene / "survey.csv"), metrics={"align": a})
           for a in ["rigid2d", "similarity2d"]]
    assert mapgauge.table(evs, names=["run0", "run1"]) == mapgauge.table(runs)
    assert mapgauge.table([e.to_dict() for e in evs], names=["run0", "run1"]) == mapgauge.table(runs)
    assert "| map |" in mapgauge.table(evs[:1])  # named after the map file
    with pytest.raises(mapgauge.MapgaugeError, match="2 names for 1 results"):
        mapgauge.table(evs[:1], names=["a", "b"])


def test_table_warns_when_runs_used_different_surveys(scene, tmp_path):
    # As `mapgauge table` does on stderr: runs scored against other targets
    # do not compare, and the table says so instead of lining them up.
    lines = (scene / "survey.csv").read_text().splitlines()
    fewer = tmp_path / "fewer.csv"
    fewer.write_text("\n".join(lines[:-1]) + "\n")
    same = mapgauge.evaluate(str(scene / "map.ply"), str(scene / "survey.csv"))
    other = mapgauge.evaluate(str(scene / "map.ply"), str(fewer))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mapgauge.table([same, same], names=["a", "b"])
    with pytest.warns(UserWarning, match=r"runs `a` and `b` were scored against different surveys \(only in `a`: "):
        text = mapgauge.table([same, other], names=["a", "b"])
    assert "| a |" in text and "| b |" in text


# --- errors(), locate(), read_points(), synth() --------------------------------


def test_errors_scores_like_eval(scene):
    ev = mapgauge.evaluate(str(scene / "map.ply"), str(scene / "survey.csv"))
    est = {t.id: (tuple(t.map) if t.map is not None else None) for t in ev.targets}
    acc = mapgauge.errors(str(scene / "survey.csv"), est)
    d, e = acc.to_dict(), ev.to_dict()
    assert "eval" not in d
    # Positions carry no covariance, so errors() has no measurement interval;
    # everything else is the same computation.
    def strip(v):
        return {k: x for k, x in v.items() if k != "ci95_measurement"} if isinstance(v, dict) else v

    for k in ("absolute", "relative", "alignment", "asprs", "leave_one_out", "sigma_hat"):
        assert strip(d[k]) == strip(e[k]), k
    assert d["absolute"]["ci95_measurement"] is None
    assert e["absolute"]["ci95_measurement"] is not None
    assert [t.status for t in acc.targets] == [t.status for t in ev.targets]


def test_errors_matches_cli_errors(cli, scene, tmp_path):
    ev = mapgauge.evaluate(str(scene / "map.ply"), str(scene / "survey.csv"))
    csv = tmp_path / "est.csv"
    csv.write_text("id,x,y,z\n" + "".join(
        f"{t.id},{float(t.map[0])!r},{float(t.map[1])!r},{float(t.map[2])!r}\n" for t in ev.targets if t.map is not None))
    want = run_cli(cli, "errors", "--survey", str(scene / "survey.csv"), "--estimates", str(csv),
                   "--align", "rigid3d", "--dim", "3d", "--format", "json").stdout
    got = mapgauge.errors(scene / "survey.csv", csv, align="rigid3d", dim="3d")
    assert got.to_json() == want
    found = {t.id: tuple(t.map) for t in ev.targets if t.map is not None}
    assert mapgauge.errors(scene / "survey.csv", found, align="rigid3d", dim="3d").to_json() == want
    want = run_cli(cli, "errors", "--survey", str(scene / "survey.csv"), "--estimates", str(csv),
                   "--survey-sigma", "0.01,0.02", "--format", "json").stdout
    assert mapgauge.errors(scene / "survey.csv", csv, survey_sigma=(0.01, 0.02)).to_json() == want
    with pytest.raises(mapgauge.MapgaugeError, match="unknown|rigid9d"):
        mapgauge.errors(scene / "survey.csv", found, align="rigid9d")


def l_target(corner=(10.0, 20.0), noise=0.0, dtype=np.float64):
    rng = np.random.default_rng(0)
    pts = []
    for i in range(1, 30):
        for k in range(30):
            s, z = i * 0.02, 1.0 + k * 0.02
            pts.append((corner[0] + s, corner[1], z))
            pts.append((corner[0], corner[1] + s, z))
    a = np.array(pts) + rng.normal(0, noise, (len(pts), 3)) if noise else np.array(pts)
    return a.astype(dtype)


def test_locate_finds_the_corner():
    for dtype in (np.float64, np.float32):
        r = mapgauge.locate(l_target(dtype=dtype))
        assert abs(r.corner[0] - 10.0) < 1e-3 and abs(r.corner[1] - 20.0) < 1e-3
        assert r.accepted == 100 and r.attempts >= r.accepted and r.samples.shape == (100, 3)
    noisy = mapgauge.locate(l_target(noise=0.01), samples=50, seed=3)
    assert noisy.accepted == 50 and noisy.spread > 0
    assert np.allclose(noisy.samples.mean(axis=0), noisy.corner)


def test_locate_errors():
    with pytest.raises(mapgauge.MapgaugeError, match="localisation failed: too few points"):
        mapgauge.locate(np.zeros((3, 3)))
    with pytest.raises(mapgauge.MapgaugeError, match="unknown field `sample`"):
        mapgauge.locate(l_target(), sample=10)


def test_read_points_bounds(scene):
    pts = mapgauge.read_points(scene / "map.ply")
    lo, hi = (0.0, -5.0), (30.0, 5.0)
    inside = mapgauge.read_points(str(scene / "map.ply"), bounds=(lo, hi))
    m = (pts[:, 0] >= 0) & (pts[:, 0] <= 30) & (pts[:, 1] >= -5) & (pts[:, 1] <= 5)
    assert np.array_equal(inside, pts[m]) and 0 < len(inside) < len(pts)
    box = mapgauge.read_points(scene / "map.ply", bounds=((0, -5, 0.5), (30, 5, 1.0)))
    assert np.array_equal(box, inside[(inside[:, 2] >= 0.5) & (inside[:, 2] <= 1.0)])
    with pytest.raises(mapgauge.MapgaugeError, match="bounds"):
        mapgauge.read_points(scene / "map.ply", bounds=((1, 1), (0, 0)))
    with pytest.raises(mapgauge.MapgaugeError, match="nope.ply"):
        mapgauge.read_points(scene / "nope.ply")


def test_synth_is_the_cli_scene(scene):
    sc = mapgauge.synth(points=1_000_000, seed=2)
    assert np.array_equal(sc.points, mapgauge.read_points(scene / "map.ply"))
    truth = json.loads((scene / "truth.json").read_text())
    assert sc.truth == {k: v for k, v in truth.items() if k != "expected"}  # the CLI adds its E_abs
    # The CSV rounds the survey to 0.1 mm; the in-memory survey is exact.
    assert np.allclose(sc.survey.positions, mapgauge.read_survey(scene / "survey.csv").positions, atol=1e-4)
    with pytest.raises(mapgauge.MapgaugeError, match="unknown field `pointz`"):
        mapgauge.synth(pointz=3)


# --- progress and the GIL -----------------------------------------------------


def test_progress_callback(scene):
    calls = []
    mapgauge.evaluate(str(scene / "map.ply"), str(scene / "survey.csv"), progress=lambda b, t: calls.append((b, t)))
    size = (scene / "map.ply").stat().st_size
    assert calls and all(t == size for _, t in calls)
    # Every pass over the file ends with its whole size (the second pass reads it again).
    assert all(b <= t for b, t in calls) and calls[-1] == (size, size)

    def boom(b, t):
        raise KeyError("stop")

    with pytest.raises(KeyError, match="stop"):
        mapgauge.evaluate(str(scene / "map.ply"), str(scene / "survey.csv"), progress=boom)


def test_gil_is_released(scene):
    pts = mapgauge.read_points(scene / "map.ply")
    survey = mapgauge.read_survey(scene / "survey.csv")
    ticks = 0
    done = threading.Event()

    def work():
        for _ in range(3):
            mapgauge.evaluate(pts, survey)
        done.set()

    th = threading.Thread(target=work)
    t0 = time.perf_counter()
    th.start()
    # Rust holds the GIL only to copy the array; the main thread keeps running.
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    th.join()
    elapsed = time.perf_counter() - t0
    # Held, the main thread would run once per evaluate (3-5 ticks in all).
    assert ticks > 50, (ticks, elapsed)


def test_errors_are_typed(tmp_path):
    # Issue 32: a caller tells a bad file, a bad value and a refused read
    # apart without parsing messages; all stay MapgaugeErrors (ValueErrors).
    with pytest.raises(mapgauge.ParamError, match="unknown configuration section"):
        mapgauge.config(cropp={"radius": 3})
    with pytest.raises(mapgauge.ParamError, match="radius"):
        mapgauge.config(crop={"radius": -1})
    bad = tmp_path / "survey.csv"
    bad.write_text("id,x,y\na,1,2\nb,3,oops\n")
    with pytest.raises(mapgauge.ParseError) as e:
        mapgauge.read_survey(bad)
    assert (e.value.path, e.value.line) == (str(bad), 3)
    missing = tmp_path / "nope.csv"
    with pytest.raises(mapgauge.FileError) as e:
        mapgauge.read_survey(missing)
    assert e.value.path == str(missing) and e.value.errno == 2
    for cls in (mapgauge.ParseError, mapgauge.ParamError, mapgauge.FileError):
        assert issubclass(cls, mapgauge.MapgaugeError) and issubclass(cls, ValueError)


# --- gates and JUnit (issue 34) ----------------------------------------------


def test_gates_are_the_cli_gates_and_junit_reads_in_a_real_consumer(cli, scene, tmp_path):
    """The same gates through Python and the CLI give the same result.json; the
    CLI's exit code is its outcome's; its JUnit file is read by junitparser (the
    library GitLab-style tooling uses) with one case per gate and per target."""
    import junitparser  # .ci/run installs it; a missing consumer fails, not skips

    gates = ["E_abs<=1m", "max_abs<=1mm", "found>=0.5"]
    out = tmp_path / "cli"
    flags = [f"--gate={g}" for g in gates]
    r = run_cli(cli, "eval", "--map", str(scene / "map.ply"), "--survey", str(scene / "survey.csv"),
                "--out", str(out), "--no-report", "--junit", str(tmp_path / "junit.xml"), *flags, check=False)
    want = json.loads((out / "result.json").read_text())
    assert [g["verdict"] for g in want["gates"]] == ["pass", "fail", "pass"]
    assert r.returncode == want["gate_outcome"]["exit_code"] == 1, r.stderr
    ev = mapgauge.evaluate(str(scene / "map.ply"), str(scene / "survey.csv"), gates={"checks": gates})
    assert ev.to_dict() == want
    assert ev.gates == want["gates"] and ev.gate_outcome["outcome"] == "fail"
    xml = junitparser.JUnitXml.fromfile(str(tmp_path / "junit.xml"))
    suites = {s.name: s for s in xml}
    g = suites["mapgauge eval: gates"]
    t = suites["mapgauge eval: targets"]
    assert (g.tests, g.failures) == (3, 1)
    assert t.tests == len(want["targets"])
    not_ok = [x for x in want["targets"] if x["status"] != "ok"]
    assert t.failures == len(not_ok)
    failed = [c.name for c in g if any(isinstance(x, junitparser.Failure) for x in c.result)]
    assert failed == ["max_abs<=0.001"]
    # A bad gate from Python is a ParamError, as a bad flag is a usage error.
    with pytest.raises(mapgauge.ParamError):
        mapgauge.evaluate(str(scene / "map.ply"), str(scene / "survey.csv"), gates={"checks": ["E_abs=1"]})


# --- benchmark scores (issue 35) ----------------------------------------------


def _hilti_points(rule: str, e: np.ndarray) -> np.ndarray:
    """The challenges' points per checkpoint, from their published bands,
    written apart from the Rust code (np.select over the bands' edges)."""
    cm = e * 100.0
    if rule == "hilti2022":
        return np.select([cm < 1, cm < 3, cm < 6, cm < 10], [10, 6, 3, 1], 0).astype(float)
    if rule == "hilti2023":
        return np.select([cm < 0.5, cm < 1, cm < 3, cm < 6, cm < 10, cm < 40],
                         [20, 10, 6, 5, 3, 1], 0).astype(float)
    return 100.0 * np.exp(-0.4605 * cm)


def test_scores_recomputed_independently_and_as_the_cli(cli, scene, tmp_path):
    """Each rule's per-target points and total from numpy over result.json's
    own errors (a target not located earns 0, the total is 100 × earned /
    most possible), equal to the CLI's and Python's; in 3D too; `table
    --score` scores a result written without scores by the same rule."""
    rules = ["hilti2022", "hilti2023", "hilti2026"]
    for dim in ("2d", "3d"):
        out = tmp_path / dim
        want = json.loads(cli_eval(cli, scene, out, "--score", ",".join(rules), "--dim", dim))
        ev = mapgauge.evaluate(str(scene / "map.ply"), str(scene / "survey.csv"),
                               metrics={"scores": rules, "dim": dim})
        assert ev.to_dict() == want
        assert list(ev.scores) == rules
        ts = want["targets"]
        located = np.array([t["status"] in ("ok", "excluded") and t["abs_error"] is not None for t in ts])
        errs = np.array([t["abs_error"] if ok else np.inf for t, ok in zip(ts, located)], dtype=float)
        assert located.sum() >= 3
        for rule, most in zip(rules, (10.0, 20.0, 100.0)):
            got = want["scores"][rule]
            pts = np.where(located, _hilti_points(rule, errs), 0.0)
            assert [p["points"] for p in got["per_target"]] == pytest.approx(pts, abs=1e-9)
            assert got["total"] == pytest.approx(100.0 * pts.sum() / (most * len(ts)), abs=1e-9)
            assert got["range95"][0] <= got["total"] <= got["range95"][1]
            assert (got["targets"], got["located"]) == (len(ts), int(located.sum()))
    plain = tmp_path / "plain"
    cli_eval(cli, scene, plain, "--dim", "3d")
    tab = json.loads(run_cli(cli, "table", str(plain / "result.json"), str(tmp_path / "3d" / "result.json"),
                             "--format", "json", "--score", "hilti2026").stdout)
    totals = [row["Hilti 2026"] for row in tab["scores"]]
    want3 = json.loads((tmp_path / "3d" / "result.json").read_text())["scores"]["hilti2026"]["total"]
    assert totals == pytest.approx([want3, want3], abs=1e-9)


def test_iso19157_recomputed_independently():
    """ISO 19157's numbers from numpy alone: the bias and its Student-t
    interval (t from a printed table), CE90/CE95/LE90/LE95 of a normal with
    the residuals' mean and covariance by 4 M Monte Carlo draws (to 0.1 mm),
    the count beyond the threshold; the positions given straight (align
    none), so the residuals are known without any fit."""
    rng = np.random.default_rng(11)
    n = 12
    truth = rng.uniform(0, 100, size=(n, 3))
    res = rng.normal([0.012, -0.006, 0.02], [0.010, 0.018, 0.015], size=(n, 3))
    survey = {f"p{i}": tuple(t) for i, t in enumerate(truth)}
    est = {f"p{i}": tuple(t + r) for i, (t, r) in enumerate(zip(truth, res))}
    acc = mapgauge.errors(survey, est, align="none", dim="3d", threshold=0.02, scores=["hilti2022"])
    iso = acc.iso19157
    assert iso["n"] == n
    t975_11 = 2.200985  # Student's t, 97.5 %, 11 degrees of freedom
    for k in range(3):
        m, s = res[:, k].mean(), res[:, k].std(ddof=1)
        b = iso["bias"][k]
        assert b["mean"] == pytest.approx(m, abs=1e-12)
        # mapgauge's t quantile is tabled to 3 decimals (2.201): 1 µm here.
        assert b["ci95"] == pytest.approx([m - t975_11 * s / np.sqrt(n), m + t975_11 * s / np.sqrt(n)], abs=1e-6)
    draws = np.random.default_rng(5).multivariate_normal(res[:, :2].mean(0), np.cov(res[:, :2].T), size=4_000_000)
    radial = np.hypot(draws[:, 0], draws[:, 1])
    assert iso["ce90"] == pytest.approx(np.quantile(radial, 0.90), abs=1e-4)
    assert iso["ce95"] == pytest.approx(np.quantile(radial, 0.95), abs=1e-4)
    vz = np.abs(np.random.default_rng(6).normal(res[:, 2].mean(), res[:, 2].std(ddof=1), size=4_000_000))
    assert iso["le90"] == pytest.approx(np.quantile(vz, 0.90), abs=1e-4)
    assert iso["le95"] == pytest.approx(np.quantile(vz, 0.95), abs=1e-4)
    h = np.hypot(res[:, 0], res[:, 1])
    assert iso["above_h"] == int((h > 0.02).sum())
    assert iso["rate_above_h"] == pytest.approx((h > 0.02).mean())
    assert iso["above_v"] == int((np.abs(res[:, 2]) > 0.02).sum())
    # The errors' 3D distances scored by the 2022 bands (errors() took scores too).
    pts = np.select([np.linalg.norm(res, axis=1) < x for x in (0.01, 0.03, 0.06, 0.10)], [10, 6, 3, 1], 0)
    assert acc.to_dict()["scores"]["hilti2022"]["total"] == pytest.approx(100 * pts.sum() / (10 * n))


def test_checkpoints_are_the_cli_files(cli, scene, tmp_path):
    """write_checkpoints writes the CLI's CSV byte for byte and a GeoPackage
    whose rows (read with the standard library's sqlite3) are result.json's."""
    import sqlite3

    cli_eval(cli, scene, tmp_path / "cli", "--checkpoints", str(tmp_path / "cli.csv"),
             "--checkpoints-crs", "EPSG:32652")
    ev = mapgauge.evaluate(str(scene / "map.ply"), str(scene / "survey.csv"))
    assert ev.write_checkpoints(tmp_path / "py.csv", crs="EPSG:32652") == "EPSG:32652"
    assert (tmp_path / "py.csv").read_bytes() == (tmp_path / "cli.csv").read_bytes()
    ev.write_checkpoints(tmp_path / "py.gpkg", crs="EPSG:32652")
    db = sqlite3.connect(tmp_path / "py.gpkg")
    assert db.execute("PRAGMA application_id").fetchone()[0] == 0x47504B47
    assert db.execute("SELECT srs_id FROM gpkg_geometry_columns").fetchone()[0] == 32652
    rows = db.execute("SELECT id, status, dx_m FROM checkpoints ORDER BY fid").fetchall()
    d = ev.to_dict()
    assert [r[0] for r in rows] == [t["id"] for t in d["targets"]]
    for (_, status, dx), t in zip(rows, d["targets"]):
        assert status == t["status"]
        if t["aligned"] is not None:
            assert dx == t["aligned"]["x"] - t["survey"]["x"]
    with pytest.raises(mapgauge.ParamError, match="RFC 7946"):
        ev.write_checkpoints(tmp_path / "py.geojson")
    with pytest.raises(mapgauge.MapgaugeError, match="refusing to overwrite"):
        ev.write_checkpoints(scene / "survey.csv")


# --- batch on any executor (issue 34) -----------------------------------------


@pytest.fixture(scope="module")
def batch_runs(cli, tmp_path_factory):
    """2 methods × 2 sequences: method b's map drifts 4 times as much as a's;
    one survey per sequence (the seed's), shared by both methods."""
    root = tmp_path_factory.mktemp("batch")
    runs = []
    for s in (1, 2):
        for m, k in (("a", 0.5), ("b", 2.0)):
            cfg = root / f"drift_{m}.toml"
            cfg.write_text(f"[distortion]\ndrift_m = [{0.04 * k}, {-0.03 * k}, {0.02 * k}]\n")
            d = root / f"s{s}" / m
            run_cli(cli, "synth", "--points", "700000", "--seed", str(s), "--config", str(cfg), "--out", str(d))
            runs.append({"method": m, "sequence": f"s{s}", "map": d / "map.ply", "survey": root / f"s{s}" / "a" / "survey.csv"})
    return runs


def _statuses(summary):
    return [r["status"] for r in summary["runs"]]


def test_batch_on_a_process_pool_is_the_cli_batch(cli, batch_runs, tmp_path):
    import concurrent.futures
    import multiprocessing

    ctx = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(2, mp_context=ctx) as ex:
        s = mapgauge.batch(batch_runs, out=tmp_path / "py", executor=ex, baseline="a")
    assert _statuses(s) == ["evaluated"] * 4 and s["exit_code"] == 0
    assert [l["method"] for l in s["leaderboard"]] == ["a", "b"]
    assert len(s["comparisons"]) == 2
    # The CLI's batch of the same runs: the same files, byte for byte.
    manifest = 'baseline = "a"\n\n' + "".join(
        f'[[run]]\nmethod = "{r["method"]}"\nsequence = "{r["sequence"]}"\nmap = "{r["map"]}"\nsurvey = "{r["survey"]}"\n\n'
        for r in batch_runs
    )
    (tmp_path / "runs.toml").write_text(manifest)
    run_cli(cli, "batch", str(tmp_path / "runs.toml"), "--out", str(tmp_path / "cli"))
    for r in batch_runs:
        for f in ("result.json", "targets.csv"):
            rel = Path(r["sequence"]) / r["method"] / f
            assert (tmp_path / "py" / rel).read_bytes() == (tmp_path / "cli" / rel).read_bytes(), rel
    assert (tmp_path / "py" / "leaderboard.csv").read_bytes() == (tmp_path / "cli" / "leaderboard.csv").read_bytes()
    # Again with the default executor: nothing changed, nothing evaluated.
    again = mapgauge.batch(batch_runs, out=tmp_path / "py", baseline="a")
    assert _statuses(again) == ["reused"] * 4
    assert again["leaderboard"] == s["leaderboard"]
    with pytest.raises(mapgauge.ParamError):
        mapgauge.batch([dict(batch_runs[0], sequence="../up")], out=tmp_path / "bad")


def test_batch_on_a_dask_cluster(batch_runs, tmp_path):
    """A Dask cluster's executor runs the batch: the recipe for hundreds of
    runs over many machines (here two local worker processes)."""
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with Client(cluster) as client:
            s = mapgauge.batch(batch_runs, out=tmp_path / "dask", executor=client.get_executor(), baseline="a")
    assert _statuses(s) == ["evaluated"] * 4 and s["exit_code"] == 0
    assert [l["method"] for l in s["leaderboard"]] == ["a", "b"]
    assert (tmp_path / "dask" / "index.html").is_file()


def test_a_mixed_survey_names_each_target_model():
    # Issue 33: spheres beside Ls, from the scene in memory to the results.
    sc = mapgauge.synth(points=4_000_000, seed=1, models=["l", "sphere"],
                        lidar={"range_noise_m": 0.01})
    assert [t.get("model", "l") for t in sc.truth["targets"]] == ["l", "sphere", "l", "sphere", "l"]
    ev = mapgauge.evaluate(sc.points, sc.survey)
    assert [t.model for t in ev.targets] == ["l", "sphere", "l", "sphere", "l"]
    assert all(t.status == "ok" for t in ev.targets), [t.reason for t in ev.targets]
    s = ev.targets[1].detail["sphere"]
    assert s["inliers"] >= 30 and abs(s["free_radius"] - 0.0725) < 0.006
    truth = np.asarray(sc.truth["targets"][1]["map"])
    assert np.linalg.norm(ev.targets[1].map - truth) < 0.01


def test_boards_are_located_from_a_map_with_intensity(cli, tmp_path):
    # Issue 33: a checkerboard is told by its print, so it is located from a
    # map file with intensity; in memory (coordinates only) it says why not.
    d = tmp_path / "boards"
    run_cli(cli, "synth", "--out", str(d), "--points", "2000000", "--seed", "3",
            "--models", "l,board", "--format", "pcd-xyzi")
    truth = json.loads((d / "truth.json").read_text())
    ev = mapgauge.evaluate(d / "map.pcd", d / "survey.csv")
    assert [t.model for t in ev.targets] == ["l", "board", "l", "board", "l"]
    for t, tt in zip(ev.targets, truth["targets"]):
        assert t.status == "ok", t.reason
        if t.model == "board":
            b = t.detail["board"]
            assert b["contrast"] > 10 and b["points"] >= 40
            assert np.linalg.norm((t.map - np.asarray(tt["map"]))[:2]) < 0.003
    sc = mapgauge.synth(points=2_000_000, seed=3, models=["l", "board"])
    ev = mapgauge.evaluate(sc.points, sc.survey)
    boards = [t for t in ev.targets if t.model == "board"]
    assert boards and all(t.status == "not_found" and "no intensity" in t.reason for t in boards)
