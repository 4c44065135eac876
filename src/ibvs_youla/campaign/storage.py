"""A campaign folder: its definition, its rows as a Parquet dataset, optional time series.

Layout of a folder ``DIR`` (only the client that runs the campaign writes it; workers return
rows and never write):

* ``DIR/campaign.json`` — the campaign's definition (family, seed, cases, controllers, plant,
  camera, duration, settings, difficulty, controller parameters), written first and atomically.
  A folder holding another definition, or holding other files and no definition, is refused
  (:class:`CampaignStorageError`) before anything is written; the same definition resumes.
* ``DIR/rows/part-<uuid>.parquet`` — the rows, one file per flushed batch, all with the schema
  :func:`arrow_schema` built from :data:`~.metrics.COLUMNS` (so a column that is empty or all
  NaN in one batch keeps its type), with a CRC per page (checked on reading). Every file here is written by
  :func:`ibvs_youla.files.atomic_write`: a hidden temporary file in the same folder
  (``.part-<uuid>.parquet.<uuid>.tmp``: skipped by pyarrow's, pandas', polars' and DuckDB's
  ``*.parquet`` discovery), flushed to disk, then renamed with :func:`os.replace`: a crash
  loses at most the rows of the batch not yet renamed, never leaves a half-written part.
  ``pandas.read_parquet(DIR + "/rows")`` reads every row.
* ``DIR/series/<key>.npz`` — optional full time series (``SimulationResult.save``, atomic too),
  one per run.
* ``DIR/.lock`` — held by the running client (:func:`ibvs_youla.files.folder_lock`: ``flock``,
  with its pid in the file), so that a second client on the same folder is refused instead
  of storing duplicate rows; the system releases it when the client dies, whatever kills it.

A resuming client (:func:`recover`, under the lock) deletes the temporary files of a killed
client and sets aside a part that does not read as rows of this schema (renamed to the hidden
``.<name>.damaged``, which no reader lists): its runs count as not stored and run again.
"""

from __future__ import annotations

import contextlib
import json
import os
import time
import uuid
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from .._validation import integer, positive
from ..exceptions import DamagedFileError, FolderLockedError, IbvsYoulaError
from ..files import LOCK_FILE, atomic_write, folder_lock, is_temporary, remove_temporaries, write_text
from .metrics import COLUMNS, LATER_COLUMNS, OUTCOMES

__all__ = [
    "DEFINITION_FILE",
    "FORMAT",
    "CampaignStorageError",
    "RowWriter",
    "arrow_schema",
    "check_folder",
    "client_lock",
    "create_folder",
    "read_definition",
    "read_rows",
    "recover",
    "save_series",
    "stored_keys",
]

DEFINITION_FILE = "campaign.json"
ROWS_DIR = "rows"
SERIES_DIR = "series"
FORMAT = 1  # version of the folder layout, stored in campaign.json
_KNOWN = {DEFINITION_FILE, ROWS_DIR, SERIES_DIR, LOCK_FILE}


class CampaignStorageError(IbvsYoulaError):
    """A folder cannot hold this campaign: another campaign's definition, other files, a busy client.

    Attributes:
        path: The campaign folder.
    """

    def __init__(self, path: Path, message: str) -> None:
        self.path = path
        super().__init__(f"{path}: {message}")


def arrow_schema() -> Any:
    """The pyarrow schema of the rows: one field per :data:`~.metrics.COLUMNS` entry, in order."""
    import pyarrow as pa

    types = {str: pa.string(), int: pa.int64(), float: pa.float64()}
    return pa.schema([(name, types[kind]) for name, kind in COLUMNS.items()])


def _canonical(definition: Mapping[str, Any]) -> dict[str, Any]:
    """The definition as stored: format first, JSON round trip (tuples to lists, keys sorted)."""
    return json.loads(json.dumps({"format": FORMAT, **definition}, sort_keys=True))


def read_definition(out_dir: str | os.PathLike[str]) -> dict[str, Any] | None:
    """The stored definition of ``out_dir``, or None when it holds none.

    Raises:
        DamagedFileError: ``campaign.json`` is a folder, is not UTF-8 JSON, or is not a
            definition (no ``format`` key, or another format than :data:`FORMAT`).
    """
    path = Path(out_dir) / DEFINITION_FILE
    if not path.exists():
        return None
    expected = f"a campaign definition of format {FORMAT} (JSON, written by 'ibvs-youla campaign')"
    if path.is_dir():
        raise DamagedFileError(path, "a directory, not a file", expected)
    try:
        stored = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        raise DamagedFileError(path, f"unreadable ({type(err).__name__}: {err})", expected) from None
    if not isinstance(stored, dict) or "format" not in stored:
        raise DamagedFileError(path, "a JSON value with no 'format' key", expected)
    if stored["format"] != FORMAT:
        raise DamagedFileError(path, f"format {stored['format']!r}", expected)
    return stored


