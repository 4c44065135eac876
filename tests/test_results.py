"""SimulationResult save/load round trip and ResultRecorder (partial results, growth)."""

from __future__ import annotations

import numpy as np
import pytest

from ibvs_youla.exceptions import InvalidArrayError, InvalidParameterError
from ibvs_youla.simulation.recorder import ResultRecorder
from ibvs_youla.simulation.results import SimulationResult

SIGNALS = ("q", "q_true", "dq", "q_ref", "q_ff", "q_fb", "tau")


def _rz(angle):
    c, s = np.cos(angle), np.sin(angle)
    T = np.eye(4)
    T[:2, :2] = [[c, -s], [s, c]]
    return T


def _fill(recorder, n, rng):
    for k in range(n):
        T = _rz(0.01 * k)
        T[:3, 3] = rng.normal(size=3)
        features = rng.normal(size=9)
        if k == 2:
            features[4] = np.nan  # a point behind the camera: NaN is allowed in recorded signals
        visible = rng.random(3) > 0.5
        recorder.record(1e-3 * k, T, features, visible, [rng.normal(size=6) for _ in SIGNALS])
        recorder.record_frame(1e-3 * k, features, visible, float(rng.random()) * 1e-4)


def _recorder(capacity=4, metadata=None):
    target_pose = _rz(0.3)
    target_pose[:3, 3] = [1.0, 2.0, 3.0]
    return ResultRecorder(
        np.linspace(-1e-3, 1e-3, 9),
        target_pose,
        capacity,
        n_points=3,
        signals=dict.fromkeys(SIGNALS, (6,)),
        metadata=metadata,
    )


def test_recorder_grows_past_capacity_and_computes_feature_error():
    rng = np.random.default_rng(0)
    rec = _recorder(capacity=4)
    _fill(rec, 37, rng)  # several doublings
    res = rec.result()
    assert len(res) == 37 and res.update_time.shape == (37,)
    assert res.q.shape == (37, 6) and res.camera_pose.shape == (37, 4, 4) and res.visible.dtype == bool
    np.testing.assert_array_equal(res.t, 1e-3 * np.arange(37))
    np.testing.assert_array_equal(res.feature_error, res.feature_target - res.features)
    assert np.isnan(res.feature_error[2, 4])
    assert res.metadata["status"] == "complete"


def test_partial_result_keeps_finished_samples_and_recording_can_continue():
    rng = np.random.default_rng(1)
    rec = _recorder(capacity=100, metadata={"scenario": "paper-2", "controller": "ff+fb"})
    _fill(rec, 10, rng)
    partial = rec.result(status="diverged", extra_metadata={"error": "dq at t = 0.01 s"})
    assert len(partial) == 10 and partial.metadata["status"] == "diverged"
    assert partial.metadata["scenario"] == "paper-2" and partial.metadata["error"].startswith("dq")
    q_before = partial.q.copy()
    _fill(rec, 5, rng)  # the partial result is a copy: later samples do not leak into it
    np.testing.assert_array_equal(partial.q, q_before)
    assert len(rec.result()) == 15


def test_save_load_round_trip_is_exact_with_and_without_suffix(tmp_path):
    rng = np.random.default_rng(2)
    meta = {
        "scenario": "physical-1",
        "controller": "fb",
        "adaptive": True,
        "rates_hz": (1000.0, 100.0),  # stored as a list (JSON)
        "gain": np.float64(0.1) / 3,  # numpy scalars become exact Python floats
        "settings": {"zeta": 10.0, "q": np.array([0.1, 1 / 3])},
    }
    rec = _recorder(metadata=meta)
    _fill(rec, 11, rng)
    res = rec.result()
    for name in ("run", "run.npz"):
        written = res.save(tmp_path / name)
        assert written == tmp_path / "run.npz"
        back = SimulationResult.load(tmp_path / name)
        for field in (
            "t",
            "q",
            "q_true",
            "dq",
            "q_ref",
            "q_ff",
            "q_fb",
            "tau",
            "features",
            "feature_target",
            "feature_error",
            "camera_pose",
            "camera_pose_target",
            "visible",
            "frame_t",
            "frame_features",
            "frame_visible",
            "update_time",
        ):
            np.testing.assert_array_equal(getattr(back, field), getattr(res, field), err_msg=field)
            assert getattr(back, field).dtype == getattr(res, field).dtype
        assert back.metadata == res.metadata
        assert back.signals.keys() == res.signals.keys()
    assert res.metadata["rates_hz"] == [1000.0, 100.0]
    assert res.metadata["gain"] == 0.1 / 3
    assert res.metadata["settings"]["q"] == [0.1, 1 / 3]


