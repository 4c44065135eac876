"""Every reader turns a damaged or foreign file into DamagedFileError naming the file and what is wrong.

The table: each kind of damage (empty, truncated, random bytes, a flipped byte, a directory,
a header that is not JSON or lacks a key, another format version, missing parts, and whole files
holding what no run records: NaN or non-rigid poses, time running backwards, strings for
booleans, an unknown status or outcome) x each
reader of that kind of file: ``SimulationResult.load`` and ``ibvs-youla view`` for results,
``campaign.storage.read_definition`` and ``ibvs-youla campaign`` for ``campaign.json``,
``campaign.storage.read_rows`` and ``ibvs-youla campaign-report`` for Parquet parts. Each case
asserts the exception type (or the CLI's one line and exit 1), that the message names the
file and a fragment saying what is wrong. Damage is seeded (``numpy.random.default_rng``).
"""

from __future__ import annotations

import io
import json
import shutil
import struct
import zipfile
from pathlib import Path

import numpy as np
import pytest

from ibvs_youla import cli
from ibvs_youla.campaign import storage
from ibvs_youla.campaign.metrics import COLUMNS
from ibvs_youla.campaign.runner import CampaignDefinition
from ibvs_youla.exceptions import DamagedFileError, InvalidParameterError
from ibvs_youla.simulation.results import SimulationResult

V1 = Path(__file__).parent / "regression" / "result_v1.npz"


# ----------------------------------------------------------------------------- damage
def _truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def _random_bytes(path: Path) -> None:
    size = path.stat().st_size if path.is_file() else 4096
    path.write_bytes(np.random.default_rng(13).integers(0, 256, size, dtype=np.uint8).tobytes())


def _empty(path: Path) -> None:
    path.write_bytes(b"")


def _directory(path: Path) -> None:
    path.unlink()
    path.mkdir()