def check_folder(out_dir: str | os.PathLike[str], definition: Mapping[str, Any]) -> bool:
    """Whether ``out_dir`` already holds this campaign (True: resume) or none yet (False); reads only.

    Raises:
        CampaignStorageError: ``out_dir`` is a file, holds another campaign's definition (the
            message names the fields that differ), or holds other files and no definition.
    """
    path = Path(out_dir)
    if path.exists() and not path.is_dir():
        raise CampaignStorageError(path, "is a file, not a campaign folder")
    stored = read_definition(path)
    if stored is None:
        names = [p.name for p in path.iterdir()] if path.is_dir() else []
        others = sorted(n for n in names if n not in _KNOWN and not is_temporary(n))
        if others:
            listed = ", ".join(others[:3]) + (", ..." if len(others) > 3 else "")
            raise CampaignStorageError(
                path, f"holds other files ({listed}) and no {DEFINITION_FILE}; give an empty or new --out"
            )
        return False
    wanted = _canonical(definition)
    if stored == wanted:
        return True
    differ = sorted(k for k in set(stored) | set(wanted) if stored.get(k) != wanted.get(k))
    detail = "; ".join(f"{k}: stored {_short(stored.get(k))}, given {_short(wanted.get(k))}" for k in differ)
    raise CampaignStorageError(
        path, f"holds another campaign ({detail}); give the same arguments to resume it, or another --out"
    )


def _short(value: Any, limit: int = 60) -> str:
    text = json.dumps(value, sort_keys=True)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def create_folder(out_dir: str | os.PathLike[str], definition: Mapping[str, Any]) -> Path:
    """Make ``out_dir/rows`` and write the definition if absent (after :func:`check_folder`)."""
    path = Path(out_dir)
    existing = check_folder(path, definition)
    (path / ROWS_DIR).mkdir(parents=True, exist_ok=True)
    if not existing:
        write_text(
            path / DEFINITION_FILE, json.dumps(_canonical(definition), indent=1, sort_keys=True) + "\n"
        )
    return path


@contextlib.contextmanager
def client_lock(out_dir: str | os.PathLike[str]) -> Iterator[None]:
    """Hold ``out_dir/.lock`` while the block runs (:func:`ibvs_youla.files.folder_lock`).

    Raises:
        CampaignStorageError: another client holds the lock (the message names its pid).
    """
    try:
        with folder_lock(out_dir):
            yield
    except FolderLockedError as err:
        holder = "another client" if err.pid is None else f"another client (pid {err.pid})"
        raise CampaignStorageError(
            Path(out_dir), f"{holder} is running this campaign (it holds {LOCK_FILE})"
        ) from None


def _parts(out_dir: str | os.PathLike[str]) -> list[Path]:
    return sorted((Path(out_dir) / ROWS_DIR).glob("part-*.parquet"))


def _read_part(part: Path, columns: list[str] | None = None) -> Any:
    """One part (its ``columns``, default all) as a pyarrow table of the rows' schema.

    Raises:
        DamagedFileError: unreadable, a page CRC that does not match, a column missing, or an
            ``outcome`` or ``status`` that no run has.
    """
    import pyarrow.parquet as pq

    expected = "a Parquet part written by a campaign client"
    try:
        names = pq.read_schema(part).names
        table = pq.read_table(
            part,
            columns=columns,
            schema=None if columns else arrow_schema(),
            page_checksum_verification=True,
        )
    except Exception as err:  # whatever pyarrow raises for a file that is not a Parquet part
        detail = " ".join(f"{type(err).__name__}: {err}".split())[:300]
        raise DamagedFileError(part, f"not readable as rows ({detail})", expected) from None
    missing = [name for name in COLUMNS if name not in names and name not in LATER_COLUMNS]
    if missing:
        listed = ", ".join(missing[:4]) + (", ..." if len(missing) > 4 else "")
        raise DamagedFileError(part, f"not rows of a campaign: no column {listed}", expected)
    from ..simulation.results import STATUSES

    for column, valid in (("outcome", OUTCOMES), ("status", (*STATUSES, "error", "timeout"))):
        if column in table.column_names:
            unknown = sorted(set(table.column(column).to_pylist()) - set(valid), key=str)
            if unknown:
                raise DamagedFileError(
                    part, f"column {column!r} holds {unknown}, not one of {', '.join(valid)}", expected
                )
    return table


