"""Damaged recordings, at random: flipped bits and cut files. Every reading command gives the
intact file's answer, the answer for the complete episodes it says it read, or exit 2 with a
message — never another answer with exit 0, never a traceback. (The same check runs for as
many cases as asked in benchmarks/fuzz_files.py; 10 000 there, 150 here.)"""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.damaged_files import SIMB, Fuzzer

pytestmark = pytest.mark.skipif(not SIMB.is_dir(), reason=f"the paper's traces are not at {SIMB}")


@pytest.fixture(scope="module")
def fuzzer(tmp_path_factory):
    return Fuzzer(tmp_path_factory.mktemp("fuzz"), traces=3)


flips = st.lists(st.tuples(st.floats(0, 1, exclude_max=True), st.integers(0, 7)),
                 min_size=1, max_size=8)
cuts = st.floats(0, 1, exclude_max=True)


@settings(max_examples=150, deadline=None, suppress_health_check=list(HealthCheck))
@given(change=st.one_of(flips, cuts))
def test_damaged_recordings_never_give_a_wrong_answer(fuzzer, change):
    data = bytearray(fuzzer.intact)
    if isinstance(change, float):
        data = data[:int(change * len(data))]
    else:
        for where, bit in change:
            data[int(where * len(data))] ^= 1 << bit
    fuzzer.check(bytes(data))  # raises on a wrong answer or a traceback


def test_the_intact_file_and_its_prefixes_answer(fuzzer):
    assert fuzzer.check(fuzzer.intact) == {"same answer": 5}
    assert sorted(fuzzer.prefix) == [0, 1, 2, 3]