def _flip_npz(path: Path) -> None:
    """Flip one bit in the middle of the compressed data of the archive's largest member."""
    with zipfile.ZipFile(path) as archive:
        info = max(archive.infolist(), key=lambda i: i.compress_size)
    data = bytearray(path.read_bytes())
    name_len, extra_len = struct.unpack("<HH", data[info.header_offset + 26 : info.header_offset + 30])
    start = info.header_offset + 30 + name_len + extra_len
    data[start + info.compress_size // 2] ^= 0x10
    path.write_bytes(bytes(data))


def _flip_page(path: Path) -> None:
    """Flip one bit in the last byte of the ``key`` column's chunk: page data, under the page's CRC."""
    import pyarrow.parquet as pq

    column = pq.ParquetFile(path).metadata.row_group(0).column(0)  # "key"
    start = column.dictionary_page_offset or column.data_page_offset
    data = bytearray(path.read_bytes())
    data[start + column.total_compressed_size - 1] ^= 0x10
    path.write_bytes(bytes(data))


# ----------------------------------------------------------------------------- results
def _result(n: int = 200) -> SimulationResult:
    rng = np.random.default_rng(5)
    return SimulationResult(
        t=1e-3 * np.arange(n),
        camera_pose=np.tile(np.eye(4), (n, 1, 1)),
        camera_pose_target=np.eye(4),
        features=rng.normal(size=(n, 9)),
        feature_target=np.zeros(9),
        visible=np.ones((n, 3), bool),
        signals={"q": rng.normal(size=(n, 6))},  # random: the largest compressed member
        metadata={"scenario": "x"},
    )


def _npz_with(path: Path, header: str | None, arrays: dict[str, np.ndarray]) -> None:
    """Replace ``path`` by an .npz of ``arrays`` with ``__metadata__`` = ``header`` (none if None)."""
    extra = {} if header is None else {"__metadata__": np.array(header)}
    with open(path, "wb") as stream:
        np.savez_compressed(stream, **extra, **arrays)


def _good_arrays(path: Path) -> dict[str, np.ndarray]:
    with np.load(path) as data:
        return {k: data[k] for k in data.files if k != "__metadata__"}


def _not_json(path: Path) -> None:
    _npz_with(path, "{format_version: 2,", _good_arrays(path))


def _no_metadata_key(path: Path) -> None:
    _npz_with(path, json.dumps({"format_version": 2}), _good_arrays(path))


def _no_header(path: Path) -> None:
    _npz_with(path, None, _good_arrays(path))


def _format_9(path: Path) -> None:
    _npz_with(path, json.dumps({"format_version": 9, "metadata": {}}), _good_arrays(path))


def _missing_arrays(path: Path) -> None:
    arrays = _good_arrays(path)
    del arrays["camera_pose"]
    _npz_with(path, json.dumps({"format_version": 2, "metadata": {}}), arrays)


def _arrays_do_not_fit(path: Path) -> None:
    arrays = _good_arrays(path)
    arrays["features"] = arrays["features"][:-1]
    _npz_with(path, json.dumps({"format_version": 2, "metadata": {}}), arrays)


def _v1_without_tau(path: Path) -> None:
    """A format-1 file (tests/regression/result_v1.npz) missing one of its joint signals."""
    with np.load(V1) as data:
        arrays = {k: data[k] for k in data.files if k not in ("__metadata__", "tau")}
        header = str(data["__metadata__"])
    _npz_with(path, header, arrays)


def _changed(change):
    """A damage that rewrites the arrays and header of a whole result with ``change(arrays, header)``."""

    def damage(path: Path) -> None:
        with np.load(path) as data:
            arrays = {k: data[k] for k in data.files if k != "__metadata__"}
            header = json.loads(str(data["__metadata__"]))
        change(arrays, header)
        _npz_with(path, json.dumps(header), arrays)

    return damage


def _set(name, index, value):
    def change(arrays, header):
        arrays[name][index] = value

    return change


def _visible_as_text(arrays, header):
    arrays["visible"] = arrays["visible"].astype(str)


def _unknown_status(arrays, header):
    header["metadata"]["status"] = "finished"


RESULT_DAMAGE = {
    "empty": (_empty, "empty (0 bytes)"),
    "truncated": (_truncate, "not a whole zip archive"),
    "random bytes": (_random_bytes, "not an .npz (zip) archive"),
    "flipped byte": (_flip_npz, "corrupted"),
    "directory": (_directory, "a directory"),
    "header not JSON": (_not_json, "its header is not JSON"),
    "header lacks metadata": (_no_metadata_key, "no 'metadata' object"),
    "no header": (_no_header, "no __metadata__ entry"),
    "format version 9": (_format_9, "format version 9"),
    "missing arrays": (_missing_arrays, "missing the arrays ['camera_pose']"),
    "arrays do not fit": (_arrays_do_not_fit, "its arrays do not form a result"),
    "format 1 missing a signal": (_v1_without_tau, "missing the arrays ['tau'] (format 1)"),
    # whole archives holding what no run records
    "NaN pose": (_changed(_set("camera_pose", (7, 0, 3), np.nan)), "field 'camera_pose': sample 7"),
    "non-rigid pose": (
        _changed(_set("camera_pose", (7, 0, 0), 2.0)),
        "field 'camera_pose': sample 7 (t = 0.007 s) is not a rigid transform",
    ),
    "time running backwards": (_changed(_set("t", 50, 0.0)), "field 't' runs backwards: sample 50"),
    "strings in visible": (_changed(_visible_as_text), "field 'visible' holds <U5 values, not booleans"),
    "unknown status": (_changed(_unknown_status), "field 'metadata.status' is 'finished'"),
}


@pytest.fixture
def damaged_result(tmp_path, request):
    damage, fragment = RESULT_DAMAGE[request.param]
    path = _result().save(tmp_path / "run.npz")
    damage(path)
    return path, fragment


@pytest.mark.parametrize("damaged_result", list(RESULT_DAMAGE), indirect=True)
def test_a_damaged_result_file_is_a_typed_error_naming_it(damaged_result):
    path, fragment = damaged_result
    with pytest.raises(DamagedFileError) as info:
        SimulationResult.load(path)
    assert str(path) in str(info.value) and fragment in str(info.value)
    assert info.value.path == path and fragment in info.value.problem
    assert isinstance(
        info.value, InvalidParameterError
    )  # existing `except InvalidParameterError` still catch it


@pytest.mark.parametrize("damaged_result", list(RESULT_DAMAGE), indirect=True)
def test_view_answers_a_damaged_result_with_one_line(capsys, damaged_result):
    path, fragment = damaged_result
    code = cli.main(["view", "--result", str(path), "--no-wait"])
    _, err = capsys.readouterr()
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 1 and len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith("ibvs-youla: error: ") and str(path) in lines[0] and fragment in lines[0]


def test_view_names_a_result_without_the_arm_run_metadata(capsys, tmp_path):
    path = _result().save(tmp_path / "free.npz")  # metadata: only a scenario name
    assert cli.main(["view", "--result", str(path), "--no-wait"]) == 1
    err = capsys.readouterr().err
    assert f"{path}: its metadata has no q_start, q_target, markers_O, joint_offset, virtual_points" in err


def test_the_files_of_both_formats_still_load(tmp_path):
    assert len(SimulationResult.load(V1)) == 11
    path = _result().save(tmp_path / "run.npz")
    np.testing.assert_array_equal(SimulationResult.load(path).q, _result().q)


# ----------------------------------------------------------------------------- campaign.json
DEFINITION = CampaignDefinition(family="free-planar", cases=2, controllers=("pbvs",), seed=1, duration=1.0)


def _json_text(text: str):
    return lambda path: path.write_text(text)


DEFINITION_DAMAGE = {
    "empty": (_empty, "JSONDecodeError"),
    "truncated": (_truncate, "JSONDecodeError"),
    "random bytes": (_random_bytes, "UnicodeDecodeError"),
    "directory": (_directory, "a directory"),
    "not a definition": (_json_text("[1, 2]"), "no 'format' key"),
    "lacks the format key": (_json_text('{"family": "free-planar"}'), "no 'format' key"),
    "format 9": (_json_text('{"format": 9}'), "format 9"),
}


@pytest.fixture
def damaged_definition(tmp_path, request):
    damage, fragment = DEFINITION_DAMAGE[request.param]
    out = tmp_path / "campaign"
    storage.create_folder(out, DEFINITION.to_dict())
    damage(out / "campaign.json")
    return out, fragment


@pytest.mark.parametrize("damaged_definition", list(DEFINITION_DAMAGE), indirect=True)
def test_a_damaged_campaign_definition_is_a_typed_error_naming_it(damaged_definition):
    out, fragment = damaged_definition
    with pytest.raises(DamagedFileError) as info:
        storage.read_definition(out)
    assert str(out / "campaign.json") in str(info.value) and fragment in str(info.value)


@pytest.mark.parametrize("damaged_definition", list(DEFINITION_DAMAGE), indirect=True)
def test_the_campaign_command_answers_a_damaged_definition_with_one_line(capsys, damaged_definition):
    out, fragment = damaged_definition
    argv = ["campaign", "--family", "free-planar", "--cases", "2", "--controllers", "pbvs", "--seed", "1"]
    code = cli.main([*argv, "--duration", "1", "--workers", "0", "--no-progress", "--out", str(out)])
    _, err = capsys.readouterr()
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 1 and len(lines) == 1 and "Traceback" not in err, err
    assert str(out / "campaign.json") in lines[0] and fragment in lines[0]


# ----------------------------------------------------------------------------- Parquet parts
def _row(key: str) -> dict:
    row = {name: (0.25 if kind is float else 3 if kind is int else key) for name, kind in COLUMNS.items()}
    return {**row, "outcome": "reached", "status": "complete"}


def _foreign_parquet(path: Path) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    pq.write_table(pa.table({"key": ["a"], "speed": [1.0]}), path)


def _directory_of_parts(path: Path) -> None:
    path.unlink()
    path.mkdir()
    (path / "inner.txt").write_text("not a part")


def _rows_with(column, value):
    """A damage that rewrites a whole part with ``value`` in ``column`` of its first row."""

    def damage(path: Path) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        rows = pq.read_table(path).to_pylist()
        rows[0][column] = value
        pq.write_table(pa.Table.from_pylist(rows, schema=storage.arrow_schema()), path)

    return damage


PART_DAMAGE = {
    "empty": (_empty, "not readable as rows"),
    "truncated": (_truncate, "not readable as rows"),
    "random bytes": (_random_bytes, "not readable as rows"),
    "flipped byte": (_flip_page, "CRC"),
    "directory": (_directory_of_parts, "not readable as rows"),
    "another schema": (_foreign_parquet, "not rows of a campaign: no column family, "),
    "unknown outcome": (_rows_with("outcome", "won"), "column 'outcome' holds ['won']"),
    "unknown status": (_rows_with("status", "finished"), "column 'status' holds ['finished']"),
}


@pytest.fixture
def damaged_part(tmp_path, request):
    damage, fragment = PART_DAMAGE[request.param]
    out = tmp_path / "campaign"
    storage.create_folder(out, DEFINITION.to_dict())
    writer = storage.RowWriter(out, batch_rows=4)
    for k in range(8):  # two parts: the first stays whole, the second is damaged
        writer.add(_row(f"key{k}"))
    good, bad = writer.parts
    damage(bad)
    return out, good, bad, fragment


@pytest.mark.parametrize("damaged_part", list(PART_DAMAGE), indirect=True)
def test_a_damaged_part_is_a_typed_error_naming_it(damaged_part):
    out, _, bad, fragment = damaged_part
    with pytest.raises(DamagedFileError) as info:
        storage.read_rows(out)
    assert str(bad) in str(info.value) and fragment in str(info.value)


@pytest.mark.parametrize("damaged_part", list(PART_DAMAGE), indirect=True)
def test_campaign_report_answers_a_damaged_part_with_one_line(capsys, damaged_part):
    out, _, bad, fragment = damaged_part
    code = cli.main(["campaign-report", str(out)])
    _, err = capsys.readouterr()
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 1 and len(lines) == 1 and "Traceback" not in err, err
    assert str(bad) in lines[0] and fragment in lines[0]


@pytest.mark.parametrize("damaged_part", list(PART_DAMAGE), indirect=True)
def test_a_resuming_client_sets_a_damaged_part_aside_and_its_runs_count_as_not_stored(damaged_part):
    out, good, bad, _ = damaged_part
    assert storage.stored_keys(out) == {f"key{k}" for k in range(4)}  # the damaged part counts as no rows
    notes = storage.recover(out)
    assert len(notes) == 1 and notes[0].startswith(f"{bad}: ") and f".{bad.name}.damaged" in notes[0]
    assert not bad.exists() and (bad.parent / f".{bad.name}.damaged").exists() and good.exists()
    assert sorted(storage.read_rows(out)["key"]) == [f"key{k}" for k in range(4)]
    assert storage.recover(out) == []  # nothing left to set aside


def test_a_part_written_before_page_checksums_still_reads(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    storage.create_folder(tmp_path, DEFINITION.to_dict())
    table = pa.Table.from_pylist([_row("old")], schema=storage.arrow_schema())
    buffer = io.BytesIO()
    pq.write_table(table, buffer, compression="zstd")  # no page CRC, as the first campaigns wrote
    (tmp_path / "rows" / "part-old.parquet").write_bytes(buffer.getvalue())
    assert list(storage.read_rows(tmp_path)["key"]) == ["old"] and storage.recover(tmp_path) == []


def test_a_copy_of_a_whole_part_is_not_damaged(tmp_path):
    storage.create_folder(tmp_path, DEFINITION.to_dict())
    writer = storage.RowWriter(tmp_path, batch_rows=1)
    writer.add(_row("a"))
    shutil.copy(writer.parts[0], tmp_path / "rows" / "part-copy.parquet")
    assert storage.recover(tmp_path) == [] and list(storage.read_rows(tmp_path)["key"]) == ["a", "a"]


def test_a_resumed_campaign_reruns_only_the_runs_of_a_damaged_part_and_says_so(tmp_path, caplog):
    import logging

    from ibvs_youla.campaign.runner import run_campaign

    out = tmp_path / "campaign"
    first = run_campaign(DEFINITION, out, workers=0, progress=False, batch_rows=1)  # one part per run
    assert (first.runs, first.ran) == (2, 2)
    rows = storage.read_rows(out).set_index("key").sort_index()
    lost, kept = sorted((out / "rows").glob("part-*.parquet"))
    _truncate(lost)
    with caplog.at_level(logging.WARNING, logger="ibvs_youla.campaign.runner"):
        again = run_campaign(DEFINITION, out, workers=0, progress=False)
    notes = [r.getMessage() for r in caplog.records]
    assert len(notes) == 1 and notes[0].startswith(f"ibvs-youla: {lost}: not readable as rows")
    assert (again.stored_before, again.ran) == (1, 1) and kept.exists()  # only the lost run ran again
    back = storage.read_rows(out).set_index("key").sort_index()
    assert list(back.index) == list(rows.index)
    assert back.drop(columns=["wall_s", "update_median_us", "update_p95_us"]).equals(
        rows.drop(columns=["wall_s", "update_median_us", "update_p95_us"])
    )
    # every run stored, and a foreign file among the parts: set aside without running anything
    _random_bytes(out / "rows" / "part-foreign.parquet")
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="ibvs_youla.campaign.runner"):
        last = run_campaign(DEFINITION, out, workers=0, progress=False)
    assert (
        last.ran == 0
        and len(caplog.records) == 1
        and "part-foreign.parquet" in caplog.records[0].getMessage()
    )
    assert (out / "rows" / ".part-foreign.parquet.damaged").exists() and len(storage.read_rows(out)) == 2