def stored_keys(out_dir: str | os.PathLike[str]) -> set[str]:
    """The keys of the rows stored in ``out_dir/rows``; a part that does not read counts as no rows.

    Temporary files are ignored; :func:`recover` sets damaged parts aside.
    """
    keys: set[str] = set()
    for part in _parts(out_dir):
        with contextlib.suppress(DamagedFileError):
            keys.update(_read_part(part, ["key", "outcome", "status"]).column("key").to_pylist())
    return keys


def read_rows(out_dir: str | os.PathLike[str]) -> Any:
    """Every stored row as a pandas DataFrame with the columns of :data:`~.metrics.COLUMNS`.

    Raises:
        DamagedFileError: a part does not read as rows of this schema (it names the part).
    """
    import pyarrow as pa

    schema = arrow_schema()
    tables = [_read_part(part) for part in _parts(out_dir)]
    return (pa.concat_tables(tables) if tables else schema.empty_table()).to_pandas()


def recover(out_dir: str | os.PathLike[str]) -> list[str]:
    """Tidy what a killed client left (module docstring); return one line per file set aside.

    Only under :func:`client_lock`. Deletes temporary files in the folder, ``rows`` and
    ``series``; renames every part that does not read (whole, with the rows' schema) to
    ``rows/.<name>.damaged``, so that its runs run again.
    """
    path = Path(out_dir)
    for folder in (path, path / ROWS_DIR, path / SERIES_DIR):
        remove_temporaries(folder)
    notes = []
    for part in _parts(path):
        try:
            _read_part(part)
        except DamagedFileError as err:
            aside = part.with_name(f".{part.name}.damaged")
            os.replace(part, aside)
            notes.append(f"{part}: {err.problem}; set aside as {aside.name}, its runs run again")
    return notes


def save_series(out_dir: str | os.PathLike[str], key: str, result: Any) -> Path:
    """Write one run's :class:`~ibvs_youla.simulation.results.SimulationResult` to ``series/<key>.npz``."""
    folder = Path(out_dir) / SERIES_DIR
    folder.mkdir(exist_ok=True)
    return result.save(folder / f"{key}.npz")


class RowWriter:
    """Buffers rows and writes them as Parquet parts (module docstring), by count or by age.

    Args:
        out_dir: The campaign folder (``out_dir/rows`` must exist).
        batch_rows: Flush when this many rows wait (an integer >= 1).
        batch_seconds: Flush when the oldest waiting row is this old [s] (finite, > 0; checked by
            the caller through :meth:`seconds_until_due`, and on :meth:`add`).

    Raises:
        InvalidParameterError: ``batch_rows`` or ``batch_seconds`` out of range.
    """

    def __init__(self, out_dir: str | os.PathLike[str], batch_rows: int = 20, batch_seconds: float = 10.0):
        self.rows_dir = Path(out_dir) / ROWS_DIR
        self.batch_rows = integer(batch_rows, "batch_rows", low=1)
        self.batch_seconds = positive(batch_seconds, "batch_seconds", unit="s")
        self.written = 0  # rows written by this writer
        self.parts: list[Path] = []
        self._buffer: list[dict[str, Any]] = []
        self._since: float | None = None  # time.monotonic() of the oldest waiting row
        self._schema = arrow_schema()

    def __len__(self) -> int:
        return len(self._buffer)

    def add(self, row: Mapping[str, Any]) -> Path | None:
        """Buffer one row; flush if a batch is due; return the part written, if any."""
        if self._since is None:
            self._since = time.monotonic()
        self._buffer.append(dict(row))
        return self.flush() if self.seconds_until_due() == 0.0 else None

    def seconds_until_due(self) -> float | None:
        """Seconds until the waiting rows are due (0: now), None when no row waits."""
        if not self._buffer or self._since is None:
            return None
        if len(self._buffer) >= self.batch_rows:
            return 0.0
        return max(0.0, self.batch_seconds - (time.monotonic() - self._since))

    def flush(self) -> Path | None:
        """Write the waiting rows as one part (atomically: module docstring); None if none wait."""
        if not self._buffer:
            return None
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.Table.from_pylist(self._buffer, schema=self._schema)
        path = self.rows_dir / f"part-{uuid.uuid4().hex}.parquet"
        with atomic_write(path) as stream:
            pq.write_table(table, stream, compression="zstd", write_page_checksum=True)
        self.written += len(self._buffer)
        self.parts.append(path)
        self._buffer, self._since = [], None
        return path
