"""A sweep's folder (docs/experiments.md, "What a sweep writes"): the manifest
``experiment.json``, the journal of finished runs (``journal/part-*.parquet``, with their
time series beside as ``series-*.parquet``) and ``results.parquet``, the journal's last row
of each run.

Every file is written to a temporary name, flushed to disk (fsync) and renamed, so a killed
sweep or a stopped machine leaves whole files only: the journal holds exactly the runs that
finished, and ``--resume`` runs the others. A journal part that cannot be read all the same
is set aside as ``journal/.part-*.parquet.torn`` when the journal is opened, so that its runs
run again (:attr:`Journal.notes` says so); temporary files a killed sweep left are deleted.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import uuid
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from pyautonomousagent.folders import sync_folder
from pyautonomousagent.inputs import InputError, load_json, read_text
from pyautonomousagent.recording import parquet_options

MANIFEST = "experiment.json"
RESULTS = "results.parquet"
JOURNAL = "journal"
RUNS = "runs"


#: The temporary files :func:`atomic_write` writes.
TEMPORARY = re.compile(r"\..+\.[0-9a-f]{32}\.tmp")


def atomic_write_table(table: pa.Table, path: Path) -> None:
    """Write ``table`` as Parquet (the run data's options) to ``path`` atomically."""
    atomic_write(path, lambda file: pq.write_table(table, file, **parquet_options(table.schema)))


def atomic_write(path: Path, write: Callable[[Path], object]) -> None:
    """Write ``path`` by ``write(temporary)`` to a temporary file, an fsync and a rename."""
    temporary = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    try:
        write(temporary)
        with open(temporary, "rb") as written:
            os.fsync(written.fileno())
        os.replace(temporary, path)
        sync_folder(path.parent)
    finally:
        temporary.unlink(missing_ok=True)


def remove_temporaries(folder: Path) -> int:
    """Delete the temporary files a killed writer left in ``folder``; how many."""
    removed = 0
    with contextlib.suppress(OSError):
        for path in folder.iterdir():
            if TEMPORARY.fullmatch(path.name) and path.is_file():
                path.unlink(missing_ok=True)
                removed += 1
    return removed


def column_type(values: Sequence[Any]) -> pa.DataType:
    """The Arrow type of a parameter's values: bool, int64, float64 or string."""
    if all(isinstance(v, bool) for v in values):
        return pa.bool_()
    if all(isinstance(v, int) and not isinstance(v, bool) for v in values):
        return pa.int64()
    if all(isinstance(v, int | float) and not isinstance(v, bool) for v in values):
        return pa.float64()
    return pa.string()


#: Units and descriptions of the results' own columns (field metadata of results.parquet).
RESULT_DOCS: dict[str, tuple[str, str]] = {
    "run": ("", "the run's position in the experiment's run list (0-based)"),
    "run_id": ("", "a stable key of the run's point and seed"),
    "seed": ("", "the run's seed"),
    "status": ("", "ok, or failed (the error column says why)"),
    "error": ("", "the first line of the error of a failed run"),
    "seconds": ("s", "wall-clock time of the run on its worker"),
    "engine": ("", "the decision engine the run used (auto's choice, where auto)"),
}


def results_schema(
    parameters: Mapping[str, Sequence[Any]],
    measures: Sequence[str],
    constants: Mapping[str, Any] | None = None,
    *,
    types: Mapping[str, pa.DataType] | None = None,
    docs: Mapping[str, tuple[str, str]] | None = None,
) -> pa.Schema:
    """The results' columns: run, run_id, each varied parameter, seed, each measure, status,
    error, seconds, engine, then each parameter the experiment does not vary
    (``constants``), so that every run's row holds all its parameters.

    Args:
        parameters: each varied parameter's values.
        measures: the measures' names.
        constants: the parameters not varied, name -> value.
        types: a parameter's column type by its declared type (a float parameter varied as
            ``20:50:10`` is float64); else the type of its values (:func:`column_type`).
        docs: name -> (unit, description) of parameters and measures, written with
            :data:`RESULT_DOCS` as each field's metadata (``unit``, ``description``).
    """
    types = types or {}

    def typed(name: str, values: Sequence[Any]) -> pa.Field:
        return pa.field(name, types.get(name) or column_type(values))

    fields = [pa.field("run", pa.int64()), pa.field("run_id", pa.string())]
    fields += [typed(name, values) for name, values in parameters.items()]
    fields.append(pa.field("seed", pa.int64()))
    fields += [pa.field(name, pa.float64()) for name in measures]
    fields += [
        pa.field("status", pa.string()),
        pa.field("error", pa.string()),
        pa.field("seconds", pa.float64()),
        pa.field("engine", pa.string()),
    ]
    taken = {f.name for f in fields}
    for name, value in (constants or {}).items():
        if name not in taken:
            fields.append(typed(name, [value]))
    return described(fields, {**RESULT_DOCS, **(docs or {})})


def described(fields: Iterable[pa.Field], docs: Mapping[str, tuple[str, str]]) -> pa.Schema:
    """A schema of ``fields``, each with metadata ``unit`` and ``description`` from ``docs``
    (name -> (unit, description); empty for a name it lacks)."""
    keys = ("unit", "description")
    return pa.schema(
        [f.with_metadata(dict(zip(keys, docs.get(f.name, ("", "")), strict=True))) for f in fields]
    )


class Journal:
    """The finished runs of a sweep folder, appended in batches of whole files.

    Args:
        out: the sweep folder.
        schema: the results' schema (:func:`results_schema`).
    """

    def __init__(self, out: Path, schema: pa.Schema) -> None:
        self.folder = out / JOURNAL
        self.folder.mkdir(parents=True, exist_ok=True)
        self.schema = schema
        self.buffer: list[dict[str, Any]] = []
        #: The held runs' time series (:mod:`pyautonomousagent.experiments.series`).
        self.series: list[pa.Table] = []
        #: What opening the journal repaired, one line each (torn parts set aside...).
        self.notes: list[str] = []
        self._check_parts()
        parts = self.parts() + sorted(self.folder.glob(".part-*.parquet.torn"))
        numbers = [int(p.name.split("-")[1].split(".")[0]) for p in parts]
        self.next_part = max(numbers) + 1 if numbers else 0

    def parts(self) -> list[Path]:
        """The journal's files, in the order they were written."""
        return sorted(self.folder.glob("part-*.parquet"))

    def _check_parts(self) -> None:
        """Read every part; one that cannot be read is set aside, with a note."""
        removed = remove_temporaries(self.folder)
        if removed:
            self.notes.append(f"removed {removed} temporary file(s) a stopped sweep left")
        for path in self.parts():
            try:
                self._read_part(path)
            except (pa.ArrowException, OSError, ValueError, KeyError) as error:
                aside = path.with_name(f".{path.name}.torn")
                os.replace(path, aside)
                reason = str(error).splitlines()[0][:120] if str(error) else type(error).__name__
                self.notes.append(
                    f"journal part {path} cannot be read ({reason}): set aside as {aside.name}, "
                    "its runs run again"
                )

    def _read_part(self, path: Path) -> pa.Table:
        """A part, as the schema says; a column an older version did not write (``engine``)
        is null."""
        table = pq.read_table(path)
        for name in self.schema.names:
            if name not in table.column_names and name in RESULT_DOCS:
                table = table.append_column(name, pa.nulls(table.num_rows, pa.string()))
        return table.select(self.schema.names).cast(self.schema)

    def read(self) -> pa.Table:
        """Every row written so far (flushed), in journal order."""
        tables = [self._read_part(p) for p in self.parts()]
        return pa.concat_tables(tables) if tables else self.schema.empty_table()

    def append(self, row: Mapping[str, Any], series: pa.Table | None = None) -> None:
        """Hold ``row`` (and the run's time series, if any) until the next :meth:`flush`."""
        self.buffer.append(dict(row))
        if series is not None:
            self.series.append(series)

    def flush(self) -> None:
        """Write the held rows as the next part (nothing if none are held); the held time
        series first, as ``series-N.parquet`` beside ``part-N.parquet``, so a part's runs
        never lack their series."""
        if not self.buffer:
            return
        if self.series:
            series = self.folder / f"series-{self.next_part:06d}.parquet"
            atomic_write_table(pa.concat_tables(self.series), series)
        rows = [{name: row.get(name) for name in self.schema.names} for row in self.buffer]
        table = pa.Table.from_pylist(rows, schema=self.schema)
        atomic_write_table(table, self.folder / f"part-{self.next_part:06d}.parquet")
        self.next_part += 1
        self.buffer, self.series = [], []

    def finished(self) -> set[str]:
        """The run_ids whose latest row has status "ok"."""
        latest = last_row_per_run(self.read())
        ok = pc.equal(latest["status"], "ok")
        return set(latest.filter(ok)["run_id"].to_pylist())


def last_row_per_run(table: pa.Table) -> pa.Table:
    """For each run_id, its last row in ``table``; sorted by ``run``."""
    if table.num_rows == 0:
        return table
    ids = table["run_id"].to_pylist()
    last = {run_id: i for i, run_id in enumerate(ids)}
    kept = table.take(pa.array(sorted(last.values()), pa.int64()))
    return kept.sort_by("run")


#: Largest manifest read, bytes (it names the experiment, not each run).
MAX_MANIFEST_BYTES = 50_000_000


def read_manifest(out: Path) -> dict[str, Any] | None:
    """The folder's manifest, or None if there is none.

    Raises:
        InputError: the manifest is unreadable, too large, not JSON or not a JSON object.
    """
    path = out / MANIFEST
    if not path.exists():
        return None
    data = load_json(read_text(path, "sweep manifest", MAX_MANIFEST_BYTES), str(path))
    if not isinstance(data, dict):
        raise InputError(f"{path}: the sweep manifest must be a JSON object; run the sweep again")
    return data


def write_manifest(out: Path, manifest: Mapping[str, Any]) -> Path:
    """Write the manifest (pretty JSON) atomically."""
    path = out / MANIFEST
    text = json.dumps(manifest, indent=2, default=str) + "\n"
    atomic_write(path, lambda file: file.write_bytes(text.encode()))
    return path
