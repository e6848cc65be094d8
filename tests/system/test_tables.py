"""Time tables (modelicagym/system/table.py): CSV and MAT files read into columns, refused in one
line when they cannot be a table, interpolated as numpy's interp with the ends held."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.io import savemat

from modelicagym.errors import DataError
from modelicagym.system.table import TableInstance, read_table


def test_a_mat_table_of_named_vectors_or_one_matrix(tmp_path):
    named = tmp_path / "named.mat"
    savemat(named, {"time": np.array([0.0, 1.0, 2.0]), "wind": np.array([1.0, 3.0, 2.0])})
    table = read_table(named)
    assert list(table.columns) == ["wind"] and table.times.tolist() == [0.0, 1.0, 2.0]
    matrix = tmp_path / "matrix.mat"
    savemat(matrix, {"tab1": np.array([[0.0, 5.0, 6.0], [10.0, 7.0, 8.0]])})
    assert {name: column.tolist() for name, column in read_table(matrix).columns.items()} == {
        "y1": [5.0, 7.0], "y2": [6.0, 8.0]}


@pytest.mark.parametrize("text, message", [
    ("time,a\n0,1\n0,2\n", "time must be finite and strictly increasing; row 2 breaks it"),
    ("time,a\n0,1\n1,x\n", "not a number"),
    ("time,a\n", "needs a header row"),
    ("time,a\n0,1,2\n", "every row needs 2 values"),
])
def test_a_csv_that_is_no_table_is_refused_in_one_line(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(DataError, match=message) as caught:
        read_table(path)
    assert "\n" not in str(caught.value) and "bad.csv" in str(caught.value)


def test_values_are_interpolated_and_held_past_the_ends(tmp_path):
    path = tmp_path / "profile.csv"
    path.write_text("# a flight profile\ntime,altitude\n0,0\n10,1000\n20,1500\n")
    table = TableInstance(read_table(path), "profile", ["altitude"], start_time=-5.0)
    table.reset({"time_offset": 0.0})
    seen = [float(table.outputs.views["altitude"])]
    for _ in range(6):
        table.step(5.0)
        seen.append(float(table.outputs.views["altitude"]))
    assert seen == [0.0, 0.0, 500.0, 1000.0, 1250.0, 1500.0, 1500.0]
    table.reset({"time_offset": 12.5})
    assert float(table.outputs.views["altitude"]) == np.interp(7.5, [0, 10, 20], [0, 1000, 1500])
