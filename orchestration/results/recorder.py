"""The recorder of a run: rows gathered in chunks, kept in memory or streamed to disk.

:class:`Recorder` keeps the chunks in memory (the library use: ``master.run`` returns a frame);
:class:`StreamingRecorder` appends each full chunk to ``timeseries.csv`` and
``timeseries.parquet`` as the run goes, so a run holds at most one chunk of rows, and what was
recorded before a failure or an interrupt is on disk already.  Both give the recorded rows back as
a DataFrame with :meth:`frame`.

The record levels of a scenario (``record: {level: ...}``) are made here too: an ``observer``
(a function of each full chunk, every row and column, before anything is dropped: the metrics
computed as the run goes, :mod:`orchestration.results.running`) and ``every`` (keep one row of
``every``: level ``decimated``); :class:`MetricsOnly` keeps no row at all (level ``metrics``).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from orchestration.results import atomic

CHUNK_ROWS = 20_000  # rows per chunk: about 4 MB of Python floats for 24 columns
METRICS_CHUNK_ROWS = 1_000  # rows per chunk of MetricsOnly
STREAM_CHUNK_ROWS = 2_000  # rows per chunk of StreamingRecorder: the rows as Python objects stay small
PARQUET_ROWS = 5_000  # rows per Parquet row group (StreamingRecorder gathers its chunks as arrays)
FILES = ("timeseries.csv", "timeseries.parquet")


class Recorder:
    """Rows ``[time, values...]`` in the order of ``columns``, in memory.

    ``keep``: indices of the row entries to record (None: all), chosen once so the stepping loop
    appends whole rows and the recorder drops what is not wanted per chunk, not per row.  Each full
    chunk becomes one float64 array (rows x kept columns); pandas is imported only by :meth:`frame`.
    The stepping loop appends its rows to :attr:`rows` itself and calls :meth:`flush` every
    :attr:`chunk_rows` rows (no method call per row); :meth:`flush` empties :attr:`rows` in place, so
    the list stays the same object for the whole run.

    Raw rows (the fmpy master's path, :meth:`raw_rows`): the loop appends each row's bytes to
    :attr:`raw` instead (the FMUs' ctypes value arrays copied as they are: no Python float per value),
    and each chunk is decoded at once by numpy; the values are the same floats as the tuple rows'.
    """

    def __init__(self, columns, keep=None, chunk_rows=CHUNK_ROWS, observer=None, every=1):
        self._all = list(columns)
        self._keep = None if keep is None else list(keep)
        self.columns = self._all if keep is None else [self._all[i] for i in keep]
        self.rows = []  # the current chunk; the stepping loop appends to it
        self.chunk_rows = chunk_rows
        self._chunks = []
        self.n_rows = 0  # rows kept (written)
        self.n_seen = 0  # rows the loop gave (the observer saw them all)
        self.observer = observer  # None, or a function of each chunk (rows x all columns)
        self.every = max(1, int(every))
        self._skip = 0  # rows to drop before the next kept one (every > 1)
        self.raw = None  # bytearray of raw rows (raw_rows), else None
        self._raw_dtype = self._raw_fields = self._raw_order = None

    def raw_rows(self, layout, order=None):
        """Take rows as bytes from now on and return the ``bytearray`` the loop extends with each
        row: ``layout`` lists the row's segments as ``(numpy type, count)``, e.g.
        ``(("<f8", 35), ("<i4", 4), ("<f8", 3))``; integer and boolean values are stored as float64
        (a boolean byte as 0.0 or 1.0) like every column.  ``order``: None (the values are in column
        order), or for each column the position of its value in the raw row.  :meth:`flush` empties
        it in place."""
        layout = [(np.dtype(t), int(n)) for t, n in layout if int(n) > 0]
        width = sum(n for _, n in layout)
        if width != len(self._all):
            raise ValueError(f"raw row layout of {width} values for {len(self._all)} columns")
        if order is not None and sorted(order) != list(range(width)):
            raise ValueError("raw row order: not a permutation of the columns")
        self._raw_order = None if order is None or list(order) == list(range(width)) else np.asarray(order)
        self._raw_fields = [(f"f{i}", t, n) for i, (t, n) in enumerate(layout)]
        self._raw_dtype = np.dtype([(name, t, (n,)) for name, t, n in self._raw_fields])
        self.raw = bytearray()
        return self.raw

    def _current(self):
        """The rows of the current chunk as a float64 array (rows x all columns)."""
        if self.raw is None:
            return np.array(self.rows, dtype=float).reshape(len(self.rows), len(self._all))
        rec = np.frombuffer(self.raw, dtype=self._raw_dtype)
        a = np.empty((len(rec), len(self._all)))
        col = 0
        for name, t, n in self._raw_fields:
            a[:, col:col + n] = (rec[name] != 0) if t.kind == "b" else rec[name]
            col += n
        return a if self._raw_order is None else a[:, self._raw_order]

    def _clear(self):
        self.rows.clear()
        if self.raw is not None:
            del self.raw[:]

    def _has_rows(self):
        return bool(self.rows) or bool(self.raw)

    def append(self, row):
        self.rows.append(row)
        if len(self.rows) >= self.chunk_rows:
            self.flush()

    def _chunk_array(self):
        a = self._current()
        self.n_seen += len(a)
        if self.observer is not None:
            self.observer(a)
        if self.every > 1:  # one row of every `every`, counted across the chunks
            first = self._skip
            self._skip = (first - len(a)) % self.every
            a = a[first::self.every]
        return a if self._keep is None else a[:, self._keep]

    def append_rows(self, rows):
        """Rows given as one float array (rows x columns), recorded as if appended one by one: the
        rows pending are flushed first, then the array goes through as a chunk of its own (the
        observer, ``every``, ``keep``).  For an engine that hands its rows over in blocks."""
        self.flush()
        if len(rows):
            pending, self.rows = self.rows, rows  # _chunk_array reads self.rows
            try:
                chunk = self._chunk_array()
            finally:
                self.rows = pending
            if len(chunk):
                self._write(chunk)
            self.n_rows += len(chunk)

    def flush(self):
        if self._has_rows():
            chunk = self._chunk_array()
            if len(chunk):
                self._write(chunk)
            self.n_rows += len(chunk)
            self._clear()

    def _write(self, chunk):
        self._chunks.append(chunk)

    def close(self):
        self.flush()

    def arrays(self, columns=None):
        """``{column: float64 array}`` of every recorded row (after :meth:`close`); ``columns``:
        only those.  No pandas."""
        if len(self._chunks) > 1:
            self._chunks = [np.concatenate(self._chunks)]  # once
        a = self._chunks[0] if self._chunks else np.empty((0, len(self.columns)))
        index = {c: i for i, c in enumerate(self.columns)}
        return {c: a[:, index[c]] for c in (self.columns if columns is None else columns)}

    def frame(self):
        """Every recorded row (after :meth:`close`) as a DataFrame."""
        import pandas as pd

        return pd.DataFrame(self.arrays(), columns=self.columns, dtype=float)


def csv_text(chunk):
    """The CSV lines of a float array, as pandas' ``to_csv`` writes them (shortest round-trip
    ``repr`` of each value, an empty field for NaN), in one pass of precomputed formatting."""
    fmt = ",".join(["%r"] * chunk.shape[1]) + "\n"
    rows = chunk.tolist()
    if np.isnan(chunk).any():
        return "".join([",".join("" if v != v else repr(v) for v in r) + "\n" for r in rows])
    return "".join([fmt % tuple(r) for r in rows])


def _numpy(column):
    """A float64 array of a pyarrow column (no pandas: ChunkedArray.to_numpy imports it)."""
    if column.num_chunks == 0:
        return np.empty(0)
    return np.concatenate([np.frombuffer(c.buffers()[1], np.float64, len(c), 8 * c.offset) if not c.null_count
                           else c.to_numpy(zero_copy_only=False) for c in column.chunks])


def read_arrays(path, columns=None):
    """``{column: float64 array}`` of a Parquet file of float64 columns (``columns``: only those)."""
    import pyarrow.parquet as pq

    with pq.ParquetFile(path) as f:  # not read_table: pyarrow.dataset imports pandas
        table = f.read(columns=columns)
    return {c: _numpy(table.column(c)) for c in table.column_names}


def read_every(path, step=1):
    """``{column: float64 array}`` of every ``step``-th row of a Parquet file of float64 columns,
    read one row group at a time (memory: one row group, and the rows kept; Arrow's allocator is
    told to give back what it no longer uses after each group, else it keeps it)."""
    if step <= 1:
        return read_arrays(path)
    import pyarrow as pa
    import pyarrow.parquet as pq

    parts, skip = {}, 0
    with pq.ParquetFile(path) as f:
        for i in range(f.num_row_groups):
            table = f.read_row_group(i, use_threads=False)
            for c in table.column_names:
                parts.setdefault(c, []).append(_numpy(table.column(c))[skip::step].copy())
            skip = (skip - table.num_rows) % step
            del table
            pa.default_memory_pool().release_unused()
        names = f.schema_arrow.names
    return {c: np.concatenate(parts[c]) if parts.get(c) else np.empty(0) for c in names}


class StreamingRecorder(Recorder):
    """A :class:`Recorder` that appends each chunk to ``directory/timeseries.{csv,parquet}``.

    The files are created (empty, with the header) by the constructor, so an unwritable directory
    is found before the run starts.  Chunks are small (:data:`STREAM_CHUNK_ROWS` rows: the rows as
    Python objects are the bulk of a run's memory) and go to the CSV file at once; the Parquet file
    gets them in row groups of :data:`PARQUET_ROWS` rows, gathered as float64 arrays (2 MB for 45
    columns), and the last one at :meth:`close`.
    They are written under temporary names
    (:mod:`orchestration.results.atomic`) and renamed by :meth:`close` when complete; a write that
    fails (a full disk) raises, sets :attr:`error` and removes both.
    """

    #: None, or a function ``on_parquet(n_rows)`` called by :meth:`close` once the Parquet file is
    #: complete, before the last chunk's CSV lines are written: the figure helper
    #: (:mod:`orchestration.results.figure_process`) reads it and draws while the CSV is written
    on_parquet = None

    def __init__(self, columns, directory, keep=None, chunk_rows=STREAM_CHUNK_ROWS, observer=None, every=1):
        super().__init__(columns, keep, chunk_rows, observer, every)
        self._pending, self._pending_rows = [], 0  # chunks not yet in the Parquet file
        import pyarrow as pa
        import pyarrow.parquet as pq

        self.directory = Path(directory)
        self.csv_path = self.directory / FILES[0]
        self.parquet_path = self.directory / FILES[1]
        self.error = None  #: the OSError that stopped the writing (a full disk...), None while all is written
        self._pa = pa
        self._csv = self._parquet = None
        self._parts = [atomic.partial_path(self.csv_path), atomic.partial_path(self.parquet_path)]
        self._closed = False
        try:
            self._csv = open(self._parts[0], "w", newline="")  # noqa: SIM115 - closed in close()
            self._csv.write(",".join(self.columns) + "\n")
            self._csv.flush()
            self._schema = pa.schema([(c, pa.float64()) for c in self.columns])
            self._parquet = pq.ParquetWriter(self._parts[1], self._schema)
        except OSError as exc:
            self._fail(exc, self.directory)
            raise

    def _write(self, chunk):
        if self.error is not None:  # pragma: no cover - the run stopped at the first failure
            raise self.error
        path = self.csv_path
        try:
            self._write_csv(chunk)
            self._pending.append(chunk)
            self._pending_rows += len(chunk)
            if self._pending_rows >= PARQUET_ROWS:
                path = self.parquet_path
                self._flush_parquet()
        except OSError as exc:  # the run stops here (its caller sees the exception)
            self._fail(exc, path)
            raise

    def _flush_parquet(self):
        if self._pending:
            pending = self._pending
            self._write_parquet(pending[0] if len(pending) == 1 else np.concatenate(pending))
            self._pending, self._pending_rows = [], 0
            self._pa.default_memory_pool().release_unused()  # Arrow's allocator keeps freed memory else

    def _fail(self, exc, path=None):
        """Writing ``path`` failed: nothing half-written is left (the temporary files are removed)."""
        if path is not None and getattr(exc, "filename", None) is None:
            exc.filename = str(path)  # the file's name, not its temporary one
        self.error = exc
        self._closed = True
        for f in (self._csv, self._parquet):
            try:
                f is not None and f.close()
            except OSError:
                pass
        for p in self._parts:
            atomic.discard(p)

    def _write_csv(self, chunk):
        self._csv.write(csv_text(chunk))
        self._csv.flush()

    def _write_parquet(self, chunk):
        pa = self._pa  # columns from their buffers: pa.array would import pandas (~0.3 s) to check types
        cols = [pa.Array.from_buffers(pa.float64(), len(chunk), [None, pa.py_buffer(np.ascontiguousarray(c))])
                for c in chunk.T]
        self._parquet.write_table(pa.Table.from_arrays(cols, schema=self._schema))

    def close(self):
        """Write the last rows and give both files their names (each renamed from its temporary
        name once complete).  Never raises OSError: a failure to write is kept in :attr:`error`
        and no file is left (a caller writing a status reads it)."""
        if self._closed:
            return
        path = self.parquet_path
        try:
            if self.on_parquet is None:
                self.flush()
                self._flush_parquet()
                self._parquet.close()
                os.replace(self._parts[1], self.parquet_path)
            else:  # the Parquet file first, complete, then the last CSV lines
                chunk = self._chunk_array() if self._has_rows() else None
                if chunk is not None and len(chunk):
                    self._pending.append(chunk)
                self._flush_parquet()
                self._parquet.close()
                os.replace(self._parts[1], self.parquet_path)
                self.on_parquet(self.n_rows + (len(chunk) if chunk is not None else 0))
                path = self.csv_path
                if chunk is not None:
                    if len(chunk):
                        self._write_csv(chunk)
                    self.n_rows += len(chunk)
                    self._clear()
            path = self.csv_path
            self._csv.close()
            os.replace(self._parts[0], self.csv_path)
            self._closed = True
        except OSError as exc:
            if self.error is None:
                self._fail(exc, path)
            for p in (self.csv_path, self.parquet_path):  # neither file of a record cut short
                atomic.discard(p)

    def arrays(self, columns=None):
        """``{column: float64 array}`` read back from the Parquet file (``columns``: only those)."""
        return read_arrays(self.parquet_path, columns)

    def frame(self, columns=None):
        """The recorded rows read back from the Parquet file (``columns``: only those)."""
        import pandas as pd

        return pd.read_parquet(self.parquet_path, columns=columns)


class MetricsOnly(Recorder):
    """Level ``metrics``: every chunk goes to the ``observer`` (the metrics computed as the run
    goes) and is dropped: nothing on disk, nothing kept; :meth:`arrays` is empty.  Its chunks are
    small (:data:`METRICS_CHUNK_ROWS`): the rows are still in the processor's cache when they are
    folded in (5 % less CPU per run than 20 000-row chunks, measured on the default scenario)."""

    def __init__(self, columns, keep=None, chunk_rows=None, observer=None, every=1):
        chunk_rows = METRICS_CHUNK_ROWS if chunk_rows is None else chunk_rows
        super().__init__(columns, keep, chunk_rows, observer, every)

    def _chunk_array(self):
        super()._chunk_array()  # the observer sees the chunk
        return np.empty((0, len(self.columns)))  # nothing kept

    def arrays(self, columns=None):
        return {c: np.empty(0) for c in (self.columns if columns is None else columns)}