def test_convenience_properties():
    rng = np.random.default_rng(3)
    rec = _recorder()
    _fill(rec, 3, rng)
    res = rec.result()
    np.testing.assert_array_equal(res.final_feature_error, res.feature_error[-1])
    assert res.duration == pytest.approx(2e-3, abs=1e-15)
    last = res.camera_pose[-1]
    mm, deg = res.final_pose_error()
    assert mm == pytest.approx(1000 * np.linalg.norm(last[:3, 3] - [1.0, 2.0, 3.0]), rel=1e-12)
    assert deg == pytest.approx(np.degrees(0.3 - 0.02), abs=1e-9)  # Rz(0.02) vs Rz(0.3)


def test_bad_input_raises():
    with pytest.raises(InvalidParameterError, match="capacity"):
        _recorder(capacity=0)
    with pytest.raises(InvalidParameterError, match="metadata"):
        _recorder(metadata={"bad": object()})
    with pytest.raises(InvalidArrayError, match="camera_pose_target"):
        ResultRecorder(np.zeros(9), np.ones((4, 4)), 3)
    res = _recorder().result()
    assert len(res) == 0
    with pytest.raises(InvalidArrayError, match="no samples"):
        res.final_feature_error  # noqa: B018
    with pytest.raises(InvalidParameterError, match="path"):
        SimulationResult.load("/nonexistent/run")
    with pytest.raises(InvalidArrayError, match="features"):
        SimulationResult(
            t=np.zeros(2),
            camera_pose=np.tile(np.eye(4), (2, 1, 1)),
            camera_pose_target=np.eye(4),
            features=np.zeros((2, 8)),
            feature_target=np.zeros(9),
            visible=np.ones((2, 3), bool),
        )
    with pytest.raises(InvalidArrayError, match="signals\\['q'\\]"):
        SimulationResult(
            t=np.zeros(2),
            camera_pose=np.tile(np.eye(4), (2, 1, 1)),
            camera_pose_target=np.eye(4),
            features=np.zeros((2, 9)),
            feature_target=np.zeros(9),
            visible=np.ones((2, 3), bool),
            signals={"q": np.zeros((3, 6))},
        )
    with pytest.raises(InvalidParameterError, match="status"):
        _recorder().result(status="finished")
    rec = ResultRecorder(np.zeros(9), np.eye(4), 2, signals={"q": (6,)})
    assert rec.result().q.shape == (0, 6)  # a run stopped before its first sample still has its signals
    rec.record(0.0, np.eye(4), np.zeros(9), np.ones(3, bool), [np.zeros(6)])
    with pytest.raises(InvalidParameterError, match="one per name of \\('q',\\)"):
        rec.record(1e-3, np.eye(4), np.zeros(9), np.ones(3, bool), [np.zeros(6), np.zeros(6)])
    with pytest.raises(InvalidArrayError, match="signal 'q': received a value of shape \\(\\)"):
        rec.record(1e-3, np.eye(4), np.zeros(9), np.ones(3, bool), [0.0])  # would broadcast silently
    with pytest.raises(InvalidArrayError, match="shape \\(5,\\)"):
        rec.record(1e-3, np.eye(4), np.zeros(9), np.ones(3, bool), [np.zeros(5)])
    with pytest.raises(AttributeError, match="no attribute or signal 'q_ff'; signals: q"):
        rec.result().q_ff  # noqa: B018
    with pytest.raises(InvalidParameterError, match="signals"):
        ResultRecorder(np.zeros(9), np.eye(4), 2, signals={"q": 6})


