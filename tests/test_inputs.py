"""Reading the files a user names: every way it fails is an InputError naming the file."""

from __future__ import annotations

import pytest

from tracecheck.errors import InputError
from tracecheck.inputs import read_json, read_text


def test_read_text_errors(tmp_path):
    with pytest.raises(InputError, match="no such model file: "):
        read_text(tmp_path / "none.mch", "model file")
    with pytest.raises(InputError, match="is a folder, not a file"):
        read_text(tmp_path, "model file")
    binary = tmp_path / "b.mch"
    binary.write_bytes(b"\xff\xfe\x00")
    with pytest.raises(InputError, match="cannot read the model file"):
        read_text(binary, "model file")


def test_read_json_names_line_and_column_and_refuses_nan(tmp_path):
    path = tmp_path / "s.json"
    path.write_text('{"x":\n  NaN}')
    with pytest.raises(InputError) as info:
        read_json(path, "state file")
    assert info.value.message == ("not valid JSON: NaN and Infinity are not JSON numbers, and "
                                  "B reals are finite")
    assert (info.value.file, info.value.line, info.value.column) == (str(path), 2, 3)
    path.write_text('{"x": [1, 2]}')
    assert read_json(path, "state file") == {"x": [1, 2]}
