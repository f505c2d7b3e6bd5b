"""The recorder of a run: rows gathered in chunks, kept in memory or streamed to disk.

:class:`Recorder` keeps the chunks in memory (the library use: ``master.run`` returns a frame);
:class:`StreamingRecorder` appends each full chunk to ``timeseries.csv`` and
``timeseries.parquet`` as the run goes, so a run holds at most one chunk of rows, and what was
recorded before a failure or an interrupt is on disk already.  Both give the recorded rows back as
a DataFrame with :meth:`frame`.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

CHUNK_ROWS = 20_000  # rows per chunk: about 4 MB of Python floats for 24 columns
FILES = ("timeseries.csv", "timeseries.parquet")


class Recorder:
    """Rows ``[time, values...]`` in the order of ``columns``, in memory.

    ``keep``: indices of the row entries to record (None: all), chosen once so the stepping loop
    appends whole rows and the recorder drops what is not wanted per chunk, not per row.
    """

    def __init__(self, columns, keep=None, chunk_rows=CHUNK_ROWS):
        self._all = list(columns)
        self._keep = None if keep is None else list(keep)
        self.columns = self._all if keep is None else [self._all[i] for i in keep]
        self.rows = []  # the current chunk; the stepping loop appends to it
        self._chunk_rows = chunk_rows
        self._chunks = []
        self.n_rows = 0

    def append(self, row):
        self.rows.append(row)
        if len(self.rows) >= self._chunk_rows:
            self.flush()

    def _chunk_frame(self):
        df = pd.DataFrame(self.rows, columns=self._all)
        return df if self._keep is None else df[self.columns]

    def flush(self):
        if self.rows:
            self._write(self._chunk_frame())
            self.n_rows += len(self.rows)
            self.rows = []

    def _write(self, df):
        self._chunks.append(df)

    def close(self):
        self.flush()

    def frame(self):
        """Every recorded row (after :meth:`close`)."""
        if not self._chunks:
            return pd.DataFrame(columns=self.columns, dtype=float)
        if len(self._chunks) > 1:
            self._chunks = [pd.concat(self._chunks, ignore_index=True)]  # once
        return self._chunks[0]


class StreamingRecorder(Recorder):
    """A :class:`Recorder` that appends each chunk to ``directory/timeseries.{csv,parquet}``.

    The files are created (empty, with the header) by the constructor, so an unwritable directory
    is found before the run starts.
    """

    def __init__(self, columns, directory, keep=None, chunk_rows=CHUNK_ROWS):
        super().__init__(columns, keep, chunk_rows)
        import pyarrow as pa
        import pyarrow.parquet as pq

        self.directory = Path(directory)
        self.csv_path = self.directory / FILES[0]
        self.parquet_path = self.directory / FILES[1]
        self._pa = pa
        self._csv = open(self.csv_path, "w", newline="")  # noqa: SIM115 - closed in close()
        self._csv.write(",".join(self.columns) + "\n")
        self._csv.flush()
        schema = pa.schema([(c, pa.float64()) for c in self.columns])
        self._parquet = pq.ParquetWriter(self.parquet_path, schema)
        self._closed = False

    def _write(self, df):
        df.to_csv(self._csv, header=False, index=False, lineterminator="\n")
        self._csv.flush()
        self._parquet.write_table(self._pa.Table.from_pandas(df.astype(float), preserve_index=False))

    def close(self):
        if self._closed:
            return
        try:
            self.flush()
        finally:
            self._closed = True
            self._csv.close()
            self._parquet.close()

    def frame(self, columns=None):
        """The recorded rows read back from the Parquet file (``columns``: only those)."""
        return pd.read_parquet(self.parquet_path, columns=columns)
