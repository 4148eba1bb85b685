"""Columns written to CSV and Parquet read back exactly with pandas' own readers."""

import numpy as np
import pandas as pd
import pytest

from chronofuse.io.tables import write_table


@pytest.mark.parametrize("name", ["sub/x.csv", "sub/x.parquet"])
def test_columns_written_read_back_exactly_with_pandas(tmp_path, name):
    rng = np.random.default_rng(5)
    columns = {"t_s": np.arange(50.0), "x_s": rng.standard_normal(50) * 1e-9, "fix": rng.integers(0, 2, 50)}
    path = write_table(columns, tmp_path / name)
    back = pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)
    assert list(back.columns) == list(columns)
    for key, values in columns.items():
        np.testing.assert_array_equal(back[key].to_numpy(), values)


def test_the_csv_header_is_the_plain_names(tmp_path):
    path = write_table({"t_s": np.arange(3.0), "x_s": np.zeros(3)}, tmp_path / "a.csv")
    assert path.read_text().splitlines()[0] == "t_s,x_s"
