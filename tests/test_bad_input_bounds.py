"""validation's magnitude bounds: NaN-proof, overflow-proof, naming the entry and the bound."""

import math

import numpy as np
import pytest

from drake_sot.validation import magnitude, position, within


def test_the_bound_helpers_are_nan_proof_and_name_the_entry():
    for bad in ([math.nan, 0.0, 0.0], [math.inf, 0.0, 0.0]):
        with pytest.raises(ValueError, match="NaN or Inf"):
            position("p", bad)
    with pytest.raises(
        ValueError, match=r"v = \[1, -20001\]: entry \[1\] = -20001: every entry must be within ±10000"
    ):
        magnitude("v", [1.0, -20001.0], 1e4)
    with pytest.raises(ValueError, match=r"q: b = 3: must be in \[-1, 2\]"):
        within("q", [0.0, 3.0], [-1.0, -1.0], [2.0, 2.0], labels=["a", "b"])
    with pytest.raises(ValueError, match="NaN or Inf"):
        within("q", [math.nan], [-1.0], [1.0])
    np.testing.assert_array_equal(position("p", [0.0, 0.0, 10.0]), [0.0, 0.0, 10.0])


def test_a_position_of_huge_entries_is_refused_with_its_true_distance_not_an_overflow():
    with pytest.raises(ValueError, match=r"1\.41421e\+200 m from the world origin"):
        position("p", [1e200, 1e200, 0.0])
