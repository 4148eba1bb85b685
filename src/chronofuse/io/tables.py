"""Writing columns of numbers to CSV or Parquet, quickly (pyarrow), for simulated truth and reports."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq


def write_table(columns: dict[str, np.ndarray], out: str | Path) -> Path:
    """Write equal-length columns (name -> (N,) array) to CSV, or Parquet for a ``.parquet`` path.

    The folder is created. The CSV has a plain header line of the names (pyarrow would quote them), then
    one row per sample. Returns the path written.
    """
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    table = pa.table(columns)
    if out.suffix == ".parquet":
        pq.write_table(table, out)
    else:
        with open(out, "wb") as fh:
            fh.write((",".join(columns) + "\n").encode())
            pacsv.write_csv(table, fh, pacsv.WriteOptions(include_header=False, quoting_style="none"))
    return out