def test_a_file_saved_in_format_1_loads_with_every_signal():
    """tests/regression/result_v1.npz was saved before the servo-loop rebuild (fixed three-marker schema)."""
    import json
    from pathlib import Path

    path = Path(__file__).parent / "regression" / "result_v1.npz"
    with np.load(path) as raw:
        header = json.loads(str(raw["__metadata__"]))
        stored = {name: raw[name] for name in raw.files if name != "__metadata__"}
    assert header["format_version"] == 1
    res = SimulationResult.load(path)
    for name in ("q", "q_true", "dq", "q_ref", "q_ff", "q_fb", "tau"):
        np.testing.assert_array_equal(getattr(res, name), stored[name], err_msg=name)
    for name in (
        "t",
        "features",
        "feature_target",
        "camera_pose",
        "camera_pose_target",
        "visible",
        "update_time",
    ):
        np.testing.assert_array_equal(getattr(res, name), stored[name], err_msg=name)
    np.testing.assert_array_equal(res.feature_error, stored["feature_error"])
    assert len(res) == 11 and res.frame_t.shape == (0,) and res.update_time.shape == (6,)
    assert res.status == "complete" and res.metadata["plant"] == "dynamic"
    assert res.metadata["controller"] == "ff+fb" and res.n_points == 3
    mm, deg = res.final_pose_error()
    assert np.isfinite(mm) and np.isfinite(deg)


def test_software_versions_are_json_strings():
    from ibvs_youla.simulation.results import software_versions

    versions = software_versions()
    assert set(versions) == {"python", "ibvs-youla", "numpy", "scipy", "pin", "control"}
    assert versions["numpy"] == np.__version__


@pytest.mark.parametrize(
    ("where", "problem"),
    [
        ("missing/run.npz", "its folder {tmp}/missing does not exist"),
        ("a-file/run.npz", "its folder {tmp}/a-file is not a folder"),
        ("a-folder", "this is a folder"),
    ],
)
def test_a_file_that_cannot_be_written_where_asked_is_named_with_its_folder(tmp_path, where, problem):
    """save() into a missing folder raised a bare FileNotFoundError naming the hidden temporary file."""
    from ibvs_youla.files import write_text

    (tmp_path / "a-file").write_text("x")
    (tmp_path / "a-folder.npz").mkdir()
    (tmp_path / "a-folder").mkdir()
    result = SimulationResult(
        t=[0.0], camera_pose=[np.eye(4)], camera_pose_target=np.eye(4), features=np.zeros((1, 2)),
        feature_target=np.zeros(2), visible=np.ones((1, 1), bool),
    )  # fmt: skip
    for write in (lambda p: result.save(p), lambda p: write_text(p, "text")):
        target = tmp_path / where
        with pytest.raises(InvalidParameterError) as info:
            write(target)
        message = str(info.value)
        assert message.startswith("path: received ") and problem.format(tmp=tmp_path) in message
        assert ".tmp" not in message and not list(tmp_path.rglob(".*.tmp"))


def test_a_run_without_samples_says_how_it_ended():
    """A first frame that loses the markers: asking for the final error named no cause."""
    import ibvs_youla as iy
    from ibvs_youla.model.camera import PinholeCamera

    markers = [
        [-0.1, -0.1, 1.0],
        [0.1, -0.1, 1.0],
        [0.1, 0.1, 1.2],
        [-0.1, 0.1, 1.1],
    ]  # [m] before the target
    turned = np.diag([-1.0, 1.0, -1.0, 1.0])  # the start camera faces away: every marker behind it
    scenario = iy.Scenario.free_camera(turned, np.eye(4), markers)
    result = iy.simulate(
        scenario, "ibvs-current", duration=0.1, plant="free-camera", camera=PinholeCamera.normalized()
    )
    assert result.status == "markers_lost" and len(result) == 0
    with pytest.raises(
        InvalidArrayError, match=r"the run ended with status 'markers_lost' before its first"
    ) as e:
        result.final_pose_error()
    assert "the true camera lost a marker" in str(e.value)
